#!/usr/bin/python3
"""A capture through goniod over Modbus TCP that reads its reference
standard again after the sample's points (the request's reference_after,
docs/radiometry.md "Drift"), on a rig without a sample changer: goniod
pauses after the last point asking the operator to mount the standard,
and gonio resume goes on. goniod is killed (SIGKILL) in that pause: the
sample's records stand, and a resume asks again, reads the standard and
reduces the samples with the drift between the calibration and it."""
import json
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_goniod_calibrate import (SAMPLE, STANDARD, CalibrateRig,  # noqa: E402
                                   frames, rig_profile)


def records(capdir):
    return [x for x in frames(os.path.join(capdir, "samples.csv")) if not int(x["flags"]) & 2]


class ReferenceAfterTests(CalibrateRig):

    def asks_for_the_standard(self, what):
        st = self.wait_state("paused", what)
        self.assertEqual(st["capture"]["kind"], "capture")
        self.assertIn("mount the standard 'spectralon-99' in the sample's place",
                      st["capture"]["message"])
        return st

    def test_kill9_before_the_standard_read_again_then_resume(self):
        # goniod's own rig profile, outside the capture root: the resume
        # takes it from the configuration as the request did.
        self.start_daemon(rig=rig_profile(self.folder, "lab", 0.25))
        self.dark_and_reference()
        self.start_sim(SAMPLE)  # the operator mounts the sample
        c = self.d.connect()
        c.request("watch")
        r = c.request("capture", plan="ds3", name="cap", calibration="newest",
                      reference_after=True)
        self.assertEqual(r["class"], "OK", r)
        self.asks_for_the_standard("after the sample's points")
        capdir = os.path.join(self.d.root, "cap")
        before = records(capdir)
        self.assertEqual(len(before), 52, "every point measured before the standard")
        self.assertFalse(os.path.exists(os.path.join(capdir, "results.json")))
        self.d.kill9()

        self.start_sim(STANDARD)  # the operator mounts the standard meanwhile
        self.d.start()
        c = self.d.connect()
        c.request("watch")
        r = c.request("resume", capture_id="cap")
        self.assertEqual(r["class"], "OK", r)
        self.asks_for_the_standard("again, after the kill")
        self.assertEqual(self.d.gonio("resume").returncode, 0)
        stop = c.until_stop("cap")[-1]
        self.assertEqual(stop["exit_status"], "success", stop)

        after = records(capdir)
        self.assertEqual(len(after), 52)
        # The sample's readings are what was measured before the kill; only
        # their reduction changed, with the drift's uncertainty now in it.
        raw = ("point", "raw_r", "raw_g", "raw_b", "integration_s", "rig_time_s", "monitor")
        self.assertEqual([[x[k] for k in raw] for x in after],
                         [[x[k] for k in raw] for x in before])
        grew = sum(float(a["u_g"]) > float(b["u_g"]) for a, b in zip(after, before))
        self.assertGreater(grew, 40, "the drift's uncertainty joins the later samples' u")
        cal = json.load(open(os.path.join(capdir, "results.json")))["calibration"]
        d = cal["reference_after"]
        self.assertEqual((d["geometries"], d["readings"]), (5, 20))
        self.assertEqual(d["rig_time_s"], float(before[-1]["rig_time_s"]))
        # lab's lamp monitor follows its drift: the standard reads as it did
        for c_ in range(3):
            self.assertLess(abs(d["ratio"][c_] - 1), 0.01, d)
        self.assertEqual(len(frames(os.path.join(capdir, "reference-after", "journal.csv"))),
                         20)


if __name__ == "__main__":
    unittest.main()
