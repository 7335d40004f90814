#!/usr/bin/python3
"""goniod with a USB spectrometer as its detector (docs/usb-spectrometer.md):
the config keys, and a capture on gonio-sim's axes (Modbus TCP) with the
spectrometer replayed by umockdev-run from the driver tests' recording.

Run from ctest, or by hand like test_goniod.py (its helpers are goniod_harness.py's;
its fixtures, test_goniod.py's CheckTests and test_goniod_modbus.py's ModbusRig).
"""
import csv
import math
import os
import shlex
import shutil
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import goniod_harness as g  # noqa: E402
import test_goniod  # noqa: E402  (CheckTests)
import test_goniod_modbus  # noqa: E402  (ModbusRig)

USB_DATA = os.path.join(g.SOURCE, "tests", "unit", "drivers", "usb")
UMOCKDEV_RUN = shutil.which("umockdev-run")


class UsbConfigTests(unittest.TestCase):
    DRIVER = ("rig: usb-spectrometer\n"
              "driver:\n  kind: modbus-tcp\n  host: 127.0.0.1\n"
              "  detector: {kind: usb-spectrometer, vendor: 0x2457, product: 0x101E,\n"
              "             serial: USB2+F01234, bands: 390-730, scale: 2.5e-5}\n"
              "  slaves: {sample: 1, arm: 2, azimuth: 4}\n"
              "capture_root: caps\n"
              "socket:\n  path: g.sock\n")

    setUp = test_goniod.CheckTests.setUp
    tearDown = test_goniod.CheckTests.tearDown
    check = test_goniod.CheckTests.check
    bad = test_goniod.CheckTests.bad

    def test_resolved_and_round_trip(self):
        path, r = self.check(self.DRIVER)
        self.assertEqual(r.returncode, 0, r.stderr)
        for line in ("    kind: usb-spectrometer\n", "    vendor: 0x2457\n",
                     "    product: 0x101e\n", '    serial: "USB2+F01234"\n',
                     "    bands: 390-730\n", "    timeout_s: 1\n"):
            self.assertIn(line, r.stdout)
        path2, r2 = self.check(r.stdout)
        self.assertEqual(r2.returncode, 0, r2.stderr)
        strip = lambda s: "\n".join(l for l in s.splitlines() if not l.startswith("#"))
        self.assertEqual(strip(r2.stdout), strip(r.stdout))

    def test_shipped_config(self):
        path = g.shipped_config("modbus-rtu-usb-spectrometer.yaml", self.folder)
        r = g.run_wrapped([g.GONIOD, "--config", path, "--check"], self.folder)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("kind: usb-spectrometer", r.stdout)

    def test_bad_values(self):
        text = self.DRIVER.replace("{kind: usb-spectrometer, vendor: 0x2457, product: 0x101E,\n"
                                   "             serial: USB2+F01234, bands: 390-730, "
                                   "scale: 2.5e-5}",
                                   "\n    kind: usb-spectrometer\n    product: 0x12345\n")
        self.bad(text, "product", "must be a USB id 0x0000-0xffff (value '0x12345')")
        self.bad(text.replace("product: 0x12345", "bands: 380-780"), "bands", "380-780")
        self.bad(text.replace("product: 0x12345", "serial: \"a b\""), "serial",
                 "printable ASCII")
        self.bad(text.replace("product: 0x12345", "colour: blue"), "colour", "colour")
        # the detector's kind (line 6), not the driver's (line 3)
        path, r = self.check(text.replace("kind: usb-spectrometer", "kind: camera")
                             .replace("    product: 0x12345\n", ""))
        self.assertEqual(r.returncode, 2)
        self.assertIn("%s:6:11: key 'kind'" % path, r.stderr)
        self.assertIn("camera", r.stderr)


@unittest.skipUnless(UMOCKDEV_RUN, "umockdev-run not installed")
class UsbCaptureTests(unittest.TestCase):
    """A 4-point capture: axes on gonio-sim, every reading from the replayed
    USB2000+ (the recording answers each spectrum request the same way)."""
    SIM = test_goniod_modbus.ModbusRig.SIM
    SIM_SCALE = test_goniod_modbus.ModbusRig.SIM_SCALE
    SIM_ARGS = test_goniod_modbus.ModbusRig.SIM_ARGS
    setUp = test_goniod_modbus.ModbusRig.setUp
    stop_sim = test_goniod_modbus.ModbusRig.stop_sim

    def tearDown(self):
        if self.d and self.d.alive():
            self.d.proc.kill()
            self.d.proc.wait()
        test_goniod_modbus.ModbusRig.tearDown(self)

    def start(self, recording, detector=""):
        self.d = self.make(recording, detector)
        self.d.start()
        c = self.d.connect()
        c.request("watch")
        return c

    def make(self, recording, detector=""):
        """A goniod (not started) whose command runs it in the testbed."""
        cap = os.path.join(self.folder, "cap")
        os.makedirs(cap)
        # (the spectrometer has no shutter: its profile says so)
        rig = open(os.path.join(g.SOURCE, "configs", "rigs", "usb-spectrometer.yaml")).read()
        # one integration, as recorded: counts are auto-ranged within these
        rig = rig.replace("settle_s: 0.3", "settle_s: 0.01").replace(
            "fixed_s: 0.05", "fixed_s: 0.1").replace("auto_min_s: 0.001", "auto_min_s: 0.1") \
            .replace("auto_max_s: 2", "auto_max_s: 0.1")
        with open(os.path.join(cap, "fast.yaml"), "w") as f:
            f.write(rig)
        with open(os.path.join(cap, "tiny.yaml"), "w") as f:
            f.write("name: tiny\npairs:\n  - [15, 0]\n  - [15, 30]\n  - [45, -30]\n"
                    "  - [45, 40]\norder: as-written\n")
        # goniod runs inside umockdev-run's testbed, which serves the recording
        # (under GONIO_WRAP: valgrind inside the testbed, on goniod itself)
        wrapper = os.path.join(self.folder, "goniod-usb")
        with open(wrapper, "w") as f:
            # (a sanitized goniod: the preload comes before ASan's runtime)
            f.write("#!/bin/sh\nASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}"
                    "verify_asan_link_order=0 exec %s --device %s "
                    "--ioctl /dev/bus/usb/001/005=%s -- %s \"$@\"\n"
                    % (UMOCKDEV_RUN, os.path.join(USB_DATA, "usb2000plus.umockdev"),
                       os.path.join(USB_DATA, recording),
                       " ".join(shlex.quote(a) for a in
                                g.wrap([os.path.abspath(g.GONIOD)], self.folder))))
        os.chmod(wrapper, 0o755)
        d = g.Daemon(self.folder, command=[wrapper], driver=(
            "  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %d\n  time_scale: 1000\n"
            "  timeout_s: %g\n  slaves: {sample: 1, arm: 2, detector: 3, azimuth: 4}\n"
            "  detector: {kind: usb-spectrometer, serial: USB2+F01234, timeout_s: 2%s}\n"
            % (self.port, 0.5 * g.SLOW, detector)))
        with open(d.config) as f:
            text = f.read()
        with open(d.config, "w") as f:
            f.write(text.replace("rig: default", "rig: usb-spectrometer"))
        return d

    def finish(self, c):
        """shutdown over the socket: umockdev-run passes no signal on."""
        c.request("shutdown")
        rc = self.d.proc.wait(timeout=2 * g.START_S)
        with open(self.d.log) as f:
            self.assertEqual(rc, 0, f.read()[-2000:])

    def probe(self, d):
        r = subprocess.run(d.command + ["--config", d.config, "--check", "--probe"],
                           capture_output=True, text=True, cwd=self.folder,
                           timeout=2 * g.START_S)
        return r, [l for l in r.stdout.splitlines() if l.startswith("# probe: detector")]

    def test_probe_opens_the_spectrometer(self):
        """--check --probe opens the spectrometer as a capture would and
        says what it is: its serial, pixels, the wavelengths its calibration
        gives them and the configured bands; a serial no device has exits 2
        naming the detector."""
        r, line = self.probe(self.make("spectrum.ioctl"))
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertEqual(len(line), 1, r.stdout)
        self.assertRegex(line[0], r"^# probe: detector \(usb\) +answered: serial USB2\+F01234, "
                         r"2048 pixels, \d+\.\d-\d+\.\d nm, 31 bands 400-700 nm$")
        lo, hi = (float(x) for x in line[0].split(" pixels, ")[1].split(" nm")[0].split("-"))
        self.assertTrue(lo < 395 and hi > 705, line)
        self.assertEqual(len([l for l in r.stdout.splitlines() if l.startswith("# probe: axis")
                              and "answered" in l]), 3, r.stdout)
        shutil.rmtree(os.path.join(self.folder, "cap"))
        d = self.make("spectrum.ioctl")
        with open(d.config) as f:
            text = f.read()
        with open(d.config, "w") as f:
            f.write(text.replace("serial: USB2+F01234", "serial: USB2+NOPE"))
        r, line = self.probe(d)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertIn("did not answer: usb spectrometer 2457:101e (serial USB2+NOPE)", line[0])
        self.assertIn("goniod: probe: usb spectrometer 2457:101e (serial USB2+NOPE)", r.stderr)

    def test_counts_refused_without_calibration(self):
        """The spectrometer gives counts: a capture naming no calibration
        fails at the first reading, naming the detector and the fix, and no
        sample is kept as BRDF."""
        c = self.start("spectrum.ioctl")
        self.assertEqual(c.request("capture", plan="tiny.yaml", rig="fast.yaml",
                                   name="raw")["class"], "OK")
        stop = c.until_stop("raw")[-1]
        self.assertEqual(stop["exit_status"], "fail", stop)
        self.assertIn("the detector (usb-spectrometer) gives counts", stop["message"])
        self.assertIn("--calibration ID", stop["message"])
        samples = os.path.join(self.d.root, "raw", "samples.csv")
        self.assertFalse(os.path.exists(samples) and g.read_samples(samples))
        self.finish(c)

    def test_uncalibrated_journals_counts(self):
        """--uncalibrated: the counts are journalled as counts (the three
        bins of the lamp-lit tile: red above blue), none as BRDF, nothing
        fitted."""
        c = self.start("spectrum.ioctl")
        self.assertEqual(c.request("capture", plan="tiny.yaml", rig="fast.yaml", name="raw",
                                   uncalibrated=True)["class"], "OK")
        docs = c.until_stop("raw")
        self.assertEqual(docs[-1]["reason"], "complete", docs[-1])
        events = [d for d in docs if d["class"] == "event" and "raw" in d]
        self.assertEqual(len(events), 4)
        for e in events:
            self.assertEqual(e["unit"], "counts")
            self.assertEqual(e["rgb"], [None, None, None])
            self.assertEqual(e["raw"], events[0]["raw"])
            self.assertTrue(all(x > 1000 for x in e["raw"]), e["raw"])
        self.assertGreater(events[0]["raw"][0], events[0]["raw"][2])
        results = g.load_json(os.path.join(self.d.root, "raw", "results.json"))
        self.assertIn("uncalibrated", results["not_fitted"])
        self.finish(c)

    def test_scale_shortcut_reports_brdf(self):
        """scale in the config: the shortcut that reports BRDF, as before."""
        c = self.start("spectrum.ioctl", detector=", scale: 2.5e-5")
        self.assertEqual(c.request("capture", plan="tiny.yaml", rig="fast.yaml",
                                   name="usb")["class"], "OK")
        stop = c.until_stop("usb")[-1]
        self.assertEqual(stop["reason"], "complete", stop)
        got = g.read_samples(os.path.join(self.d.root, "usb", "samples.csv"))
        self.assertEqual(sorted(got), [0, 1, 2, 3])
        # one recorded spectrum, replayed at every point: one colour, a
        # lamp-lit white tile's (all channels positive, red above blue)
        first = got[0]
        for p in got:
            self.assertEqual(got[p], first)
        self.assertTrue(all(v > 0 and math.isfinite(v) for v in first), first)
        self.assertGreater(first[0], first[2])
        self.finish(c)

    def test_dark_asks_the_operator_to_cover_it(self):
        """The spectrometer has no shutter: a dark calibration on its rig
        profile pauses before the first frame, asking the operator to cover
        the detector or turn the lamp off, and reads its frames after
        gonio resume."""
        c = self.start("spectrum.ioctl")
        self.assertEqual(c.request("calibrate", kind="dark", frames=2, rig="fast.yaml",
                                   name="dark")["class"], "OK")
        deadline = time.time() + 2 * g.START_S
        st = c.request("status")
        while st["state"] != "paused":
            self.assertLess(time.time(), deadline, st)
            time.sleep(0.05)
            st = c.request("status")
        self.assertIn("rig 'usb-spectrometer' has no shutter: cover the detector (or turn "
                      "the lamp off), then: gonio resume", st["capture"]["message"])
        self.assertEqual(st["points_done"], 0, "nothing read before the operator acted")
        self.assertEqual(c.request("resume")["class"], "OK")
        stop = c.until_stop("dark")[-1]
        self.assertEqual(stop["exit_status"], "success", stop)
        with open(os.path.join(self.folder, "calibrations", "dark", "frames.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual(len(rows), 2)
        # the lamp-lit recording, read as the "dark": the cover is the operator's
        self.assertTrue(all(float(r["r"]) > 1000 for r in rows), rows)
        self.finish(c)

    def test_unplugged_device_fails_the_capture(self):
        c = self.start("unplug.ioctl")
        self.assertEqual(c.request("capture", plan="tiny.yaml", rig="fast.yaml",
                                   name="gone")["class"], "OK")
        stop = c.until_stop("gone")[-1]
        self.assertEqual(stop["exit_status"], "fail", stop)
        self.assertIn("usb spectrometer 2457:101e (serial USB2+F01234): read spectrum: "
                      "packet 4 of 8: device unplugged", stop["message"])
        self.assertEqual(c.request("status")["state"], "idle")
        self.finish(c)


if __name__ == "__main__":
    unittest.main()
