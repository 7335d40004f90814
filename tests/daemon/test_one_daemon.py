#!/usr/bin/python3
"""One goniod per rig (docs/goniod.md, One daemon per rig): a second goniod
configured with the socket or the capture root of a running one is refused
- exit 1, a message naming the lock and the first daemon's pid, the first
daemon's socket untouched - however busy, stopped or backlogged the first
one is; a socket left by a daemon that died is still replaced. Each test
starts its own daemon on the simulated rig (goniod_harness.py's helpers).
"""
import errno
import os
import shutil
import signal
import socket
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import GONIOD, START_S, Daemon, DaemonTest, run_wrapped, tmpdir  # noqa: E402


class OneDaemonTests(DaemonTest):
    pace_s = 0.02

    def second(self, config):
        """Run a second goniod on config; it must give up by itself."""
        return run_wrapped([GONIOD, "--config", config], self.folder)

    def assert_refused(self, r, path, what):
        self.assertEqual(r.returncode, 1, r.stderr)
        msg = "%s: locked by pid %d: another goniod is using this %s" % (
            path, self.d.proc.pid, what)
        self.assertIn(msg, r.stderr)

    def assert_first_intact(self, inode):
        """The first daemon's socket file is the one it bound, and (once it
        runs again) it answers there: greeted as soon as it has seen the
        connections a full backlog left go (until then a newcomer may be
        one too many)."""
        self.assertEqual(os.lstat(self.d.sock).st_ino, inode)
        deadline = time.monotonic() + START_S
        while True:
            try:
                c = self.d.connect()
            except BlockingIOError:  # the backlog not drained yet (a slow goniod: memcheck)
                c = None
            if c and c.version["class"] == "VERSION":
                break
            if c:
                self.assertEqual(c.version.get("code"), "too-many-clients", c.version)
            self.assertLess(time.monotonic(), deadline, "goniod never served again")
            time.sleep(0.1)
        self.assertEqual(c.request("status")["class"], "STATUS")

    def fill_backlog(self):
        """Connect without being accepted until the kernel refuses more
        (the daemon is stopped): the connections, oldest first."""
        held = []
        for _ in range(1000):
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.setblocking(False)
            try:
                s.connect(self.d.sock)
            except OSError as e:
                s.close()
                self.assertEqual(e.errno, errno.EAGAIN, e)
                return held
            held.append(s)
        self.fail("the listen backlog never filled")

    def other_config(self, folder, root=None, sock=None):
        """A config in folder sharing the first daemon's capture root or
        socket (absolute paths), the other one of its own."""
        d2 = Daemon(folder)
        text = open(d2.config).read()
        if root:
            text = text.replace("capture_root: cap\n", "capture_root: %s\n" % root)
        if sock:
            text = text.replace("  path: s.sock\n", "  path: %s\n" % sock)
        with open(d2.config, "w") as f:
            f.write(text)
        return d2

    def test_same_config_while_capturing(self):
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("capture", plan="ds1", name="busy")["class"], "OK")
        inode = os.lstat(self.d.sock).st_ino
        r = self.second(self.d.config)
        self.assert_refused(r, self.d.root, "capture root")
        self.assert_first_intact(inode)
        self.assertEqual(c.request("status")["state"], "running")
        c.request("abort")
        self.assertEqual(c.until_stop("busy")[-1]["reason"], "aborted")

    def test_stopped_with_a_full_backlog(self):
        # The case a connect test cannot tell from a dead daemon: the first
        # goniod stopped (SIGSTOP) and its backlog full, so a connect gets
        # EAGAIN. Same config (the capture root's lock refuses), and the
        # same socket with another capture root (the socket's lock does).
        inode = os.lstat(self.d.sock).st_ino
        os.kill(self.d.proc.pid, signal.SIGSTOP)
        held = []
        other = tmpdir()
        try:
            held = self.fill_backlog()
            self.assert_refused(self.second(self.d.config), self.d.root, "capture root")
            d2 = self.other_config(other, sock=self.d.sock)
            r = self.second(d2.config)
            self.assert_refused(r, self.d.sock + ".lock", "control socket")
            self.assertFalse(os.path.exists(d2.sock))
            self.assertEqual(os.lstat(self.d.sock).st_ino, inode)
            self.assertEqual(open(self.d.sock + ".lock").read(), "%d\n" % self.d.proc.pid)
        finally:
            os.kill(self.d.proc.pid, signal.SIGCONT)
            for s in held:
                s.close()
            shutil.rmtree(other, ignore_errors=True)
        self.assert_first_intact(inode)

    def test_stopped_shared_capture_root(self):
        # Another socket, the same capture root: two daemons would write
        # the same captures (and on Modbus drive the same rig).
        os.kill(self.d.proc.pid, signal.SIGSTOP)
        other = tmpdir()
        try:
            d2 = self.other_config(other, root=self.d.root)
            r = self.second(d2.config)
            self.assert_refused(r, self.d.root, "capture root")
            self.assertFalse(os.path.exists(d2.sock))
        finally:
            os.kill(self.d.proc.pid, signal.SIGCONT)
            shutil.rmtree(other, ignore_errors=True)
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")

    def test_dead_daemons_socket_is_replaced(self):
        # kill -9 leaves the socket file and the lock file; the locks died
        # with the process, so the next goniod takes both over.
        self.d.kill9()
        self.assertTrue(os.path.exists(self.d.sock))
        self.d.start()
        self.assertEqual(self.d.connect().request("status")["class"], "STATUS")
        self.assertEqual(open(self.d.sock + ".lock").read(), "%d\n" % self.d.proc.pid)
        # A clean stop removes the socket and leaves the (unlocked) lock
        # file: removing it could let two daemons lock two different files.
        self.assertEqual(self.d.stop(), 0)
        self.assertFalse(os.path.exists(self.d.sock))
        self.assertTrue(os.path.exists(self.d.sock + ".lock"))
        self.d.start()


if __name__ == "__main__":
    unittest.main()
