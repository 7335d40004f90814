#!/usr/bin/python3
"""The README's first goniod commands work as written: goniod from the top
of the source tree with configs/goniod/source-tree.yaml (the simulated rig,
its state in build/goniod-state/, no system user or group), then `gonio
status` on its socket, a capture, and `gonio shutdown`.

The commands are read from README.md and run unchanged, in a folder laid out
like the checkout (configs/goniod/source-tree.yaml copied, build/bin linking
to the binaries under test), so that the state the config names lands in
that folder's build/goniod-state/, not in the real checkout. The variables
that point gonio at data and configs (GONIO_CONFIG, GONIO_SHARED) are
dropped: a first run has none.
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import BIN, SOURCE, START_S, Conn, assert_valgrind_clean, tmpdir, wrap  # noqa: E402
import child_procs  # noqa: E402

README = os.path.join(SOURCE, "README.md")


def readme_commands():
    """The goniod command and the gonio status command of README.md."""
    text = open(README).read()
    daemon = re.search(r"`(build/bin/goniod --config configs/goniod/[^`]+)`", text)
    status = re.search(r"`(build/bin/gonio status [^`]+)`", text)
    if not daemon or not status:
        raise AssertionError("README.md names no source-tree goniod and gonio status commands")
    return shlex.split(daemon.group(1)), shlex.split(status.group(1))


class FirstRunTests(unittest.TestCase):
    def setUp(self):
        self.top = tmpdir()
        self.log = os.path.join(self.top, "goniod.log")
        self.proc = None
        self.env = {k: v for k, v in os.environ.items()
                    if k not in ("GONIO_CONFIG", "GONIO_SHARED", "GONIO_SOCKET", "NOTIFY_SOCKET",
                                 "WATCHDOG_USEC")}

    def tearDown(self):
        if self.proc and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        shutil.rmtree(self.top, ignore_errors=True)

    def run_here(self, argv):
        return subprocess.run(argv, cwd=self.top, env=self.env, capture_output=True, text=True,
                              timeout=2 * START_S)

    def test_readme_commands(self):
        daemon, status = readme_commands()
        config = daemon[daemon.index("--config") + 1]
        os.makedirs(os.path.join(self.top, os.path.dirname(config)))
        shutil.copy(os.path.join(SOURCE, config), os.path.join(self.top, config))
        os.makedirs(os.path.join(self.top, "build"))
        os.symlink(os.path.abspath(BIN), os.path.join(self.top, "build", "bin"))
        sock = os.path.join(self.top, status[status.index("--socket") + 1])

        with open(self.log, "w") as logf:
            self.proc = subprocess.Popen(wrap(daemon, self.top), cwd=self.top, env=self.env,
                                         stdout=logf, stderr=logf,
                                         preexec_fn=child_procs.die_with_parent)
        deadline = time.time() + START_S
        while True:
            try:
                Conn(sock).close()
                break
            except OSError:
                self.assertIsNone(self.proc.poll(), open(self.log).read())
                self.assertLess(time.time(), deadline, "goniod did not listen on " + sock)
                time.sleep(0.05)

        r = self.run_here(status)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("goniod idle", r.stdout)
        # The rig works: a capture by plan name (the source tree's configs),
        # its directory in the state folder.
        gonio, opts = status[0], status[2:]
        r = self.run_here([gonio, "capture", "--plan", "ds3", "--name", "first", "--wait"]
                          + opts)
        self.assertEqual(r.returncode, 0, r.stderr)
        capdir = os.path.join(self.top, "build", "goniod-state", "captures", "first")
        self.assertTrue(os.path.exists(os.path.join(capdir, "results.json")), r.stdout)
        r = self.run_here([gonio, "shutdown"] + opts)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(self.proc.wait(timeout=2 * START_S), 0, open(self.log).read())
        self.assertFalse(os.path.exists(sock))
        # Nothing but the state folder was written beside the config.
        self.assertEqual(sorted(x for x in os.listdir(self.top) if not x.endswith(".valgrind")),
                         ["build", "configs", "goniod.log"])
        self.assertEqual(sorted(os.listdir(os.path.join(self.top, "build"))),
                         ["bin", "goniod-state"])
        assert_valgrind_clean(self.top)


if __name__ == "__main__":
    unittest.main()
