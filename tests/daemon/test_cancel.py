#!/usr/bin/python3
"""Scenes at the top of their documented ranges, and the stop of a capture
on them: offline (gonio capture --offline) and in goniod (its simulated
rig).

  hot   responsivity 1e15 with shot noise: counts of 1e11 electrons and more
  dark  a dark rate of 1e12 e-/s with shot noise: 1e9 to 2e12 electrons

A capture on either finishes in seconds with counts that are right (no
wrapped count), and SIGTERM, SIGINT and goniod's abort end one within 2 s
of the request. The engine asks whether to stop before every point, and a
point of the in-process rig is computed in microseconds of CPU, so 2 s (the
limit the operator is promised) leaves the whole margin to a loaded
machine; under valgrind every limit stretches by SLOW.

Over Modbus TCP (goniod on gonio-sim at time scale 1, as on hardware) a
point waits out its integration in wall time: the drivers ask goniod's
abort flag every 50 ms while they wait, so an abort or SIGTERM during an
integration of several seconds ends the capture within the same 2 s,
journalling nothing of the point under way, and the capture resumes.

Run from ctest, or by hand as tests/daemon/test_goniod.py says.
"""
import csv
import math
import os
import shutil
import signal
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import (GONIO, START_S, SLOW, Daemon, journal_points, plan_total,  # noqa: E402
                            tmpdir, wrap, assert_valgrind_clean)
import child_procs  # noqa: E402
from test_goniod_modbus import ModbusRig  # noqa: E402

STOP_S = 2.0 * SLOW  # from the signal or the abort to the end of the capture

SCENES = {
    "hot": "name: hot\nmaterial: default\n"
           "detector: {kind: rgb, responsivity: 1.0e15}\n"
           "effects:\n  - {name: shot_noise}\n",
    "dark": "name: dark\nmaterial: default\n"
            "effects:\n  - {name: dark, rate_e_per_s: 1.0e12}\n  - {name: shot_noise}\n",
}
# A long capture: 12,322 points in written order, each journalled (and
# synced) before the next; far from done when the tests stop it.
LONG = ["--plan", "inplane-1deg", "--order", "as-written", "--stop", "all"]


def write_scenes(folder):
    paths = {}
    for name, text in SCENES.items():
        paths[name] = os.path.join(folder, name + ".yaml")
        with open(paths[name], "w") as f:
            f.write(text)
    return paths


def samples(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def wait_for_samples(path, n, proc, limit_s):
    """Until the journal at path holds n samples; fails when proc ends first
    or after limit_s (a point that never returns)."""
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise AssertionError("the capture ended before its %d samples" % n)
        try:
            with open(path) as f:
                if sum(1 for _ in f) > n:
                    return
        except FileNotFoundError:
            pass
        time.sleep(0.02)
    raise AssertionError("no %d samples in %g s: a point does not return" % (n, limit_s))


def abort_timed(t):
    """Abort t's capture "long" through its connection t.c: it must end,
    aborted, within STOP_S and leave goniod idle; (stop document, seconds)."""
    sent = time.monotonic()
    t.assertEqual(t.c.request("abort")["class"], "OK")
    stop = t.c.until_stop("long")[-1]
    took = time.monotonic() - sent
    t.assertEqual(stop["reason"], "aborted")
    t.assertLess(took, STOP_S, "abort took %.2f s to end the capture" % took)
    t.assertNotEqual(t.c.request("status")["state"], "running")
    return stop, took


def sigterm_timed(t):
    """SIGTERM to t's goniod t.d during capture "long": goniod must end it
    (shutdown) and exit 0 within STOP_S; (stop document, seconds)."""
    sent = time.monotonic()
    t.d.proc.send_signal(signal.SIGTERM)
    stop = t.c.until_stop("long")[-1]
    rc = t.d.proc.wait(timeout=3 * START_S)
    took = time.monotonic() - sent
    t.assertEqual(stop["reason"], "shutdown")
    t.assertEqual(rc, 0)
    t.assertLess(took, STOP_S, "goniod took %.2f s to end on SIGTERM" % took)
    return stop, took


class OfflineTests(unittest.TestCase):
    def setUp(self):
        self.folder = tmpdir()
        self.scenes = write_scenes(self.folder)

    def tearDown(self):
        assert_valgrind_clean(self.folder)
        shutil.rmtree(self.folder, ignore_errors=True)

    def capture(self, scene, out, extra):
        argv = [GONIO, "capture", "--offline", "--scene", self.scenes[scene],
                "--out", out, "--quiet"] + extra
        return wrap(argv, self.folder)

    def test_extreme_scenes_finish_with_right_counts(self):
        """DS1 on each scene completes; every reading is what the scene
        says (hot: the ideal scene's reading to 6/sqrt(e); dark: the dark offset
        1e12 t / (1e6 cos t) = 1e6 / cos theta_i per channel, the material
        adding < 1e-5 of it, shot noise < 1e-4)."""
        for scene in ("hot", "dark"):
            out = os.path.join(self.folder, scene)
            r = subprocess.run(self.capture(scene, out, ["--plan", "ds1"]),
                               capture_output=True, text=True, timeout=6 * START_S)
            self.assertEqual(r.returncode, 0, r.stderr)
            rows = samples(os.path.join(out, "samples.csv"))
            self.assertEqual(len(rows), plan_total(out))
            for row in rows:
                cos_i = max(math.cos(math.radians(float(row["theta_i"]))), 1e-3)
                for ch in "rgb":
                    v = float(row[ch])
                    if scene == "dark":
                        self.assertLess(abs(v * cos_i / 1e6 - 1), 1e-4, row)
                    else:
                        self.assertGreater(v, 0, row)
        hot = samples(os.path.join(self.folder, "hot", "samples.csv"))
        ideal = os.path.join(self.folder, "ideal")
        r = subprocess.run(wrap([GONIO, "capture", "--offline", "--scene", "ideal", "--out",
                                 ideal, "--quiet", "--plan", "ds1"],
                                self.folder),
                           capture_output=True, text=True, timeout=6 * START_S)
        self.assertEqual(r.returncode, 0, r.stderr)
        for a, b in zip(hot, samples(os.path.join(ideal, "samples.csv"))):
            self.assertEqual(a["point"], b["point"])
            cos_i = max(math.cos(math.radians(float(a["theta_i"]))), 1e-3)
            for ch in "rgb":
                e = float(b[ch]) * 1e15 * cos_i * float(a["integration_s"])
                self.assertLess(abs(float(a[ch]) / float(b[ch]) - 1), 6 / math.sqrt(e), (a, b))

    def signal_ends_capture(self, scene, sig):
        out = os.path.join(self.folder, "long-" + scene)
        proc = subprocess.Popen(self.capture(scene, out, LONG), stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True,
                                preexec_fn=child_procs.die_with_parent)
        try:
            wait_for_samples(os.path.join(out, "samples.csv"), 3, proc, 3 * START_S)
            sent = time.monotonic()
            proc.send_signal(sig)
            _, err = proc.communicate(timeout=3 * START_S)
            took = time.monotonic() - sent
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        self.assertEqual(proc.returncode, 130, err)
        self.assertLess(took, STOP_S, "%s took %.2f s to end the capture" % (sig.name, took))
        self.assertIn("%s: stopped after" % sig.name, err)
        pts = journal_points(os.path.join(out, "samples.csv"))
        self.assertLess(len(pts), plan_total(out))
        self.assertFalse(os.path.exists(os.path.join(out, "results.json")))
        sys.stderr.write("%s on %s: the capture ended %.3f s after it, %d samples kept\n"
                         % (sig.name, scene, took, len(pts)))

    def test_sigterm_ends_a_capture_on_the_hot_scene(self):
        self.signal_ends_capture("hot", signal.SIGTERM)

    def test_sigint_ends_a_capture_on_the_dark_scene(self):
        self.signal_ends_capture("dark", signal.SIGINT)


class DaemonTests(unittest.TestCase):
    """goniod on its simulated rig with each scene (pace 0: points as fast
    as they compute)."""

    def start(self, scene):
        self.folder = tmpdir()
        self.d = Daemon(self.folder, scene=write_scenes(self.folder)[scene]).start()
        self.c = self.d.connect()
        self.c.request("watch")
        r = self.c.request("capture", plan="inplane-1deg", order="as-written", stop="all",
                           name="long")
        self.assertEqual(r["class"], "OK", r)
        wait_for_samples(os.path.join(self.d.root, "long", "samples.csv"), 3, self.d.proc,
                         3 * START_S)

    def tearDown(self):
        if getattr(self, "d", None):
            self.d.stop()
        shutil.rmtree(self.folder, ignore_errors=True)

    def test_abort_ends_a_capture_on_the_hot_scene(self):
        self.start("hot")
        stop, took = abort_timed(self)
        pts = journal_points(os.path.join(self.d.root, "long", "samples.csv"))
        self.assertEqual(len(pts), stop["samples"])
        sys.stderr.write("abort on hot: the capture ended %.3f s after it\n" % took)

    def test_sigterm_ends_goniod_on_the_dark_scene(self):
        self.start("dark")
        stop, took = sigterm_timed(self)
        pts = journal_points(os.path.join(self.d.root, "long", "samples.csv"))
        self.assertEqual(len(pts), stop["samples"])
        sys.stderr.write("SIGTERM on dark: goniod ended %.3f s after it\n" % took)


# The default rig with an integration far longer than STOP_S: on the ideal
# scene (no noise) every point integrates fixed_s of rig time, which at
# time scale 1 is as many wall seconds.
LONG_INTEGRATION_S = 8
SLOW_RIG = """name: slow
out_of_plane: true
blind_deg: 5
settle_s: 0.3
integration: {fixed_s: %g, auto_min_s: 0.001, auto_max_s: 2}
axes:
  sample:  {speed: 20, accel: 40, min: -90, max: 90}
  arm:     {speed: 15, accel: 30, min: -170, max: 170}
  azimuth: {speed: 30, accel: 60, min: -180, max: 180}
mechanics: {in_position_deg: 0.1, backlash_deg: 0.05, approach: positive, move_retries: 5}
""" % LONG_INTEGRATION_S


class ModbusTests(ModbusRig):
    """goniod on the Modbus drivers over TCP to gonio-sim at time scale 1,
    each point integrating LONG_INTEGRATION_S wall seconds."""
    SIM_SCALE = 1

    def start_long(self):
        """A capture on the slow rig, from its first sample into the next
        point's integration (settle 0.3 s and a move of a degree or two
        come before it)."""
        self.d = Daemon(self.folder, driver=self.tcp_driver(1)).start()
        with open(os.path.join(self.d.root, "slow.yaml"), "w") as f:
            f.write(SLOW_RIG)  # a request's rig path is taken in the capture root
        self.c = self.d.connect()
        self.c.request("watch")
        r = self.c.request("capture", plan="ds3", name="long", rig="slow.yaml")
        self.assertEqual(r["class"], "OK", r)
        while True:
            d = self.c.read()
            self.assertIsNotNone(d, "the stream ended before the first sample")
            self.assertNotEqual(d.get("class"), "stop", d)
            if d.get("class") == "event":
                break
        time.sleep(LONG_INTEGRATION_S / 4)
        return d["done"]

    def check_journal(self, stop, done):
        """The journal holds what the stop document says, the points before
        the stop request and nothing of the one it interrupted."""
        capdir = os.path.join(self.d.root, "long")
        pts = journal_points(os.path.join(capdir, "samples.csv"))
        self.assertEqual(len(pts), stop["samples"])
        self.assertEqual(len(pts), done)
        self.assertFalse(os.path.exists(os.path.join(capdir, "results.json")))
        return len(pts)

    def resume_then_abort(self, done):
        r = self.c.request("resume", capture_id="long")
        self.assertEqual(r["class"], "OK", r)
        while True:
            d = self.c.read()
            self.assertIsNotNone(d, "the stream ended before the resumed start")
            if d.get("class") == "start":
                break
        self.assertTrue(d["resume"])
        self.assertEqual(d["already_done"], done)
        self.assertEqual(self.c.request("abort")["class"], "OK")
        self.assertEqual(self.c.until_stop("long")[-1]["reason"], "aborted")

    def test_abort_ends_an_integration(self):
        done = self.start_long()
        stop, took = abort_timed(self)
        self.check_journal(stop, done)
        sys.stderr.write("abort over Modbus: the capture ended %.3f s after it\n" % took)
        self.resume_then_abort(done)

    def test_sigterm_ends_goniod_during_an_integration(self):
        done = self.start_long()
        stop, took = sigterm_timed(self)
        self.check_journal(stop, done)
        sys.stderr.write("SIGTERM over Modbus: goniod ended %.3f s after it\n" % took)
        self.d.start()
        self.c = self.d.connect()
        self.c.request("watch")
        self.resume_then_abort(done)


if __name__ == "__main__":
    unittest.main()
