#!/usr/bin/python3
"""gonio calibrate stray through goniod: the rig's stray light read with the
sample removed, a reference naming it (--stray ID|newest), and captures
with that reference subtracting it (docs/radiometry.md, "Calibrations").

Over Modbus TCP against gonio-sim (lab, counts) the operator removes the
sample as on a real rig: gonio-sim is started again with the light trap
in the sample's place (--material trap), as it is started again with the
standard for the reference and with the sample for a capture; goniod
pauses before the first stray frame and says what to do. On goniod's
in-process simulated rig the trap is mounted by the simulator itself,
after the same pause.

- the stray frames read the stray light (above the dark, far below the
  standard), the reference names them, a metal captured with it comes
  back closer to the material alone than the same capture reduced with
  the stray light not subtracted;
- requests that mix the kinds' fields, or name a stray light of another
  dark or kind, are refused with exit 2 naming what is wrong, nothing
  created.
"""
import json
import os
import statistics
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import gonio_cal  # noqa: E402
from goniod_harness import GONIO, Daemon  # noqa: E402
from test_goniod_calibrate import STANDARD, CalibrateRig, frames  # noqa: E402

METAL = "builtin:gold-metallic-paint"


def excess(rows, dark_rows, t):
    """The mean g of rows over the mean of dark_rows at integration t, and
    its standard error."""
    dark = [float(x["g"]) for x in dark_rows if abs(float(x["integration_s"]) - t) < 1e-6 * t]
    got = [float(x["g"]) for x in rows]
    se = (statistics.pvariance(got) / len(got) + statistics.pvariance(dark) / len(dark)) ** 0.5
    return statistics.mean(got) - statistics.mean(dark), se


class CalibrateStrayTests(CalibrateRig):

    def test_stray_subtracted_through_goniod(self):
        self.start_daemon()
        d = self.calibrate("dark", "--ladder")
        self.assertEqual(d.returncode, 0, d.stderr)
        dark_id = d.stdout.strip()
        dark_rows = frames(os.path.join(self.cal_root, dark_id, "frames.csv"))

        # The operator takes the sample out: a light trap in its place.
        self.start_sim("trap")
        s = self.calibrate("stray", "--plan", "ds3", "--repeats", "4",
                           operator=self.remove_sample)
        self.assertEqual(s.returncode, 0, s.stderr)
        stray_id = s.stdout.strip()
        meta = json.load(open(os.path.join(self.cal_root, stray_id, "calibration.json")))
        self.assertEqual((meta["kind"], meta["dark"], meta["rig"], meta["frames"]),
                         ("stray", dark_id, "lab", 208))
        stray_rows = frames(os.path.join(self.cal_root, stray_id, "frames.csv"))
        # The trap reflects nothing: the stray light alone over the dark
        # (lab's floor, 0.0005/sr: about 100 ADU at 0.25 s), not the standard.
        over, se = excess(stray_rows, dark_rows, 0.25)
        sys.stderr.write("stray light through goniod: %.1f +- %.1f ADU over the dark\n"
                         % (over, se))
        self.assertGreater(over, 10 * se)
        self.assertLess(over, 500)

        self.start_sim(STANDARD)
        r = self.calibrate("reference", "--plan", "ds3", "--repeats", "8", "--stray", "newest",
                           operator=self.mount_standard)
        self.assertEqual(r.returncode, 0, r.stderr)
        ref_id = r.stdout.strip()
        ref = json.load(open(os.path.join(self.cal_root, ref_id, "calibration.json")))
        self.assertEqual((ref["dark"], ref["stray"]), (dark_id, stray_id))

        self.start_sim(METAL)
        c = self.d.gonio("capture", "--plan", "ds3", "--name", "metal", "--calibration",
                         "newest", "--wait", "--quiet")
        self.assertEqual(c.returncode, 0, c.stderr + c.stdout)
        capdir = os.path.join(self.d.root, "metal")
        rows = frames(os.path.join(capdir, "samples.csv"))
        with_stray = gonio_cal.chain_errors(rows, dark_rows, METAL)
        plain = gonio_cal.without_stray(self.cal_root, ref_id, os.path.join(self.folder, "ns"))
        without = gonio_cal.recalibrated_material_error(capdir, ref_id, plain, dark_rows, METAL,
                                                        os.path.join(self.folder, "metal-ns"))
        sys.stderr.write("%s DS3 through goniod against the material alone: stray light "
                         "subtracted %.3f %%, not subtracted %.3f %% (%d values)\n"
                         % (METAL, 100 * with_stray["material"], 100 * without,
                            with_stray["n"]))
        self.assertGreaterEqual(with_stray["n"], 50)
        self.assertLess(with_stray["material"], without - 0.0003)

    def test_refusals(self):
        self.start_daemon()
        d = self.calibrate("dark", "--frames", "2", "--name", "dark-a")
        self.assertEqual(d.returncode, 0, d.stderr)
        cases = [
            (["dark", "--stray", "newest"], "--stray is a reference's"),
            (["stray"], "a stray needs --plan"),
            (["stray", "--plan", "ds3", "--standard", "spectralon-99"],
             "field 'standard' is not a stray calibration's"),
            (["stray", "--plan", "ds3", "--stray", "newest"],
             "--stray is a reference's"),
            (["stray", "--plan", "ds3", "--frames", "3"],
             "field 'frames' is not a stray calibration's"),
            (["reference", "--plan", "ds3", "--stray", "dark-a"],
             "calibration dark-a is not a stray-light calibration"),
            (["reference", "--plan", "ds3", "--stray", "newest"],
             "no valid stray calibration"),
            (["reference", "--plan", "ds3", "--stray", "../x"], "field 'stray' '../x'"),
        ]
        for args, needle in cases:
            r = self.calibrate(*args)
            self.assertEqual(r.returncode, 2, (args, r.stderr))
            self.assertIn(needle, r.stderr, args)
        # A stray light taken with another dark does not serve the reference.
        self.start_sim("trap")
        s = self.calibrate("stray", "--plan", "ds3", "--repeats", "2", "--name", "stray-a",
                           operator=self.remove_sample)
        self.assertEqual(s.returncode, 0, s.stderr)
        self.assertEqual(self.calibrate("dark", "--frames", "2", "--name", "dark-b").returncode,
                         0)
        r = self.calibrate("reference", "--plan", "ds3", "--stray", "stray-a", "--dark", "dark-b")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("calibration stray-a was taken with dark dark-a, not the reference's "
                      "dark-b", r.stderr)
        self.assertEqual(sorted(os.listdir(self.cal_root)), ["dark-a", "dark-b", "stray-a"])

    def test_on_goniods_simulated_rig(self):
        """The sim driver mounts the light trap itself, after the same
        pause: its stray frames read what the offline calibration on the
        same scene reads."""
        self.d = Daemon(self.folder, scene="lab").start()
        self.cal_root = os.path.join(self.folder, "calibrations")
        d = self.calibrate("dark", "--frames", "64")
        self.assertEqual(d.returncode, 0, d.stderr)
        s = self.calibrate("stray", "--plan", "ds3", "--repeats", "2",
                           operator=self.remove_sample)
        self.assertEqual(s.returncode, 0, s.stderr)
        offline = os.path.join(self.folder, "offline")
        for kind in (["dark", "--frames", "64"], ["stray", "--plan", "ds3", "--repeats", "2"]):
            r = subprocess.run([GONIO, "calibrate", *kind, "--offline", "--scene", "lab",
                                "--out", offline], capture_output=True, text=True, timeout=60)
            self.assertEqual(r.returncode, 0, r.stderr)
        rows = {}
        for root, sid, did in ((self.cal_root, s.stdout.strip(), d.stdout.strip()),
                               (offline, r.stdout.strip(), None)):
            if did is None:
                did = json.load(open(os.path.join(root, sid, "calibration.json")))["dark"]
            t = float(frames(os.path.join(root, sid, "frames.csv"))[0]["integration_s"])
            rows[root] = excess(frames(os.path.join(root, sid, "frames.csv")),
                                frames(os.path.join(root, did, "frames.csv")), t)
        got, want = rows[self.cal_root], rows[offline]
        sys.stderr.write("stray light on goniod's simulated rig %.1f +- %.1f, offline %.1f +- "
                         "%.1f ADU over the dark\n" % (got + want))
        self.assertGreater(want[0], 5 * want[1])
        self.assertLess(abs(got[0] - want[0]), 4 * (got[1] ** 2 + want[1] ** 2) ** 0.5)


if __name__ == "__main__":
    unittest.main()
