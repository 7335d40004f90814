#!/usr/bin/python3
"""goniod's defences (docs/goniod.md, Security): who may connect (socket
mode, folder mode, peer credentials), what one client may cost the others
(rate limit, output limit, slow and silent clients) and where a request's
paths may lead (the capture root, symbolic links included). Each test starts
its own daemon on the simulated rig, like test_goniod.py, with the helpers
of goniod_harness.py.
"""
import grp
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import GONIOD, SOURCE, START_S, Conn, Daemon, DaemonTest, journal_points, plan_total, tmpdir  # noqa: E402

DS3 = os.path.join(SOURCE, "configs", "plans", "ds3.yaml")


def config_socket(d, path="s.sock", extra=""):
    """Rewrite d's config so the socket lives at path (relative to the
    folder) with extra socket keys."""
    text = open(d.config).read()
    head = text[:text.index("socket:\n")]
    with open(d.config, "w") as f:
        f.write(head + "socket:\n  path: %s\n%s" % (path, extra))
    d.sock = os.path.join(d.folder, path)


def nobody_ids():
    """uid and gid of an unprivileged account to connect as (root only)."""
    return 65534, 65534


def connect_as(sock, uid, gid, groups, script):
    """Run script (Python, with `s` a socket connected to sock, or the
    connect error printed) as uid/gid/groups; returns its stdout lines."""
    code = ("import socket, sys\n"
            "s = socket.socket(socket.AF_UNIX)\n"
            "s.settimeout(20)\n"
            "try:\n"
            "    s.connect(%r)\n"
            "except OSError as e:\n"
            "    print('CONNECT-ERROR', e.errno); sys.exit(0)\n"
            "f = s.makefile('rb')\n" % sock) + script
    r = subprocess.run(["/usr/bin/python3", "-c", code], user=uid, group=gid,
                       extra_groups=groups, capture_output=True, text=True, timeout=60)
    if r.returncode != 0:
        raise AssertionError("client failed: " + r.stderr)
    return r.stdout.splitlines()


# ---------------------------------------------------------------------------

class AccessTests(DaemonTest):
    """The socket's mode and folder, and the peer-credential check."""

    def restart(self, path="s.sock", extra=""):
        self.d.stop()
        self.d = Daemon(self.folder)
        config_socket(self.d, path, extra)
        self.d.start()

    def test_socket_folder_and_mode(self):
        # goniod creates a missing socket folder 0750 (operators reach the
        # socket through the group, others cannot even look in) and the
        # socket 0660 in the configured group.
        group = grp.getgrnam("dialout") if "dialout" in [g.gr_name for g in grp.getgrall()] else None
        if group is None or os.geteuid() != 0:
            extra = ""
        else:
            extra = "  group: dialout\n"
        self.restart("run/gd/s.sock", extra)
        st = os.stat(os.path.join(self.folder, "run", "gd"))
        self.assertEqual(st.st_mode & 0o777, 0o750)
        sk = os.stat(self.d.sock)
        self.assertEqual(sk.st_mode & 0o777, 0o660)
        if extra:
            self.assertEqual(st.st_gid, group.gr_gid)
            self.assertEqual(sk.st_gid, group.gr_gid)
        else:
            sys.stderr.write("(not root or no group dialout: socket group not checked)\n")
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")

    def restart_reachable(self):
        """Restart with the socket (group dialout) in a fresh folder anyone
        may pass: the test's own folder may sit below a 0700 one (a checkout
        under /root or in mktemp -d) that nobody cannot pass."""
        if os.geteuid() != 0:
            self.skipTest("needs root to connect as other users (SKIPPED: peer credentials)")
        if "dialout" not in [g.gr_name for g in grp.getgrall()]:
            self.skipTest("no group dialout to allow (SKIPPED: peer credentials)")
        folder = tempfile.mkdtemp(prefix="gds", dir="/tmp")
        self.addCleanup(shutil.rmtree, folder, True)
        os.chmod(folder, 0o755)
        self.restart(os.path.join(folder, "s.sock"), "  group: dialout\n")

    def test_peer_credentials(self):
        self.restart_reachable()
        allowed = grp.getgrnam("dialout").gr_gid
        uid, gid = nobody_ids()
        # Prints the first line, asks for status, prints every further line
        # up to the end of the stream, then EOF.
        probe = ("print(f.readline().decode().strip())\n"
                 "try:\n"
                 "    s.sendall(b'{\"cmd\": \"status\", \"id\": 1}\\n')\n"
                 "    s.shutdown(socket.SHUT_WR)\n"
                 "    for line in f:\n"
                 "        print(line.decode().strip())\n"
                 "except OSError:\n"
                 "    pass\n"
                 "print('EOF')\n")
        # First fence: the file mode keeps a stranger out before goniod
        # sees it.
        out = connect_as(self.d.sock, uid, gid, [], probe)
        self.assertEqual(out[0], "CONNECT-ERROR 13", out)  # EACCES
        # A member of the allowed group, as a supplementary group (the usual
        # way) and as the primary group, is served.
        for g, extra in ((gid, [allowed]), (allowed, [])):
            out = connect_as(self.d.sock, uid, g, extra, probe)
            self.assertEqual(json.loads(out[0])["class"], "VERSION", out)
            self.assertEqual(json.loads(out[1])["class"], "STATUS", out)
        # Second fence: with the socket opened to everyone by mistake, the
        # kernel's credentials still refuse the stranger: one error line,
        # then the connection is closed, and the refusal is logged.
        os.chmod(self.d.sock, 0o666)
        out = connect_as(self.d.sock, uid, gid, [], probe)
        err = json.loads(out[0])
        self.assertEqual(err["class"], "ERROR", out)
        self.assertEqual(err["code"], "not-authorized", out)
        self.assertEqual(out[1:], ["EOF"], out)  # no reply to its request
        log = open(self.d.log).read()
        self.assertIn("refused client", log)
        self.assertIn("uid %d" % uid, log)
        # The daemon's own user (root here) is still served.
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")

    def test_refusals_logged_with_a_count(self):
        # A stranger connecting in a loop to a socket opened to everyone by
        # mistake: each connection refused, the first few logged in full,
        # the rest counted in one line per 10 s window (and at shutdown),
        # not one line each (~95,000 lines in 5 s before).
        self.restart_reachable()
        os.chmod(self.d.sock, 0o666)
        uid, gid = nobody_ids()
        n = 300
        loop = ("refused = [f.readline()]\n"
                "for _ in range(%d):\n"
                "    s = socket.socket(socket.AF_UNIX)\n"
                "    s.settimeout(20)\n"
                "    s.connect(%r)\n"
                "    refused.append(s.makefile('rb').readline())\n"
                "    s.close()\n"
                "print(sum(b'not-authorized' in r for r in refused))\n" % (n - 1, self.d.sock))
        t0 = time.time()
        self.assertEqual(connect_as(self.d.sock, uid, gid, [], loop), [str(n)])
        windows = (time.time() - t0) // 10 + 1
        self.d.stop()
        log = open(self.d.log).read()
        logged = log.count("refused client")
        counted = [int(k) for k in re.findall(r"\.\.\. and (\d+) more refused in the last "
                                              r"\d+ s\n", log)]
        self.assertEqual(logged + sum(counted), n, log)
        self.assertLessEqual(logged, 5 * windows, log)
        self.assertLessEqual(len(counted), windows, log)


# ---------------------------------------------------------------------------

class LimitTests(DaemonTest):
    """One client cannot stall the capture or starve the others."""
    pace_s = 0.01

    def restart(self, extra, pace_s=None):
        self.d.stop()
        self.d = Daemon(self.folder, pace_s=self.pace_s if pace_s is None else pace_s,
                        extra_socket=extra)
        self.d.start()

    def status_while(self, capture_id, busy):
        """Ask for status from a fresh client until the capture is over or
        busy() is false; return the points_done seen."""
        seen = []
        c = self.d.connect()
        while True:
            st = c.request("status")
            self.assertEqual(st["class"], "STATUS", st)
            if st["capture_id"] != capture_id or not busy():
                return seen
            seen.append(st["points_done"])
            time.sleep(0.05)

    def test_flood_is_rate_limited_daemon_stays_responsive(self):
        self.restart("  rate_per_s: 5\n  burst: 10\n")
        w = self.d.connect()
        w.request("watch")
        self.assertEqual(w.request("capture", plan="ds3", name="fl")["class"], "OK")
        flood = self.d.connect()
        n = 500
        t0 = time.time()
        flood.send_raw(b"".join(b'{"cmd": "status", "id": %d}\n' % i for i in range(n)))
        replies = [flood.read() for _ in range(n)]
        elapsed = time.time() - t0
        # Every request is answered, in order, each with its own id: run
        # or refused, never left hanging.
        self.assertEqual([r["id"] for r in replies], list(range(n)))
        ok = [r for r in replies if r["class"] == "STATUS"]
        limited = [r for r in replies if r.get("code") == "rate-limited"]
        self.assertEqual(len(ok) + len(limited), n, replies[:3])
        # The bucket: the burst, plus what refilled meanwhile.
        self.assertGreaterEqual(len(ok), 10)
        self.assertLessEqual(len(ok), 10 + 5 * elapsed + 1)
        # The limit is per client: another one is served at once, and the
        # flooder itself again once the bucket refilled.
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")
        time.sleep(0.5)
        self.assertEqual(flood.request("status")["class"], "STATUS")
        self.assertEqual(w.until_stop("fl")[-1]["reason"], "complete")
        self.check_complete("fl")

    def test_refill_follows_the_configured_rate(self):
        # The bucket's refill, bounded both ways by the configured rate
        # alone. Too slow: after a refusal the bucket holds less than one
        # token, and 1/rate seconds later (the client's sleep; host delays
        # only add to it) it holds at least one, so the next request must
        # be served. Too fast: over the whole exchange at most the burst
        # plus rate x the time the client saw pass are served, since the
        # daemon's time between its first and last answer lies inside it.
        rate, burst, waits = 5.0, 4, 15
        self.restart("  rate_per_s: %g\n  burst: %d\n" % (rate, burst))
        t0 = time.monotonic()
        c = self.d.connect()
        served = 0
        for _ in range(waits):
            while True:
                r = c.request("status")
                if r["class"] != "STATUS":
                    break
                served += 1
            self.assertEqual(r.get("code"), "rate-limited", r)
            time.sleep(1.05 / rate)
            r = c.request("status")
            self.assertEqual(r["class"], "STATUS",
                             "refused %.2f s after a refusal at %g requests/s: %r"
                             % (1.05 / rate, rate, r))
            served += 1
        elapsed = time.monotonic() - t0
        self.assertLessEqual(served, burst + rate * elapsed + 0.5,
                             "%d served in %.2f s at %g/s, bursts of %d"
                             % (served, elapsed, rate, burst))

    def test_empty_lines_spend_tokens(self):
        # An empty line is a request as far as the rate limit goes: a burst
        # of them leaves no token for the real request behind them (the
        # refill, 0.01 a second, adds none meanwhile).
        self.restart("  rate_per_s: 0.01\n  burst: 10\n")
        c = self.d.connect()
        c.send_raw(b"\n" * 6 + b"\r\n" * 4 + b'{"cmd": "status", "id": "late"}\n')
        r = c.read()
        self.assertEqual((r["class"], r.get("code"), r.get("id")),
                         ("ERROR", "rate-limited", "late"), r)

    def test_empty_line_clients_do_not_lock_out(self):
        # max_clients (16) connections that send only empty lines, under the
        # rate limit, are not activity: the idle timeout closes them, and a
        # seventeenth client gets in.
        self.restart("  idle_timeout_s: 1\n  rate_per_s: 5\n  burst: 10\n")
        stop = threading.Event()
        held = []
        while len(held) < 16:
            s = socket.socket(socket.AF_UNIX)
            s.settimeout(20)
            s.connect(self.d.sock)
            f = s.makefile("rb")
            first = json.loads(f.readline())
            if first["class"] == "VERSION":
                held.append((s, f))
            else:  # start()'s probe not yet reaped
                self.assertEqual(first.get("code"), "too-many-clients", first)
                s.close()
                time.sleep(0.05)

        def keep_sending(s):
            while not stop.is_set():
                try:
                    s.sendall(b"\n")
                except OSError:
                    return  # closed by goniod
                stop.wait(0.3)

        threads = [threading.Thread(target=keep_sending, args=(s,)) for s, _ in held]
        for t in threads:
            t.start()
        try:
            admitted = None
            deadline = time.monotonic() + 6 * START_S
            while admitted is None and time.monotonic() < deadline:
                s = socket.socket(socket.AF_UNIX)
                s.settimeout(20)
                s.connect(self.d.sock)
                first = json.loads(s.makefile("rb").readline())
                s.close()
                if first["class"] == "VERSION":
                    admitted = first
                else:
                    self.assertEqual(first.get("code"), "too-many-clients", first)
                    time.sleep(0.2)
            self.assertIsNotNone(admitted, "16 clients sending empty lines kept the 17th out "
                                 "for %d s with idle_timeout_s 1" % (6 * START_S))
        finally:
            stop.set()
            for t in threads:
                t.join()
        # Each was closed by the idle timeout, and told so last.
        for s, f in held:
            lines = f.read().splitlines()
            codes = [json.loads(x).get("code") for x in lines]
            self.assertEqual(codes[-1:], ["idle-timeout"], codes)
            s.close()
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")

    def test_flooder_that_never_reads_is_dropped(self):
        # Refusals are output too: a flooder that does not read them fills
        # its output limit and is dropped; the capture and the other
        # clients carry on.
        self.restart("  rate_per_s: 5\n  burst: 10\n  max_queue_kib: 16\n")
        w = self.d.connect()
        w.request("watch")
        self.assertEqual(w.request("capture", plan="ds3", name="nr")["class"], "OK")
        s = socket.socket(socket.AF_UNIX)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        s.connect(self.d.sock)
        s.settimeout(20)
        line = b'{"cmd": "status"}\n' * 4096
        dropped = False
        try:
            for _ in range(2000):  # at most ~150 MB; the drop comes long before
                s.sendall(line)
        except OSError:
            dropped = True  # EPIPE/ECONNRESET: goniod closed it
        self.assertTrue(dropped)
        self.assertIn("too slow to read its output", open(self.d.log).read())
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")
        self.assertEqual(w.until_stop("nr")[-1]["reason"], "complete")
        self.check_complete("nr")
        s.close()

    def test_watcher_that_never_reads(self):
        # A watcher that subscribes and then never reads (a hung or stopped
        # client): within its output limit it is kept, beyond it dropped;
        # either way the capture completes and status is answered all along.
        self.restart("  max_queue_kib: 16\n", pace_s=0.002)
        lazy = socket.socket(socket.AF_UNIX)
        lazy.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        lazy.connect(self.d.sock)
        lazy.sendall(b'{"cmd": "watch"}\n')
        time.sleep(0.1)
        c = self.d.connect()
        self.assertEqual(c.request("capture", plan="ds1", name="lz")["class"], "OK")
        seen = self.status_while("lz", lambda: True)
        # status was answered while the capture ran, and saw it progress.
        self.assertGreater(len(seen), 1)
        self.assertEqual(seen, sorted(seen))
        self.assertLess(seen[0], seen[-1])
        pts = journal_points(os.path.join(self.d.root, "lz", "samples.csv"))
        self.assertEqual(sorted(pts), list(range(plan_total(os.path.join(self.d.root, "lz")))))
        self.assertIn("too slow to read its output", open(self.d.log).read())
        lazy.close()

    def test_byte_by_byte_client(self):
        # A client that sends its request a byte at a time: the capture and
        # the other clients do not wait for it, and its request is run once
        # whole.
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("capture", plan="ds3", name="bb")["class"], "OK")
        slow = self.d.connect()
        req = b'{"cmd": "status", "id": "slow"}\n'
        done = threading.Event()

        def trickle():
            for b in req:
                slow.send_raw(bytes([b]))
                time.sleep(0.05)
            done.set()

        t = threading.Thread(target=trickle)
        t.start()
        seen = self.status_while("bb", lambda: not done.is_set())
        t.join()
        self.assertGreater(len(seen), 1)  # others were served meanwhile
        self.assertLess(seen[0], seen[-1])  # and the capture moved on
        r = slow.read()
        self.assertEqual((r["class"], r["id"]), ("STATUS", "slow"))
        self.assertEqual(c.until_stop("bb")[-1]["reason"], "complete")
        self.check_complete("bb")

    def test_trickle_without_newline_times_out(self):
        # Bytes that never make a request are not activity: such a client
        # (slowloris) is closed by the idle timeout like a silent one.
        self.restart("  idle_timeout_s: 0.5\n")
        slow = self.d.connect()
        got = None
        for _ in range(60):
            try:
                slow.send_raw(b" ")
            except OSError:
                break
            slow.s.settimeout(0.1)
            try:
                got = slow.read()
                break
            except socket.timeout:
                pass
        self.assertIsNotNone(got, "a trickling client was kept for 6 s")
        self.assertEqual(got["code"], "idle-timeout")
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")


# ---------------------------------------------------------------------------

class PathBase(DaemonTest):
    """A daemon with a capture root and a folder outside it."""
    pace_s = 0.0

    def setUp(self):
        super().setUp()
        self.root = self.d.root
        os.makedirs(self.root, exist_ok=True)
        self.outside = os.path.join(self.folder, "outside")
        os.makedirs(self.outside)
        # A perfectly good plan, just not inside the capture root.
        shutil.copy(DS3, os.path.join(self.outside, "ds3.yaml"))
        self.c = self.d.connect()
        self.c.request("watch")

    def refused(self, code="bad-value", **args):
        r = self.c.request("capture", **args)
        self.assertEqual(r["class"], "ERROR", (args, r))
        self.assertEqual(r["code"], code, (args, r))
        return r

    def outside_untouched(self):
        self.assertEqual(sorted(os.listdir(self.outside)), ["ds3.yaml"])


class PathTests(PathBase):
    """Paths in requests stay inside the capture root, links included. No
    capture runs here."""

    def test_symlinked_files_pointing_out_are_refused(self):
        os.symlink(os.path.join(self.outside, "ds3.yaml"), os.path.join(self.root, "p.yaml"))
        r = self.refused(plan="p.yaml", name="x1")
        self.assertIn("outside the capture root", r["message"])
        os.symlink(self.outside, os.path.join(self.root, "plans"))
        self.refused(plan="plans/ds3.yaml", name="x2")
        self.refused(plan="ds3", scene="p.yaml", name="x3")
        self.refused(plan="ds3", rig="plans/ds3.yaml", name="x4")
        self.refused(plan="ds3", material="merl:plans/ds3.yaml", name="x5")
        r = self.refused(plan="missing/none.yaml", name="x6")
        self.assertIn("no such file", r["message"])
        # None of these created a capture.
        self.assertEqual(sorted(os.listdir(self.root)), ["p.yaml", "plans"])
        self.outside_untouched()

    def test_capture_name_that_is_a_link(self):
        os.symlink(self.outside, os.path.join(self.root, "ln"))
        os.symlink(os.path.join(self.folder, "nowhere"), os.path.join(self.root, "dangling"))
        self.refused(code="exists", plan="ds3", name="ln")
        self.refused(code="exists", plan="ds3", name="dangling")
        self.assertFalse(os.path.exists(os.path.join(self.folder, "nowhere")))
        self.outside_untouched()

    def fake_capture(self, name, **fields):
        """A capture directory as goniod leaves it before measuring: its
        request.json (daemon/control.c, save_request) and nothing else."""
        d = os.path.join(self.root, name)
        os.makedirs(d)
        rec = dict(id=name, plan="ds3", scene="ideal", rig="default", material="",
                   model="abc", order="", stop="")
        rec.update(fields)
        with open(os.path.join(d, "request.json"), "w") as f:
            json.dump(rec, f)
        return d

    def resume_refused(self, cid, code):
        r = self.c.request("resume", capture_id=cid)
        self.assertEqual(r["class"], "ERROR", r)
        self.assertEqual(r["code"], code, r)
        return r

    def test_resume_through_links_is_refused(self):
        # A capture directory elsewhere, linked into the root.
        away = os.path.join(self.folder, "away")
        os.rename(self.fake_capture("tmp"), away)
        os.symlink(away, os.path.join(self.root, "linked"))
        self.resume_refused("linked", "not-found")
        self.assertEqual(os.listdir(away), ["request.json"])
        # A capture whose journal is a link to a file elsewhere.
        victim = os.path.join(self.outside, "victim.csv")
        with open(victim, "w") as f:
            f.write("keep me\n")
        jl = self.fake_capture("jl")
        os.symlink(victim, os.path.join(jl, "samples.csv"))
        r = self.resume_refused("jl", "bad-value")
        self.assertIn("samples.csv", r["message"])
        self.assertEqual(open(victim).read(), "keep me\n")
        # Request records naming files outside the root, directly or
        # through a link.
        self.fake_capture("ed", plan=os.path.join(self.outside, "ds3.yaml"))
        r = self.resume_refused("ed", "not-found")
        self.assertIn("outside the capture root", r["message"])
        os.symlink(os.path.join(self.outside, "ds3.yaml"), os.path.join(self.root, "p.yaml"))
        self.fake_capture("ed2", scene=os.path.join(self.root, "p.yaml"))
        self.resume_refused("ed2", "not-found")
        self.fake_capture("ed3", material="merl:" + os.path.join(self.outside, "ds3.yaml"))
        self.resume_refused("ed3", "not-found")
        self.assertEqual(self.c.request("status")["state"], "idle")
        self.outside_untouched_but("victim.csv")

    def outside_untouched_but(self, *extra):
        self.assertEqual(sorted(os.listdir(self.outside)), sorted(["ds3.yaml", *extra]))


class PathCaptureTests(PathBase):
    """The same rules do not get in the way of real captures."""

    def test_link_that_stays_inside_is_fine(self):
        os.makedirs(os.path.join(self.root, "real"))
        shutil.copy(DS3, os.path.join(self.root, "real", "ds3.yaml"))
        os.symlink("real", os.path.join(self.root, "alias"))
        r = self.c.request("capture", plan="alias/ds3.yaml", name="in")
        self.assertEqual(r["class"], "OK", r)
        self.assertEqual(self.c.until_stop("in")[-1]["reason"], "complete")
        self.check_complete("in")

    def test_real_capture_resumes_its_linked_copy_does_not(self):
        r = self.c.request("capture", plan="ds3", name="good")
        self.assertEqual(r["class"], "OK", r)
        self.assertEqual(self.c.until_stop("good")[-1]["reason"], "complete")
        away = os.path.join(self.folder, "away")
        shutil.copytree(os.path.join(self.root, "good"), away)
        before = sorted(os.listdir(away))
        os.symlink(away, os.path.join(self.root, "linked"))
        r = self.c.request("resume", capture_id="linked")
        self.assertEqual((r["class"], r["code"]), ("ERROR", "not-found"), r)
        self.assertEqual(sorted(os.listdir(away)), before)
        # a complete capture resumes only to be fitted again
        r = self.c.request("resume", capture_id="good", refit=True)
        self.assertEqual(r["class"], "OK", r)
        self.assertEqual(self.c.until_stop("good")[-1]["exit_status"], "success")
        self.check_complete("good")


# ---------------------------------------------------------------------------

class UnitFileTests(unittest.TestCase):
    """configs/goniod.service passes systemd's own checks."""

    def setUp(self):
        self.tool = shutil.which("systemd-analyze")
        if not self.tool:
            self.skipTest("systemd-analyze not installed (SKIPPED: unit file not verified)")
        self.folder = tmpdir()
        # verify insists the ExecStart binaries exist: point it at the build.
        text = open(os.path.join(SOURCE, "configs", "goniod.service")).read()
        self.unit = os.path.join(self.folder, "goniod.service")
        with open(self.unit, "w") as f:
            f.write(text.replace("/usr/bin/goniod", os.path.abspath(GONIOD)))

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def test_verify(self):
        r = subprocess.run([self.tool, "verify", self.unit], capture_output=True, text=True,
                           timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stderr.strip(), "", "warnings from systemd-analyze verify")

    def test_security_exposure(self):
        # systemd's exposure score, 0 (locked down) .. 10 (none). docs/goniod.md
        # gives the figure; a unit edit that loosens the sandbox fails here.
        r = subprocess.run([self.tool, "security", "--offline=true", self.unit],
                           capture_output=True, text=True, timeout=60)
        line = [x for x in r.stdout.splitlines() if "Overall exposure level" in x]
        if r.returncode != 0 and not line:
            self.skipTest("systemd-analyze security --offline unsupported (SKIPPED): "
                          + r.stderr.strip()[:200])
        score = float(line[0].split(":")[1].split()[0])
        self.assertLessEqual(score, 1.5, line[0])
        for setting in ("PrivateTmp=", "NoNewPrivileges=", "ProtectSystem=",
                        "CapabilityBoundingSet=~CAP_SYS_ADMIN", "SystemCallFilter=~@mount",
                        "MemoryDenyWriteExecute=", "RestrictRealtime="):
            row = [x for x in r.stdout.splitlines() if x.split()[1:2] == [setting]]
            self.assertTrue(row and row[0].startswith("✓"), (setting, row))


if __name__ == "__main__":
    unittest.main()
