#!/usr/bin/python3
"""goniod's systemd notifications (READY, WATCHDOG, STOPPING), and gonio
capture --offline (and the other long commands) on a terminal: the bar,
the interrupt, the resume (goniod_harness.py).

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \
      python3 tests/daemon/test_goniod_offline.py -v
"""
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
import unittest

import ctest_skips

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import gonio_cal  # noqa: E402
from goniod_harness import (GONIO, START_S, Daemon, journal_points, run_on_pty, tmpdir)


class NotifyTests(unittest.TestCase):
    def run_with(self, name, bind_addr):
        folder = tmpdir()
        try:
            rx = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
            rx.bind(bind_addr)
            rx.settimeout(10)
            d = Daemon(folder, env={"NOTIFY_SOCKET": name, "WATCHDOG_USEC": "100000"})
            d.start()
            got = []
            deadline = time.time() + START_S
            while time.time() < deadline and sum("WATCHDOG=1" in g for g in got) < 3:
                got.append(rx.recv(4096).decode())
            d.proc.send_signal(signal.SIGTERM)
            while not any("STOPPING=1" in g for g in got):
                got.append(rx.recv(4096).decode())
            self.assertEqual(d.proc.wait(timeout=2 * START_S), 0)
            rx.close()
            self.assertIn("READY=1", got[0])
            self.assertIn("MAINPID=%d" % d.proc.pid, got[0])
            self.assertGreaterEqual(sum("WATCHDOG=1" in g for g in got), 3)
            self.assertTrue(any(g.startswith("STATUS=") for g in got))
        finally:
            shutil.rmtree(folder, ignore_errors=True)

    def test_path_socket(self):
        folder = tmpdir()
        path = os.path.join(folder, "notify")
        self.run_with(path, path)
        shutil.rmtree(folder, ignore_errors=True)

    def test_abstract_socket(self):
        name = "gonio-test-%d" % os.getpid()
        self.run_with("@" + name, "\0" + name)

    def test_watchdog_for_another_pid_is_ignored(self):
        folder = tmpdir()
        try:
            path = os.path.join(folder, "notify")
            rx = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
            rx.bind(path)
            rx.settimeout(0.5)
            d = Daemon(folder, env={"NOTIFY_SOCKET": path, "WATCHDOG_USEC": "50000",
                                    "WATCHDOG_PID": "1"})
            d.start()
            got = [rx.recv(4096).decode()]
            time.sleep(0.4)
            try:
                while True:
                    got.append(rx.recv(4096).decode())
            except socket.timeout:
                pass
            d.stop()
            self.assertIn("READY=1", got[0])
            self.assertFalse(any("WATCHDOG=1" in g for g in got), got)
        finally:
            shutil.rmtree(folder, ignore_errors=True)

# ---------------------------------------------------------------------------

class OfflineTests(unittest.TestCase):
    """gonio capture --offline on a terminal: the bar, the interrupt, the
    resume. Through a pty: the display is what the terminal shows."""

    def setUp(self):
        self.folder = tmpdir()
        self.env = dict(os.environ)

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def capture(self, out, plan="ds3", scene="lab"):
        """lab's detector gives counts: calibrated first for the plan."""
        cal = []
        if scene == "lab":
            root = os.path.join(self.folder, "cal-" + plan)
            if not os.path.isdir(root):
                gonio_cal.calibrate(root, scene, plan)
            cal = ["--calibrations", root]
        return [GONIO, "capture", "--offline", "--scene", scene, "--plan", plan, "--out",
                out] + cal

    def leftovers(self, path):
        return [f for f in os.listdir(path) if ".tmp." in f] if os.path.isdir(path) else []

    def test_bar_on_a_terminal(self):
        out = os.path.join(self.folder, "bar")
        rc, text = run_on_pty(self.capture(out), self.env)
        self.assertEqual(rc, 0, text)
        with open(os.path.join(out, "plan.json")) as f:
            total = len(json.load(f)["pairs"])
        # One line redrawn in place (carriage returns), the first with the
        # estimate and an ETA before a point is measured, the last complete.
        bars = re.findall(r"\rcapture \[[#.]+\] (\d+)/(\d+)([^\r\n]*)", text)
        self.assertEqual(bars[0][:2], ("0", str(total)), text[:300])
        self.assertRegex(bars[0][2], r"rig 0:00 of ~\d+:\d\d estimated  ETA \d+:\d\d")
        self.assertEqual(bars[-1][:2], (str(total), str(total)))
        self.assertIn("ETA 0:00", bars[-1][2])
        self.assertIn("fit ", bars[-1][2])  # the live fit error, once there is a round
        self.assertNotIn("capture: ", text)  # no plain lines on a terminal
        # --quiet: no bar.
        rc, text = run_on_pty(self.capture(os.path.join(self.folder, "q"), "ds4") + ["--quiet"],
                              self.env)
        self.assertEqual(rc, 0, text)
        self.assertNotIn("[", text)

    def test_interrupt_ends_cleanly_and_resumes(self):
        out = os.path.join(self.folder, "int")
        argv = self.capture(out, "inplane-full", "ideal")
        rc, text = run_on_pty(argv, self.env, interrupt_at=r"\] [1-9]\d*/\d+")
        self.assertEqual(rc, 130, text[-500:])
        m = re.search(r"SIGINT: stopped after (\d+) of (\d+) points, all in (\S+)/samples.csv; "
                      r"run the same command again to resume", text)
        self.assertTrue(m, text[-500:])
        done, total = int(m.group(1)), int(m.group(2))
        self.assertEqual(journal_points(os.path.join(out, "samples.csv")), list(range(done)))
        self.assertLess(done, total)
        self.assertEqual(self.leftovers(out), [])
        self.assertFalse(os.path.exists(os.path.join(out, "results.json")))
        # The rerun says it resumes, and measures only what is missing.
        r = subprocess.run(argv, capture_output=True, text=True,
                           env=self.env, timeout=600)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("resuming: %d of %d points in the journal" % (done, total), r.stderr)
        self.assertEqual(sorted(journal_points(os.path.join(out, "samples.csv"))),
                         list(range(total)))

    def test_plan_scene_estimate(self):
        """gonio plan --scene counts a metering detector's auto-exposure
        (lab's noise read by the simulator's ideal meter): within 5 % of
        the capture's rig time, where the plan alone is 11 % short."""
        metered = gonio_cal.metered_scene(self.folder)
        def estimate(*args):
            r = subprocess.run([GONIO, "plan", "ds4", "--json"] + list(args),
                               capture_output=True, text=True, env=self.env, timeout=60)
            self.assertEqual(r.returncode, 0, r.stderr)
            return json.loads(r.stdout)["estimate"]["total_s"]
        out = os.path.join(self.folder, "est")
        r = subprocess.run(self.capture(out, "ds4", metered) + ["--quiet"], capture_output=True,
                           text=True, env=self.env, timeout=120)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "results.json")) as f:
            actual = json.load(f)["rig_time_s"]
        self.assertLess(abs(estimate("--scene", metered) - actual), 0.05 * actual)
        self.assertGreater(abs(estimate() - actual), 0.05 * actual)
        r = subprocess.run([GONIO, "plan", "ds4", "--scene", "nosuch"], capture_output=True,
                           text=True, env=self.env, timeout=60)
        self.assertEqual((r.returncode, r.stdout), (2, ""))
        self.assertIn("nosuch", r.stderr)

    def test_study_and_its_renders_on_a_terminal(self):
        """gonio study and gonio render --study show the same bar."""
        out = os.path.join(self.folder, "study")
        rc, text = run_on_pty([GONIO, "study", "--materials", "default", "--plans", "ds4,ds3",
                               "--models", "abc", "--scenes", "ideal", "--jobs", "1",
                               "--out", out], self.env)
        self.assertEqual(rc, 0, text[-500:])
        bars = re.findall(r"\rstudy \[[#.]+\] (\d+)/2([^\r\n]*)", text)
        self.assertEqual([b[0] for b in bars], ["0", "1", "2"], text[-500:])
        self.assertRegex(bars[1][1], r"ETA \d+:\d\d")
        rc, text = run_on_pty([GONIO, "render", "--study", out, "--size", "16"], self.env)
        self.assertEqual(rc, 0, text[-500:])
        bars = re.findall(r"\rrender \[[#.]+\] (\d+)/(\d+)", text)
        self.assertEqual(bars[0][0], "0", text)
        self.assertEqual(bars[-1][0], bars[-1][1])
        self.assertNotIn("render: ", text)  # the per-image lines are gonio render's own

    def test_study_quiet(self):
        """gonio study --quiet: no bar, the study still done."""
        out = os.path.join(self.folder, "quiet")
        rc, text = run_on_pty([GONIO, "study", "--materials", "default", "--plans", "ds4",
                               "--models", "abc", "--scenes", "ideal", "--jobs", "1", "--quiet",
                               "--out", out], self.env)
        self.assertEqual(rc, 0, text[-500:])
        self.assertNotIn("study [", text)
        self.assertNotRegex(text, r"study: \d+/\d+ jobs")
        with open(os.path.join(out, "results.csv")) as f:
            self.assertEqual(len(f.read().splitlines()), 2)  # header and the one row

    def test_train_decoder_on_a_terminal(self):
        """gonio train-decoder draws latent training on the one display (it
        used to print its own lines from inside fit/); stdout and the file do
        not depend on it."""
        ctest_skips.shared_or_skip()  # the decoder trains on the MERL materials
        tiny = ["--epochs", "40", "--nz", "4", "--width", "16", "--samples", "16"]
        out = os.path.join(self.folder, "bar.gld")
        rc, text = run_on_pty([GONIO, "train-decoder", "-o", out] + tiny, self.env)
        self.assertEqual(rc, 0, text[-500:])
        bars = re.findall(r"\rtrain-decoder \[[#.]+\] (\d+)/40([^\r\n]*)", text)
        self.assertEqual(bars[0][0], "0", text)
        self.assertEqual(bars[-1][0], "40", text)
        self.assertRegex(bars[-1][1], r"ETA 0:00  fit \d+\.\d{4}$")
        self.assertNotIn("step ", text)
        quiet = os.path.join(self.folder, "quiet.gld")
        rc, text = run_on_pty([GONIO, "train-decoder", "-o", quiet, "--quiet"] + tiny, self.env)
        self.assertEqual(rc, 0, text)
        self.assertNotIn("[", text)
        self.assertRegex(text, r"^wrote \S+quiet.gld \(90 training materials.*crc [0-9a-f]{8}\)")
        with open(out, "rb") as a, open(quiet, "rb") as b:
            self.assertEqual(a.read(), b.read())
        # Not a terminal: plain lines on stderr, stdout only the result.
        r = subprocess.run([GONIO, "train-decoder", "-o", quiet] + tiny, capture_output=True,
                           text=True, env=self.env, timeout=120)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout.splitlines(), [text.strip()])
        self.assertIn("train-decoder: 40/40 epochs", r.stderr)

    def test_interrupt_while_planning_leaves_nothing(self):
        """SIGINT while the plan is made (oop200k: 2 s before its first
        point; inplane-full's 8710 pairs now order in a quarter second),
        sent as soon as gonio catches it, which it does just before it
        plans: no directory, no plan.json.tmp.PID."""
        out = os.path.join(self.folder, "plan")
        rc, text = run_on_pty(self.capture(out, "oop200k", "ideal"), self.env,
                              interrupt_when_caught=True)
        self.assertEqual(rc, 130, text)
        self.assertIn("SIGINT before the first point; nothing written", text)
        self.assertFalse(os.path.exists(out), os.listdir(out) if os.path.exists(out) else "")

if __name__ == "__main__":
    unittest.main()
