#!/usr/bin/python3
"""goniod end to end: config checking (--check), the socket protocol, a
progressive capture's early stop and crash safety (kill -9 + resume). Each
test starts its own daemon in a fresh folder. The harness is
goniod_harness.py; captures and the gonio client are in
test_goniod_capture.py, the Modbus drivers in test_goniod_modbus.py, the
systemd notifications and offline captures in test_goniod_offline.py.

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \
      python3 tests/daemon/test_goniod.py -v
"""
import json
import os
import random
import re
import shutil
import socket
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import (GONIOD, MAX_LINE, SOURCE, START_S, Daemon, DaemonTest, journal_points,
                            plan_total, run_wrapped, shipped_config, tmpdir)


def position(text, key):
    """1-based line and column of `key:` in a YAML text (independent of the
    daemon's parser)."""
    for i, line in enumerate(text.splitlines(), 1):
        m = re.match(r"(\s*)" + re.escape(key) + r"\s*:", line)
        if m:
            return i, len(m.group(1)) + 1
    raise KeyError(key)


class CheckTests(unittest.TestCase):
    GOOD = ("rig: default\n"
            "driver:\n  kind: sim\n  scene: ideal\n  pace_s: 0.5\n"
            "capture_root: caps\n"
            "socket:\n  path: run/g.sock\n  max_clients: 4\n")

    def setUp(self):
        self.folder = tmpdir()

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def check(self, text):
        path = os.path.join(self.folder, "c.yaml")
        with open(path, "w") as f:
            f.write(text)
        r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
        return path, r

    def test_good_config_resolved(self):
        path, r = self.check(self.GOOD)
        self.assertEqual(r.returncode, 0, r.stderr)
        out = r.stdout
        # Relative paths come back taken from the config file's folder.
        self.assertIn("capture_root: %s/caps\n" % self.folder, out)
        self.assertIn("path: %s/run/g.sock\n" % self.folder, out)
        self.assertIn("pace_s: 0.5\n", out)
        self.assertIn("max_clients: 4\n", out)
        # The resolved form is itself a valid config that resolves to itself.
        path2, r2 = self.check(out)
        self.assertEqual(r2.returncode, 0, r2.stderr)
        strip = lambda s: "\n".join(l for l in s.splitlines() if not l.startswith("#"))
        self.assertEqual(strip(r2.stdout), strip(out))
        self.assertFalse(os.path.exists(os.path.join(self.folder, "caps")),
                         "--check must not create anything")

    def test_config_named_relative_to_the_working_directory(self):
        """--config c.yaml or sub/c.yaml: the paths still come back absolute,
        from the config's folder (they used to print as 'caps' and
        'sub/caps', relative to whatever folder goniod was started in)."""
        sub = os.path.join(self.folder, "sub")
        os.mkdir(sub)
        with open(os.path.join(sub, "c.yaml"), "w") as f:
            f.write(self.GOOD)
        for cwd, name in ((sub, "c.yaml"), (self.folder, "sub/c.yaml")):
            r = run_wrapped([GONIOD, "--config", name, "--check"], self.folder, cwd=cwd)
            self.assertEqual(r.returncode, 0, r.stderr)
            real = os.path.realpath(sub)  # getcwd's spelling
            self.assertIn("capture_root: %s/caps\n" % real, r.stdout)
            self.assertIn("path: %s/run/g.sock\n" % real, r.stdout)

    def test_rig_and_scene_files_beside_the_config(self):
        for sub, name in (("rigs", "default.yaml"), ("scenes", "ideal.yaml")):
            shutil.copy(os.path.join(SOURCE, "configs", sub, name),
                        os.path.join(self.folder, "my-" + name))
        path, r = self.check(self.GOOD.replace("rig: default", "rig: my-default.yaml")
                             .replace("scene: ideal", "scene: ./my-ideal.yaml"))
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("rig: %s/my-default.yaml\n" % self.folder, r.stdout)
        self.assertIn("scene: %s/./my-ideal.yaml\n" % self.folder, r.stdout)
        path, r = self.check(self.GOOD.replace("rig: default", "rig: none.yaml"))
        self.assertEqual(r.returncode, 2)
        self.assertIn("%s:1:" % path, r.stderr)

    def test_shipped_configs(self):
        for name in ("sim.yaml", "modbus-rtu.yaml", "modbus-tcp.yaml", "source-tree.yaml",
                     "modbus-tcp-rotating.yaml"):
            path = shipped_config(name, self.folder)
            r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
            self.assertEqual(r.returncode, 0, name + ": " + r.stderr)
        r = run_wrapped([GONIOD, "--config", shipped_config("modbus-rtu.yaml", self.folder),
                         "--check"], self.folder)
        for line in ("kind: modbus-rtu", "device: /dev/ttyUSB0", "baud: 115200",
                     "parity: none", "data_bits: 8", "stop_bits: 1", "arm: 2",
                     "detector: 3", "steps_per_deg: 100"):
            self.assertIn(line, r.stdout)

    def bad(self, text, key, needle):
        """text must be refused at key's line:col with needle in the message."""
        path, r = self.check(text)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertEqual(r.stdout, "")
        line, col = position(text, key)
        self.assertIn("%s:%d:" % (path, line), r.stderr)
        m = re.search(re.escape(path) + r":(\d+):(\d+): ", r.stderr)
        self.assertIsNotNone(m, r.stderr)
        self.assertEqual(int(m.group(1)), line, r.stderr)
        self.assertIn(needle, r.stderr)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)

    def test_unknown_key(self):
        self.bad(self.GOOD + "colour: blue\n", "colour", "colour")

    def test_unknown_driver_key(self):
        self.bad(self.GOOD.replace("  pace_s: 0.5\n", "  pace_s: 0.5\n  baud: 9600\n"), "baud",
                 "baud")

    def test_wrong_type(self):
        self.bad(self.GOOD.replace("max_clients: 4", "max_clients: many"), "max_clients",
                 "max_clients")

    def test_out_of_range(self):
        self.bad(self.GOOD.replace("pace_s: 0.5", "pace_s: -1"), "pace_s", "pace_s")

    def test_bad_driver_kind(self):
        self.bad(self.GOOD.replace("kind: sim", "kind: canbus"), "kind", "canbus")

    def test_bad_parity(self):
        text = ("driver:\n  kind: modbus-rtu\n  device: /dev/ttyS0\n  parity: mark\n"
                "capture_root: /tmp/x\nsocket:\n  path: /tmp/x.sock\n")
        self.bad(text, "parity", "parity")

    def test_tcp_needs_host(self):
        text = ("capture_root: /tmp/x\nsocket:\n  path: /tmp/x.sock\n"
                "driver:\n  kind: modbus-tcp\n  port: 1502\n")
        self.bad(text, "kind", "host")

    def test_shared_slave_ids(self):
        text = ("capture_root: /tmp/x\nsocket:\n  path: /tmp/x.sock\n"
                "driver:\n  kind: modbus-tcp\n  host: 127.0.0.1\n"
                "  slaves:\n    sample: 1\n    arm: 1\n")
        self.bad(text, "sample", "slave")

    def test_unknown_scene(self):
        self.bad(self.GOOD.replace("scene: ideal", "scene: no-such-scene"), "scene",
                 "no-such-scene")

    def test_missing_socket(self):
        text = "driver:\n  kind: sim\ncapture_root: /tmp/x\n"
        path, r = self.check(text)
        self.assertEqual(r.returncode, 2)
        self.assertRegex(r.stderr, re.escape(path) + r":\d+:\d+: .*socket")

    def test_yaml_syntax_error(self):
        path, r = self.check("driver: [kind: sim\n")
        self.assertEqual(r.returncode, 2)
        self.assertRegex(r.stderr, re.escape(path) + r":\d+:\d+: ")

    def test_usage(self):
        r = run_wrapped([GONIOD], self.folder)
        self.assertEqual(r.returncode, 2)
        r = run_wrapped([GONIOD, "--config", os.path.join(self.folder, "none.yaml"), "--check"],
                        self.folder)
        self.assertEqual(r.returncode, 2)
        self.assertIn("none.yaml", r.stderr)


# ---------------------------------------------------------------------------

class ProtocolTests(DaemonTest):
    pace_s = 0.02

    def test_version_on_connect(self):
        c = self.d.connect()
        self.assertEqual(c.version["class"], "VERSION")
        self.assertEqual(c.version["proto_major"], 1)
        self.assertEqual(c.version["proto_minor"], 0)
        self.assertIsInstance(c.version["release"], str)

    def expect_error(self, c, raw, code):
        c.send_raw(raw)
        d = c.read()
        self.assertEqual(d["class"], "ERROR", d)
        self.assertEqual(d["code"], code, d)
        self.assertTrue(d["message"])
        return d

    def test_bad_requests_leave_the_daemon_running(self):
        c = self.d.connect()
        r = c.request("capture", plan="ds3", name="p1")
        self.assertEqual(r["class"], "OK", r)
        self.expect_error(c, b"{not json\n", "bad-json")
        self.expect_error(c, b"[1, 2]\n", "bad-request")
        self.expect_error(c, b'{"id": 5}\n', "bad-request")
        d = self.expect_error(c, b'{"cmd": "explode", "id": "x1"}\n', "unknown-command")
        self.assertEqual(d["id"], "x1")
        d = self.expect_error(c, b'{"cmd": "status", "id": 7, "verbose": true}\n',
                              "unknown-field")
        self.assertEqual(d["id"], 7)
        self.assertIn("verbose", d["message"])
        self.expect_error(c, b'{"cmd": "resume", "capture_id": 12}\n', "bad-type")
        self.expect_error(c, b'{"cmd": 3}\n', "bad-request")
        self.expect_error(c, b'{"cmd": "status", "id": [1]}\n', "bad-type")
        self.expect_error(c, b'{"cmd": "status", "cmd": "status"}\n', "bad-json")
        # Still serving, and the capture went on to completion.
        st = c.request("status")
        self.assertEqual(st["class"], "STATUS")
        self.assertEqual(st["capture_id"], "p1")
        w = self.d.connect()
        self.assertEqual(w.request("watch")["class"], "OK")
        stop = w.until_stop("p1")[-1]
        self.assertEqual(stop["reason"], "complete")
        self.check_complete("p1")

    def test_oversized_line_closes_only_that_client(self):
        c = self.d.connect()
        other = self.d.connect()
        try:
            c.send_raw(b'{"cmd": "status", "pad": "' + b"x" * (MAX_LINE + 100))
        except OSError:
            pass
        d = c.read()
        self.assertEqual(d["class"], "ERROR")
        self.assertEqual(d["code"], "line-too-long")
        # Then the daemon closes the connection.
        try:
            self.assertIsNone(c.read())
        except ConnectionResetError:
            pass
        self.assertEqual(other.request("status")["class"], "STATUS")
        # A line just under the limit is read whole (and refused for its field).
        pad = MAX_LINE - len(b'{"cmd":"status","pad":""}')
        d = self.expect_error(other, b'{"cmd":"status","pad":"' + b"y" * pad + b'"}\n',
                              "unknown-field")

    def test_watcher_disconnect_mid_stream(self):
        c = self.d.connect()
        self.assertEqual(c.request("capture", plan="ds3", name="dis")["class"], "OK")
        for _ in range(3):
            w = self.d.connect()
            w.request("watch")
            while w.read()["class"] != "event":
                pass
            w.s.shutdown(socket.SHUT_RDWR)
            w.close()
        # A watcher that never reads and one that leaves half a request.
        lazy = self.d.connect()
        lazy.send({"cmd": "watch"})
        half = self.d.connect()
        half.send_raw(b'{"cmd": "sta')
        half.close()
        w = self.d.connect()
        w.request("watch")
        stop = w.until_stop("dis")[-1]
        self.assertEqual(stop["exit_status"], "success")
        self.assertTrue(self.d.alive())
        self.check_complete("dis")

    def test_paths_stay_inside_the_capture_root(self):
        c = self.d.connect()
        for args in ({"plan": "ds3", "name": "../escape"}, {"plan": "ds3", "name": "a/b"},
                     {"plan": "ds3", "name": ".hidden"}, {"plan": "/etc/passwd"},
                     {"plan": "../../configs/plans/ds3.yaml"}, {"plan": "ds3", "scene": "/x.yaml"},
                     {"plan": "ds3", "rig": "../rig.yaml"},
                     {"plan": "ds3", "material": "merl:/etc/passwd"},
                     {"plan": "ds3", "material": "merl:../x.binary"},
                     {"plan": "ds3", "material": "nbrdf:../../x"}):
            r = c.request("capture", **args)
            self.assertEqual(r["class"], "ERROR", args)
            self.assertEqual(r["code"], "bad-value", (args, r))
        for cid in ("../cap", "/tmp", "..", "a/../b"):
            r = c.request("resume", capture_id=cid)
            self.assertEqual(r["class"], "ERROR", cid)
        self.assertEqual(os.listdir(self.d.root) if os.path.isdir(self.d.root) else [], [])
        # A plan file inside the capture root is fine.
        os.makedirs(os.path.join(self.d.root, "plans"), exist_ok=True)
        shutil.copy(os.path.join(SOURCE, "configs", "plans", "ds3.yaml"),
                    os.path.join(self.d.root, "plans", "mine.yaml"))
        c.request("watch")
        r = c.request("capture", plan="plans/mine.yaml", name="inside")
        self.assertEqual(r["class"], "OK", r)
        self.assertEqual(c.until_stop("inside")[-1]["reason"], "complete")

    def test_socket_file(self):
        self.assertEqual(os.stat(self.d.sock).st_mode & 0o777, 0o660)
        # A second daemon on the same socket refuses to start; so does one
        # whose socket path is an ordinary file.
        r = run_wrapped([GONIOD, "--config", self.d.config], self.folder)
        self.assertEqual(r.returncode, 1)
        self.assertIn("another goniod", r.stderr)
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")
        other = tmpdir()
        try:
            with open(os.path.join(other, "s.sock"), "w") as f:
                f.write("precious")
            d2 = Daemon(other)
            r = run_wrapped([GONIOD, "--config", d2.config], other)
            self.assertEqual(r.returncode, 1)
            self.assertIn("not a socket", r.stderr)
            self.assertEqual(open(os.path.join(other, "s.sock")).read(), "precious")
        finally:
            shutil.rmtree(other, ignore_errors=True)

    def test_too_many_clients(self):
        self.d.stop()
        self.d = Daemon(self.folder, extra_socket="  max_clients: 2\n")
        self.d.start()
        a = self.d.connect()
        # start()'s probe connection counts until goniod has seen it close
        # (late under valgrind): b waits for its slot, then the third is one
        # too many.
        deadline = time.time() + START_S
        while True:
            b = self.d.connect()
            if b.version["class"] == "VERSION" or time.time() > deadline:
                break
            b.close()
            time.sleep(0.05)
        self.assertEqual(b.version["class"], "VERSION")
        s = socket.socket(socket.AF_UNIX)
        s.connect(self.d.sock)
        f = s.makefile("r")
        d = json.loads(f.readline())
        self.assertEqual(d["class"], "ERROR")
        self.assertEqual(d["code"], "too-many-clients")
        self.assertEqual(f.readline(), "")
        s.close()
        self.assertEqual(a.request("status")["class"], "STATUS")
        b.close()
        deadline = time.time() + START_S
        while True:  # until the daemon has seen b go
            c = self.d.connect()
            if c.version["class"] == "VERSION" or time.time() > deadline:
                break
            time.sleep(0.05)
        self.assertEqual(c.request("status")["class"], "STATUS")

    def test_idle_client_times_out_watcher_does_not(self):
        self.d.stop()
        self.d = Daemon(self.folder, extra_socket="  idle_timeout_s: 0.3\n")
        self.d.start()
        idle, watcher = self.d.connect(), self.d.connect()
        watcher.request("watch")
        d = idle.read()
        self.assertEqual(d["code"], "idle-timeout")
        self.assertIsNone(idle.read())
        time.sleep(0.5)
        r = self.d.connect().request("capture", plan="ds3", name="late")
        self.assertEqual(r["class"], "OK")
        self.assertEqual(watcher.until_stop("late")[-1]["reason"], "complete")

    def test_slow_watcher_is_dropped_not_waited_for(self):
        self.d.stop()
        self.d = Daemon(self.folder, pace_s=0, extra_socket="  max_queue_kib: 16\n")
        self.d.start()
        slow = socket.socket(socket.AF_UNIX)
        slow.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        slow.connect(self.d.sock)
        slow.sendall(b'{"cmd": "watch"}\n')
        time.sleep(0.1)
        # ds1 streams some 900 events (~400 kB, more than the kernel's
        # socket buffers hold) to a reader that reads nothing: the queue
        # limit must drop it while a reading watcher gets everything.
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("capture", plan="ds1", name="big")["class"], "OK")
        docs = c.until_stop("big")
        self.assertEqual(docs[-1]["reason"], "complete")
        self.assertEqual(sum(d["class"] == "event" for d in docs), docs[-1]["samples"])
        self.assertIn("dropped", open(self.d.log).read())
        slow.close()


# ---------------------------------------------------------------------------


class ConvergeTests(DaemonTest):
    """A progressive capture that the streaming fit's stop rule ends early."""

    def test_stop_converge(self):
        c = self.d.connect()
        c.request("watch")
        r = c.request("capture", plan="ds1", order="progressive", stop="converge", name="cv")
        self.assertEqual(r["class"], "OK", r)
        docs = c.until_stop("cv")
        self.assertEqual(docs[0]["stop"], "converge")
        stop = docs[-1]
        total = plan_total(os.path.join(self.d.root, "cv"))
        self.assertEqual(stop["reason"], "converged", stop)
        self.assertEqual(stop["exit_status"], "success")
        self.assertLess(stop["samples"], total)
        pts = journal_points(os.path.join(self.d.root, "cv", "samples.csv"))
        self.assertEqual(len(pts), stop["samples"])
        self.assertEqual(len(set(pts)), len(pts))
        self.assertTrue(os.path.exists(os.path.join(self.d.root, "cv", "results.json")))
        self.assertEqual(c.request("capture", plan="ds3", stop="sometimes")["code"],
                         "bad-value")

# ---------------------------------------------------------------------------

class CrashTests(DaemonTest):
    pace_s = 0.02

    def test_kill9_at_random_moments_then_resume(self):
        # CI kills 4 times during DS3; GONIO_CRASH_KILLS=20 GONIO_CRASH_PLAN=ds1
        # runs the longer torture by hand.
        kills = int(os.environ.get("GONIO_CRASH_KILLS", "4"))
        plan = os.environ.get("GONIO_CRASH_PLAN", "ds3")
        rng = random.Random(20261122)
        c = self.d.connect()
        self.assertEqual(c.request("capture", plan=plan, name="crash")["class"], "OK")
        capdir = os.path.join(self.d.root, "crash")
        journal = os.path.join(capdir, "samples.csv")
        counts = []
        for _ in range(kills):
            time.sleep(rng.uniform(0.05, 0.3))
            self.d.kill9()
            self.assertTrue(os.path.exists(self.d.sock), "kill -9 leaves the socket file")
            pts = journal_points(journal) if os.path.exists(journal) else []
            # Whatever the moment, the journal never holds a point twice.
            self.assertEqual(len(pts), len(set(pts)))
            counts.append(len(pts))
            self.d.start()  # replaces the stale socket
            c = self.d.connect()
            self.assertEqual(c.request("status")["state"], "idle")
            c.request("watch")
            r = c.request("resume", capture_id="crash", refit=True)  # even if it completed
            self.assertEqual(r["class"], "OK", r)
            start = c.read()
            self.assertEqual(start["class"], "start")
            self.assertEqual(start["already_done"], len(pts))
        total = plan_total(capdir)
        self.assertEqual(counts, sorted(counts))
        self.assertTrue(any(0 < n < total for n in counts), counts)
        stop = c.until_stop("crash")[-1]
        self.assertEqual(stop["exit_status"], "success", stop)
        self.assertEqual(stop["samples"], total)
        self.check_complete("crash")

    def test_kill9_through_gonio(self):
        r = self.d.gonio("capture", "--plan", "ds3", "--name", "gk")
        self.assertEqual(r.returncode, 0, r.stderr)
        time.sleep(0.15)
        self.d.kill9()
        self.d.start()
        r = self.d.gonio("resume", "gk")
        self.assertEqual(r.returncode, 0, r.stderr)
        r = self.d.gonio("watch")
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("stopped: complete", r.stdout)
        self.check_complete("gk")


# ---------------------------------------------------------------------------

if __name__ == "__main__":
    unittest.main()
