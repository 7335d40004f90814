#!/usr/bin/python3
"""A capture through goniod over Modbus TCP that reads its reference
standard again after the sample's points, on a rig profile with a sample
changer (sample_changer: true, driver.slaves.sample_changer) served by
gonio-sim: goniod swaps the standard in and the sample back through the
changer, never pausing for the operator, and the standard's reading is
that of the standard (the ratio the operator-swap path gives, within its
noise: tests/daemon/test_goniod_reference_after.py).

Calibrations through the changer: gonio calibrate stray swaps the light
trap in (slot 2) and reference the standard (slot 1), the sample back
after each, never pausing; the reference's frames are those the
operator's swap gives, within their noise. goniod killed mid-reference
with the standard in: started again, gonio resume ID finishes without a
second swap and puts the sample back."""
import json
import os
import statistics
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import child_procs  # noqa: E402
from test_goniod_calibrate import (GONIO, SAMPLE, SLOW, START_S, CalibrateRig,  # noqa: E402
                                   Daemon, frames, journal_lines, rig_profile)


class ChangerTests(CalibrateRig):

    def start_sim(self, material, time_scale=None):
        """gonio-sim on the changer's rig profile, writing its --stats."""
        self.changer_rig = rig_profile(self.folder, "changer", 0.25)
        with open(self.changer_rig, "a") as f:
            f.write("sample_changer: true\n")
        self.stats = os.path.join(self.folder, "stats.json")
        self.launch_sim(["--scene", "lab", "--material", material, "--rig", self.changer_rig,
                         "--stats", self.stats] +
                        (["--time-scale", str(time_scale)] if time_scale
                         else ["--clock", "simulated"]))

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
        self.calibrate_unattended("dark")
        self.calibrate_unattended("reference", "--plan", "ds3", "--repeats", "2")
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

    def calibrate_unattended(self, *args, name=None):
        """gonio calibrate ARGS through goniod, which must not pause for the
        operator (aborted if it does, so that the test fails, not hangs)."""
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        p = subprocess.Popen([GONIO, "calibrate", *args], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=env,
                             preexec_fn=child_procs.die_with_parent)
        paused = None
        while p.poll() is None and not paused:
            st = self.status()
            if st["state"] == "paused":
                paused = st
                self.d.gonio("abort")
            time.sleep(0.05)
        out, err = p.communicate(timeout=30 * START_S)
        self.assertIsNone(paused, "asked the operator")
        self.assertEqual(p.returncode, 0, err)
        return out.strip()

    def test_calibrations_through_the_changer(self):
        # The operator's swap, on a goniod that drives no changer (the rig
        # profile without one): the standard mounted by hand.
        CalibrateRig.start_daemon(self)
        hand_dark, by_hand = self.dark_and_reference()
        self.d.stop()
        self.start_sim(SAMPLE)  # now the sample in its place, the changer holding the rest
        self.start_daemon(rig=self.changer_rig)
        dark_id = self.calibrate_unattended("dark")
        stray_id = self.calibrate_unattended("stray", "--plan", "ds3", "--repeats", "2")
        ref_id = self.calibrate_unattended("reference", "--plan", "ds3", "--repeats", "2")
        self.assertEqual(self.stop_sim(), 0)
        moved = json.load(open(self.stats))["sample_changer"]
        self.assertEqual((moved["to_trap"], moved["to_standard"], moved["to_sample"]),
                         (1, 1, 2), moved)
        for cid in (stray_id, ref_id):  # nothing left to undo
            self.assertFalse(os.path.exists(os.path.join(self.cal_root, cid, "changer")))
        def dark_of(cid):
            return statistics.mean(float(x["g"]) for x in
                                   frames(os.path.join(self.cal_root, cid, "frames.csv")))
        dark, dark_hand = dark_of(dark_id), dark_of(hand_dark)
        stray = frames(os.path.join(self.cal_root, stray_id, "frames.csv"))
        ref = frames(os.path.join(self.cal_root, ref_id, "frames.csv"))
        hand = frames(os.path.join(self.cal_root, by_hand, "frames.csv"))
        # The light trap: lab's stray floor over the dark (about 100 ADU at
        # 0.25 s), nothing of the sample's.
        over = statistics.mean(float(x["g"]) for x in stray) - dark
        self.assertLess(over, 500, over)
        # The standard as the operator mounted it: the same frames, their
        # counts over the dark alike within the readings' noise.
        key = ("kind", "theta_i", "theta_r", "integration_s", "gain_state")
        self.assertEqual([[x[k] for k in key] for x in ref], [[x[k] for k in key] for x in hand])
        ratios = [(float(a["g"]) - dark) / (float(b["g"]) - dark_hand)
                  for a, b in zip(ref, hand)]
        sys.stderr.write("changer's reference over the operator's: mean %.4f, sd %.4f\n"
                         % (statistics.mean(ratios), statistics.pstdev(ratios)))
        self.assertLess(abs(statistics.mean(ratios) - 1), 0.005)
        self.assertLess(max(abs(r - 1) for r in ratios), 0.05)

    def test_kill9_mid_reference_then_resume(self):
        # On wall time (tests/daemon/test_goniod_calibrate.py's crash test),
        # so that the kill lands mid-way.
        self.start_sim(SAMPLE, time_scale=10)
        self.start_daemon(rig=self.changer_rig, time_scale=10)
        self.calibrate_unattended("dark")
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        p = subprocess.Popen([GONIO, "calibrate", "reference", "--plan", "ds3", "--repeats",
                              "2", "--name", "ref-killed"], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=env,
                             preexec_fn=child_procs.die_with_parent)
        run = os.path.join(self.cal_root, "ref-killed")
        deadline = time.time() + 4 * START_S
        journal = os.path.join(run, "journal.csv")
        while time.time() < deadline and (not os.path.exists(journal) or
                                          journal_lines(journal) < 31):
            time.sleep(0.005)
        self.d.kill9()
        p.communicate(timeout=START_S)
        self.assertNotEqual(p.returncode, 0)
        self.assertFalse(os.path.exists(os.path.join(run, "calibration.json")),
                         "killed before the end")
        # The run knows what sits in the sample's place: the standard.
        self.assertEqual(open(os.path.join(run, "changer")).read(), "slot 1 in\n")
        self.d.start()
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("resume", capture_id="ref-killed")["class"], "OK")
        stop = c.until_stop("ref-killed")[-1]
        self.assertEqual(stop["exit_status"], "success", stop)
        self.assertEqual(stop["calibration"]["frames"], 104)
        self.assertFalse(os.path.exists(os.path.join(run, "changer")))
        self.assertEqual(self.stop_sim(), 0)
        moved = json.load(open(self.stats))["sample_changer"]
        self.assertEqual((moved["to_standard"], moved["to_sample"]), (1, 1), moved)


if __name__ == "__main__":
    unittest.main()
