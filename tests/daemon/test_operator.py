#!/usr/bin/python3
"""What an operator reads of goniod's captures, end to end on the simulated
rig: the list of captures and their states (an interrupted one after a
kill -9, an aborted one, a complete one), the command that resumes one,
and a resume that leaves a complete capture alone (ListTests); the final
fit's verdict and plan-domain error wherever a capture's end is shown
(VerdictTests); the sample's name, the operator and a note kept with a
capture, and a hardware rig's material that must resolve (MetadataTests).

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \
      python3 tests/daemon/test_operator.py -v
"""
import json
import os
import re
import shutil
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import (GONIO, START_S, Daemon, DaemonTest, tmpdir, journal_points, load_json,  # noqa: E402
                            plan_total, rig_times)
import child_procs  # noqa: E402


def wait_idle(t):
    """Until goniod runs no capture (status), within START_S."""
    deadline = time.monotonic() + 2 * START_S
    while True:
        st = json.loads(t.d.gonio("status", "--json").stdout)
        if st["state"] == "idle":
            return st
        t.assertLess(time.monotonic(), deadline, "the capture did not end")
        time.sleep(0.05)


class ListTests(DaemonTest):
    pace_s = 0.02

    def listed(self):
        r = self.d.gonio("list", "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout)
        return {e["id"]: e for e in doc["captures"]}, [e["id"] for e in doc["captures"]]

    def start_and_wait_for_samples(self, c, name):
        c.request("watch")
        self.assertEqual(c.request("capture", plan="ds3", name=name)["class"], "OK")
        seen = 0
        while seen < 3:
            if c.read()["class"] == "event":
                seen += 1

    def test_interrupted_aborted_complete(self):
        r = self.d.gonio("capture", "--plan", "ds4", "--name", "done", "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)

        # Aborted by the operator: abort names the command that resumes it.
        c = self.d.connect()
        self.start_and_wait_for_samples(c, "ab")
        caps, _ = self.listed()
        self.assertEqual(caps["ab"]["state"], "running")
        r = self.d.gonio("abort")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("gonio resume ab", r.stdout)
        c.until_stop("ab")

        # Interrupted: goniod killed mid-capture, then started again.
        c = self.d.connect()
        self.start_and_wait_for_samples(c, "cut")
        self.d.kill9()
        self.d.conns = []
        self.d.start()

        caps, order = self.listed()
        self.assertEqual(order, ["cut", "ab", "done"])
        for cid, state in (("cut", "interrupted"), ("ab", "aborted"), ("done", "complete")):
            capdir = os.path.join(self.d.root, cid)
            e = caps[cid]
            self.assertEqual(e["state"], state, e)
            self.assertEqual(e["plan"], "ds3" if cid != "done" else "ds4")
            self.assertEqual(e["samples_done"],
                             len(journal_points(os.path.join(capdir, "samples.csv"))))
            self.assertEqual(e["samples_total"], plan_total(capdir))
            self.assertAlmostEqual(e["rig_time_s"], rig_times(capdir)[-1], places=3)
            self.assertRegex(e["last_change"], r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ$")
        self.assertLess(caps["cut"]["samples_done"], caps["cut"]["samples_total"])
        self.assertEqual(caps["done"]["samples_done"], caps["done"]["samples_total"])

        # The table names them too.
        table = self.d.gonio("list").stdout.splitlines()
        self.assertEqual([line.split()[:3] for line in table[1:]],
                         [["cut", "ds3", "interrupted"], ["ab", "ds3", "aborted"],
                          ["done", "ds4", "complete"]])

        # status: idle, and the newest capture with the command that resumes it.
        out = self.d.gonio("status").stdout
        self.assertIn("newest capture cut: interrupted", out)
        self.assertIn("resume it with: gonio resume cut", out)
        self.assertEqual(self.d.gonio("resume", "cut").returncode, 0)
        wait_idle(self)
        self.check_complete("cut")
        self.assertEqual(self.listed()[0]["cut"]["state"], "complete")

    def test_resume_of_a_complete_capture_changes_nothing(self):
        r = self.d.gonio("capture", "--plan", "ds4", "--name", "done", "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        capdir = os.path.join(self.d.root, "done")
        files = {n: open(os.path.join(capdir, n), "rb").read() for n in os.listdir(capdir)
                 if n != "lock"}
        stamp = os.stat(os.path.join(capdir, "results.json")).st_mtime_ns
        r = self.d.gonio("resume", "done")
        self.assertEqual(r.returncode, 2, r.stdout)
        self.assertIn("'done' is complete", r.stderr)
        self.assertEqual(self.d.connect().request("resume", capture_id="done")["code"],
                         "complete")
        time.sleep(0.2)
        self.assertEqual({n: open(os.path.join(capdir, n), "rb").read() for n in files}, files)
        self.assertEqual(os.stat(os.path.join(capdir, "results.json")).st_mtime_ns, stamp)
        # --refit fits again: results.json is written anew.
        r = self.d.gonio("resume", "done", "--refit")
        self.assertEqual(r.returncode, 0, r.stderr)
        wait_idle(self)
        self.assertNotEqual(os.stat(os.path.join(capdir, "results.json")).st_mtime_ns, stamp)
        self.assertEqual(load_json(os.path.join(capdir, "stop.json"))["state"], "complete")

    def test_shutdown_interrupts(self):
        c = self.d.connect()
        self.start_and_wait_for_samples(c, "sd")
        self.d.stop()
        self.d.start()
        caps, _ = self.listed()
        self.assertEqual((caps["sd"]["state"], caps["sd"]["reason"]), ("interrupted", "shutdown"))
        self.assertIn("gonio resume sd", self.d.gonio("status").stdout)

    def test_resumed_then_killed_is_interrupted(self):
        """A resume clears the earlier run's end: killed during it, the
        capture is interrupted, not still aborted."""
        c = self.d.connect()
        self.start_and_wait_for_samples(c, "ra")
        self.assertEqual(c.request("abort")["class"], "OK")
        c.until_stop("ra")
        self.assertEqual(self.listed()[0]["ra"]["state"], "aborted")
        self.assertEqual(c.request("resume", capture_id="ra")["class"], "OK")
        while c.read()["class"] != "event":
            pass
        self.d.kill9()
        self.d.conns = []
        self.d.start()
        self.assertEqual(self.listed()[0]["ra"]["state"], "interrupted")


class VerdictTests(DaemonTest):
    """DS4 is six pairs for ABC's nine parameters: the final fit is
    underdetermined, however small its plan-domain error, and every place
    that shows the error says so."""

    pace_s = 0.1  # DS4's six points last long enough to pause the capture

    def test_underdetermined_fit_is_said_everywhere(self):
        # watch subscribes while the capture is held paused: its start line
        # says it is following, and the stop is still to come.
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("capture", plan="ds4", name="few")["class"], "OK")
        while c.read()["class"] != "start":  # the start a late watcher is sent
            pass
        self.assertEqual(c.request("pause")["class"], "OK")
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        watch = subprocess.Popen([GONIO, "watch", "--quiet"], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True, env=env,
                                 preexec_fn=child_procs.die_with_parent)
        self.assertTrue(watch.stdout.readline().startswith("capture few: plan ds4"))
        self.assertEqual(c.request("resume")["class"], "OK")
        out, err = watch.communicate(timeout=2 * START_S)
        results = load_json(os.path.join(self.d.root, "few", "results.json"))
        verdict, plan_log = results["fit_status"]["status"], results["errors"]["plan"]["log"]
        self.assertEqual(verdict, "underdetermined")
        line = "fit abc: underdetermined, plan log error %.4f" % plan_log
        self.assertIn(line, out, err)

        st = json.loads(self.d.gonio("status", "--json").stdout)
        self.assertEqual(st["fit_error"]["status"], verdict)
        self.assertAlmostEqual(st["fit_error"]["log_error"], plan_log, places=9)
        out = self.d.gonio("status").stdout
        self.assertIn("log error %.4f, relative RMSE" % plan_log, out)
        self.assertIn(", underdetermined\n", out)
        self.assertIn("fit underdetermined, plan log error %.4f" % plan_log, out)
        listed = json.loads(self.d.gonio("list", "--json").stdout)["captures"][0]
        self.assertEqual(listed["fit_status"], verdict)
        self.assertAlmostEqual(listed["plan_log_error"], plan_log, places=9)
        table = self.d.gonio("results", os.path.join(self.d.root, "few")).stdout.splitlines()
        cells = dict(zip(re.split(r"  +", table[0].strip()), re.split(r"  +", table[1].strip())))
        self.assertEqual((cells["fit status"], cells["plan log"]), (verdict, "%.4f" % plan_log))

        # --wait says the same of the next capture.
        r = self.d.gonio("capture", "--plan", "ds4", "--name", "again", "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        again = load_json(os.path.join(self.d.root, "again", "results.json"))
        self.assertIn("fit abc: underdetermined, plan log error %.4f"
                      % again["errors"]["plan"]["log"], r.stdout)

class MetadataTests(DaemonTest):
    META = {"sample": "PTFE puck 3", "operator": "Ana Lima", "note": "after cleaning, 21 C"}

    def test_metadata_kept_and_listed(self):
        c = self.d.connect()
        c.request("watch")
        r = self.d.gonio("capture", "--plan", "ds4", "--name", "m1", "--sample",
                         self.META["sample"], "--operator", self.META["operator"], "--note",
                         self.META["note"], "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        start = next(d for d in c.until_stop("m1") if d["class"] == "start")
        files = [load_json(os.path.join(self.d.root, "m1", name))
                 for name in ("request.json", "setup.json", "results.json")]
        listed = json.loads(self.d.gonio("list", "--json").stdout)["captures"][0]
        for key, value in self.META.items():
            self.assertEqual([start[key], listed[key]] + [f[key] for f in files], [value] * 5)
        self.assertIn(self.META["sample"], self.d.gonio("list").stdout.splitlines()[1])
        # A resume keeps them (request.json is read back), and its refit's
        # results.json names them as setup.json does.
        os.unlink(os.path.join(self.d.root, "m1", "results.json"))
        self.assertEqual(self.d.gonio("resume", "m1", "--refit").returncode, 0)
        wait_idle(self)
        self.assertEqual(load_json(os.path.join(self.d.root, "m1", "request.json"))["note"],
                         self.META["note"])
        for name in ("setup.json", "results.json"):
            self.assertEqual(load_json(os.path.join(self.d.root, "m1", name))["operator"],
                             self.META["operator"])

    def test_metadata_absent_is_null(self):
        r = self.d.gonio("capture", "--plan", "ds4", "--name", "m0", "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        for name in ("setup.json", "results.json"):
            got = load_json(os.path.join(self.d.root, "m0", name))
            self.assertEqual([got[k] for k in self.META], [None] * 3, name)

    def test_bad_metadata_is_refused(self):
        for args in (["--note", "two\nlines"], ["--operator", "x" * 200]):
            r = self.d.gonio("capture", "--plan", "ds4", "--name", "bad", *args)
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn(args[0][2:], r.stderr)
        self.assertEqual(os.listdir(self.d.root) if os.path.isdir(self.d.root) else [], [])


class HardwareMaterialTests(unittest.TestCase):
    """On a Modbus rig goniod cannot measure a material it is told: a spec
    that does not resolve is refused before anything is created or any
    device is opened (no gonio-sim needed: nothing is opened)."""

    def setUp(self):
        self.folder = tmpdir()
        driver = ("  kind: modbus-tcp\n  host: 127.0.0.1\n  port: 1\n"
                  "  slaves: {sample: 1, arm: 2, detector: 3, azimuth: 4}\n")
        self.d = Daemon(self.folder, driver=driver).start()

    def tearDown(self):
        self.d.stop()
        shutil.rmtree(self.folder, ignore_errors=True)

    def test_unresolved_material_is_refused(self):
        for spec in ("foo", "nbrdf:unobtainium"):
            r = self.d.gonio("capture", "--plan", "ds4", "--name", "hw", "--material", spec)
            self.assertEqual(r.returncode, 2, (spec, r.stdout, r.stderr))
            self.assertIn("material '%s' does not resolve" % spec, r.stderr)
        self.assertEqual(os.listdir(self.d.root) if os.path.isdir(self.d.root) else [], [])


if __name__ == "__main__":
    unittest.main()
