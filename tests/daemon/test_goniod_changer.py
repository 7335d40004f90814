#!/usr/bin/python3
"""A capture through goniod over Modbus TCP that reads its reference
standard again after the sample's points, on a rig profile with a sample
changer (sample_changer: true, driver.slaves.sample_changer) served by
gonio-sim: goniod swaps the standard in and the sample back through the
changer, never pausing for the operator, and the standard's reading is
that of the standard (the ratio the operator-swap path gives, within its
noise: tests/daemon/test_goniod_reference_after.py)."""
import json
import os
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_goniod_calibrate import (SAMPLE, SLOW, START_S, CalibrateRig, Daemon,  # noqa: E402
                                   rig_profile)


class ChangerTests(CalibrateRig):

    def start_sim(self, material, time_scale=None):
        """gonio-sim on the changer's rig profile, writing its --stats."""
        self.changer_rig = rig_profile(self.folder, "changer", 0.25)
        with open(self.changer_rig, "a") as f:
            f.write("sample_changer: true\n")
        self.stats = os.path.join(self.folder, "stats.json")
        self.launch_sim(["--scene", "lab", "--material", material, "--rig", self.changer_rig,
                         "--clock", "simulated", "--stats", self.stats])

    def start_daemon(self, rig=None, time_scale=1):
        """goniod with the changer's drive at slave 6 (gonio-sim's)."""
        driver = ("  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %d\n  timeout_s: %g\n"
                  "  time_scale: %d\n  slaves: {sample: 1, arm: 2, detector: 3, azimuth: 4, "
                  "sample_changer: 6}\n" % (self.port, 0.5 * SLOW, time_scale))
        self.d = Daemon(self.folder, driver=driver)
        text = open(self.d.config).read().replace("rig: default", "rig: %s" % rig)
        with open(self.d.config, "w") as f:
            f.write(text)
        self.d.start()
        self.cal_root = os.path.join(self.folder, "calibrations")
        return self.d

    def test_reference_after_through_the_changer(self):
        self.start_daemon(rig=self.changer_rig)
        self.dark_and_reference()
        self.start_sim(SAMPLE)  # the sample in its place, the standard in the changer
        c = self.d.connect()
        c.request("watch")
        r = c.request("capture", plan="ds3", name="cap", calibration="newest",
                      reference_after=True)
        self.assertEqual(r["class"], "OK", r)
        deadline = time.time() + 4 * START_S
        while time.time() < deadline:
            st = self.status()
            self.assertNotEqual(st["state"], "paused", "asked the operator: %r" % st)
            if st["state"] == "idle":
                break
            time.sleep(0.05)
        stop = c.until_stop("cap")[-1]
        self.assertEqual(stop["exit_status"], "success", stop)
        self.assertEqual(self.stop_sim(), 0)
        moved = json.load(open(self.stats))["sample_changer"]
        self.assertEqual((moved["to_standard"], moved["to_sample"]), (1, 1), moved)
        cal = json.load(open(os.path.join(self.d.root, "cap", "results.json")))["calibration"]
        d = cal["reference_after"]
        self.assertEqual((d["geometries"], d["readings"]), (5, 20))
        # The standard read as at the calibration (lab's monitor follows the
        # lamp), as on the operator's path; the sample would read far off.
        for c_ in range(3):
            self.assertLess(abs(d["ratio"][c_] - 1), 0.01, d)


if __name__ == "__main__":
    unittest.main()
