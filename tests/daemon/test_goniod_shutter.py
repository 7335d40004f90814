#!/usr/bin/python3
"""goniod against a rig profile whose shutter the detector cannot work: the
USB spectrometer has none, so a profile that says it has one (shutter:
true, the default) is refused at --check, at start, at a request naming it
(capture, calibrate) and at resume; the shipped USB config names the
shipped usb-spectrometer profile, which has none (goniod_harness.py).

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \
      python3 tests/daemon/test_goniod_shutter.py -v
"""
import os
import shutil
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import (GONIOD, SOURCE, Daemon, run_wrapped,  # noqa: E402
                            shipped_config, tmpdir)

RIGS = os.path.join(SOURCE, "configs", "rigs")
# A Modbus TCP rig (nothing listens on port 1: no device is opened by
# anything these tests do) with the USB spectrometer as its detector.
USB_DRIVER = ("  kind: modbus-tcp\n  host: 127.0.0.1\n  port: 1\n"
              "  slaves: {sample: 1, arm: 2, detector: 3, azimuth: 4}\n"
              "  detector:\n    kind: usb-spectrometer\n    bands: 400-700\n")
TINY_PLAN = "name: tiny\npairs:\n  - [15, 0]\n  - [45, 30]\norder: as-written\n"
REFUSAL = "driver.detector.kind is usb-spectrometer, which has no shutter"


def built_with_usb():
    r = run_wrapped([GONIOD, "--config", os.path.join(SOURCE, "configs", "goniod",
                                                      "modbus-rtu-usb-spectrometer.yaml"),
                     "--check"], tmpdir())
    return "built without" not in r.stderr


class ShutterConfigTests(unittest.TestCase):
    """The rig profile's shutter against the detector at --check and start."""

    def setUp(self):
        self.folder = tmpdir()
        if not built_with_usb():
            self.skipTest("goniod built without the USB spectrometer")

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def config(self, rig):
        path = os.path.join(self.folder, "c.yaml")
        with open(path, "w") as f:
            f.write("rig: %s\ndriver:\n%scapture_root: caps\nsocket:\n  path: g.sock\n"
                    % (rig, USB_DRIVER))
        return path

    def test_shutter_on_usb_spectrometer_refused(self):
        path = self.config("default")
        r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertEqual(r.stdout, "")
        # the file, the line of the detector's kind, the field, the fix
        self.assertIn("%s:8:" % path, r.stderr)
        self.assertIn("key 'kind'", r.stderr)
        self.assertIn(REFUSAL + ", but rig profile 'default' has one (shutter: true",
                      r.stderr)
        self.assertIn("shutter: false (the shipped usb-spectrometer)", r.stderr)
        r = run_wrapped([GONIOD, "--config", path], self.folder, timeout=30)
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn(REFUSAL, r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.folder, "caps")))

    def test_profile_without_shutter_accepted(self):
        r = run_wrapped([GONIOD, "--config", self.config("usb-spectrometer"), "--check"],
                        self.folder)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("rig: usb-spectrometer\n", r.stdout)

    def test_shipped_usb_config_names_a_profile_without_shutter(self):
        path = shipped_config("modbus-rtu-usb-spectrometer.yaml", self.folder)
        with open(path) as f:
            rig = [l.split()[1] for l in f if l.startswith("rig:")][0]
        with open(os.path.join(RIGS, rig + ".yaml")) as f:
            self.assertIn("\nshutter: false", f.read())
        r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("rig: usb-spectrometer\n", r.stdout)
        # the same file naming the default profile (a shutter): refused
        with open(path) as f:
            text = f.read()
        bad = os.path.join(self.folder, "bad.yaml")
        with open(bad, "w") as f:
            f.write(text.replace("rig: usb-spectrometer", "rig: default"))
        r = run_wrapped([GONIOD, "--config", bad, "--check"], self.folder)
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn(REFUSAL, r.stderr)


class ShutterRequestTests(unittest.TestCase):
    """A request or a resume naming a profile with a shutter on the USB
    rig: refused before anything is created or opened."""

    def setUp(self):
        self.folder = tmpdir()
        if not built_with_usb():
            self.skipTest("goniod built without the USB spectrometer")
        self.d = None

    def tearDown(self):
        if self.d:
            self.d.stop()
        shutil.rmtree(self.folder, ignore_errors=True)

    def usb_daemon(self):
        self.d = Daemon(self.folder, driver=USB_DRIVER)
        with open(self.d.config) as f:
            text = f.read()
        with open(self.d.config, "w") as f:
            f.write(text.replace("rig: default", "rig: usb-spectrometer"))
        return self.d.start()

    def test_capture_and_calibrate_naming_a_shutter_refused(self):
        self.usb_daemon()
        c = self.d.connect()
        r = c.request("capture", plan="ds3", rig="default", name="x")
        self.assertEqual((r["class"], r["code"]), ("ERROR", "bad-value"), r)
        self.assertIn(self.d.config, r["message"])
        self.assertIn(REFUSAL + ", but rig profile 'default' has one", r["message"])
        self.assertFalse(os.path.exists(os.path.join(self.d.root, "x")))
        r = c.request("calibrate", kind="dark", rig="default", name="d")
        self.assertEqual(r["class"], "ERROR", r)
        self.assertIn(REFUSAL, r["message"])
        self.assertEqual(c.request("status")["state"], "idle")

    def test_resume_naming_a_shutter_refused(self):
        """A capture made on the simulated rig with the default profile,
        resumed by a goniod on the USB rig: refused before it runs."""
        self.d = Daemon(self.folder).start()
        os.makedirs(self.d.root, exist_ok=True)
        with open(os.path.join(self.d.root, "tiny.yaml"), "w") as f:
            f.write(TINY_PLAN)
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("capture", plan="tiny.yaml", name="old")["class"], "OK")
        c.until_stop("old")  # (two samples: its fit fails, the journal stays)
        self.d.stop()
        with open(os.path.join(self.d.root, "old", "samples.csv")) as f:
            samples = f.read()
        self.usb_daemon()
        r = self.d.connect().request("resume", capture_id="old")
        self.assertEqual((r["class"], r["code"]), ("ERROR", "bad-value"), r)
        self.assertIn(REFUSAL + ", but rig profile 'default' has one", r["message"])
        with open(os.path.join(self.d.root, "old", "samples.csv")) as f:
            self.assertEqual(f.read(), samples)


if __name__ == "__main__":
    unittest.main()
