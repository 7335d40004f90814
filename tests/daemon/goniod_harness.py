"""What the goniod end-to-end tests share: where the programs are (BIN,
GONIOD, GONIO, ...), running them under make check-valgrind (wrap,
run_wrapped, assert_valgrind_clean), a scratch folder per test (tmpdir), a
daemon on the simulated rig (Daemon, DaemonTest) and a client connection to
it (Conn), and readers of what a capture writes (journal_points, plan_total,
read_samples, rig_times, load_json). test_goniod*.py hold the tests; the
rig tests (tests/rig), the torture, the soak and the other daemon tests
import this module too.
"""
import glob
import grp
import json
import os
import pty
import re
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest

import child_procs

BIN = os.environ.get("GONIO_BIN", "build/bin")
TESTS_BIN = os.environ.get("GONIO_TESTS_BIN", "build/tests")
SOURCE = os.environ.get("GONIO_SOURCE", os.path.join(os.path.dirname(__file__), "..", ".."))
GONIOD = os.path.join(BIN, "goniod")
# The test variant: goniod with the crash torture's hooks compiled in
# (GONIOD_PHASE_LOG, GONIOD_PHASE_HOLD, GONIO_JOURNAL_TEAR_S; docs/torture.md).
GONIOD_TEST = os.path.join(BIN, "goniod-test")
GONIO = os.path.join(BIN, "gonio")
JOURNAL_POINTS = os.path.join(TESTS_BIN, "journal_points")
MAX_LINE = 65536  # docs/protocol.md
# make check-valgrind runs goniod, and the gonio-sim processes the tests
# start, under valgrind's memcheck: GONIO_WRAP is the valgrind command line
# (scripts/check-valgrind.sh). Each wrapped process writes its report to a
# file of its own beside the test's files (wrap), and a test fails when one
# of them shows an error (assert_valgrind_clean, run when the test is done
# with the process). Under valgrind waits for a process stretch (START_S),
# Modbus timeouts and the delays that provoke them stretch by SLOW (the
# driver's side of an exchange runs 20-50x slower), and a finished capture
# computes its truth errors on a sample of ASSESS_NODES nodes of the full
# domain (goniod's assess_nodes) instead of all 924k: evaluating those takes
# memcheck a minute per capture. docs/testing-memory.md.
WRAP = os.environ.get("GONIO_WRAP", "").split()
VALGRIND = bool(WRAP)
START_S = 60 if WRAP else 10
SLOW = 20 if WRAP else 1
ASSESS_NODES = 20000 if WRAP else 0


def wrap(argv, log_dir):
    """argv as run under GONIO_WRAP, valgrind's report going to
    log_dir/<program>.<pid>.valgrind (argv itself without GONIO_WRAP)."""
    if not WRAP:
        return list(argv)
    log = os.path.join(os.path.abspath(log_dir), os.path.basename(argv[0]) + ".%p.valgrind")
    return WRAP + ["--log-file=" + log] + list(argv)


def valgrind_reports(log_dir):
    """The valgrind reports in log_dir that show an error, with their text."""
    bad = []
    for path in sorted(glob.glob(os.path.join(log_dir, "*.valgrind"))):
        with open(path, errors="replace") as f:
            text = f.read()
        m = re.search(r"ERROR SUMMARY: (\d+) errors", text)
        # A process killed with SIGKILL writes no summary (and runs no leak
        # check): any report with a stack in its file is an error.
        if (int(m.group(1)) > 0) if m else re.search(r"^==\d+== +(at|by) 0x", text, re.M):
            bad.append("%s:\n%s" % (path, text[-6000:]))
    return bad


def assert_valgrind_clean(log_dir):
    bad = valgrind_reports(log_dir)
    if bad:
        raise AssertionError("valgrind found errors:\n" + "\n".join(bad))


def run_wrapped(argv, log_dir, **kw):
    """subprocess.run of argv under GONIO_WRAP (output captured as text),
    failing on a valgrind error."""
    kw.setdefault("timeout", 2 * START_S)
    r = subprocess.run(wrap(argv, log_dir), capture_output=True, text=True, **kw)
    assert_valgrind_clean(log_dir)
    return r


def tmpdir():
    base = os.environ.get("GONIO_TMP")
    if base:
        os.makedirs(base, exist_ok=True)
    # Unix socket paths are short (108 bytes): keep the folder name short.
    return tempfile.mkdtemp(prefix="gd", dir=base if base and len(base) < 60 else None)


def journal_points(path):
    """Point indices of a journal, read by journal/journal.h."""
    out = subprocess.run([JOURNAL_POINTS, path], capture_output=True, text=True, check=True)
    return [int(x) for x in out.stdout.split()]


def plan_total(capdir):
    with open(os.path.join(capdir, "plan.json")) as f:
        doc = json.load(f)
    return len(doc["pairs"])


def shipped_config(name, folder):
    """configs/goniod/NAME, in a copy naming this machine's group for the
    socket when the installed group 'gonio' does not exist here (--check
    refuses a group that does not exist; test_cli_install checks that)."""
    path = os.path.join(SOURCE, "configs", "goniod", name)
    if grp_exists("gonio"):
        return path
    with open(path) as f:
        text = f.read().replace("group: gonio", "group: " + grp.getgrgid(os.getgid()).gr_name)
    copy = os.path.join(folder, "shipped-" + name)
    with open(copy, "w") as f:
        f.write(text)
    return copy


def grp_exists(name):
    try:
        grp.getgrnam(name)
        return True
    except KeyError:
        return False

class Conn:
    """One client connection: JSON lines both ways."""

    def __init__(self, path, timeout=2 * START_S):
        self.s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.s.settimeout(timeout)
        try:
            self.s.connect(path)
        except OSError:
            self.s.close()
            raise
        self.buf = b""
        self.next_id = 1
        self.version = self.read()

    def close(self):
        self.s.close()

    def send_raw(self, data):
        self.s.sendall(data)

    def send(self, doc):
        self.send_raw(json.dumps(doc).encode() + b"\n")

    def read(self):
        """The next document, or None at end of stream."""
        while b"\n" not in self.buf:
            chunk = self.s.recv(65536)
            if not chunk:
                return None
            self.buf += chunk
        line, self.buf = self.buf.split(b"\n", 1)
        return json.loads(line)

    def request(self, cmd, **args):
        rid = self.next_id
        self.next_id += 1
        self.send(dict(cmd=cmd, id=rid, **args))
        while True:
            d = self.read()
            if d is None:
                raise AssertionError("connection closed awaiting reply to %s" % cmd)
            if d.get("id") == rid:
                return d

    def until_stop(self, capture_id=None):
        """Every document up to and including the stop document."""
        docs = []
        while True:
            d = self.read()
            if d is None:
                raise AssertionError("stream ended before stop: %r" % docs[-3:])
            docs.append(d)
            if d.get("class") == "stop" and capture_id in (None, d.get("capture_id")):
                return docs


class Daemon:
    def __init__(self, folder, pace_s=0.0, extra_socket="", env=None, scene="ideal",
                 driver=None, command=None, binary=GONIOD):
        # command: what runs goniod (a wrapper taking goniod's arguments,
        # itself responsible for GONIO_WRAP); default goniod under wrap().
        self.command = command
        self.binary = binary
        self.folder = folder
        self.sock = os.path.join(folder, "s.sock")
        self.root = os.path.join(folder, "cap")
        self.config = os.path.join(folder, "goniod.yaml")
        self.log = os.path.join(folder, "goniod.log")
        with open(self.config, "w") as f:
            f.write(
                "rig: default\n"
                "driver:\n%s"
                "capture_root: cap\n%s"
                "socket:\n  path: s.sock\n%s" % (
                    driver or "  kind: sim\n  scene: %s\n  pace_s: %g\n" % (scene, pace_s),
                    "assess_nodes: %d\n" % ASSESS_NODES if ASSESS_NODES else "",
                    extra_socket))
        self.env = dict(os.environ)
        self.env.pop("NOTIFY_SOCKET", None)
        self.env.pop("WATCHDOG_USEC", None)
        self.env.update(env or {})
        self.proc = None
        self.conns = []

    def start(self):
        logf = open(self.log, "a")
        argv = (self.command + ["--config", self.config] if self.command else
                wrap([self.binary, "--config", self.config], self.folder))
        self.proc = subprocess.Popen(argv, stdout=logf, stderr=logf, env=self.env,
                                     preexec_fn=child_procs.die_with_parent)
        logf.close()
        deadline = time.time() + START_S
        while time.time() < deadline:
            try:
                Conn(self.sock).close()
                return self
            except OSError:
                if self.proc.poll() is not None:
                    raise AssertionError("goniod exited: " + open(self.log).read())
                time.sleep(0.02)
        raise AssertionError("goniod did not listen")

    def connect(self, timeout=2 * START_S):
        """A client connection; timeout: the longest wait for a document."""
        c = Conn(self.sock, timeout)
        self.conns.append(c)
        return c

    def kill9(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()

    def stop(self):
        for c in self.conns:
            c.close()
        self.conns = []
        rc = self.proc.returncode if self.proc else None
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                rc = self.proc.wait(timeout=2 * START_S)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise AssertionError("goniod ignored SIGTERM")
        # Sanitizer builds: a report in the daemon's log fails the test;
        # under valgrind, an error in its report.
        if os.path.exists(self.log):
            log = open(self.log, errors="replace").read()
            if "Sanitizer" in log or "runtime error" in log:
                raise AssertionError("goniod sanitizer report:\n" + log[-4000:])
        assert_valgrind_clean(self.folder)
        return rc

    def alive(self):
        return self.proc.poll() is None

    def gonio(self, *args):
        """gonio ARGS against this goniod. With --wait it lasts the whole
        capture, its final fit and its errors: seconds here, several times
        that on a loaded machine, minutes under memcheck."""
        env = dict(self.env, GONIO_SOCKET=self.sock)
        return subprocess.run([GONIO] + list(args), capture_output=True, text=True, env=env,
                              timeout=12 * START_S)


class DaemonTest(unittest.TestCase):
    pace_s = 0.0

    def setUp(self):
        self.folder = tmpdir()
        self.d = Daemon(self.folder, pace_s=self.pace_s)
        self.d.start()

    def tearDown(self):
        self.d.stop()
        if os.environ.get("GONIO_KEEP"):
            sys.stderr.write("kept %s\n" % self.folder)
        else:
            shutil.rmtree(self.folder, ignore_errors=True)

    def check_complete(self, capture_id):
        """Every planned point exactly once, and results.json written."""
        capdir = os.path.join(self.d.root, capture_id)
        pts = journal_points(os.path.join(capdir, "samples.csv"))
        self.assertEqual(sorted(pts), list(range(plan_total(capdir))))
        self.assertTrue(os.path.exists(os.path.join(capdir, "results.json")))
        return pts


# ---------------------------------------------------------------------------

def read_samples(path):
    """samples.csv rows by point: the rgb triple."""
    with open(path) as f:
        rows = [l.split(",") for l in f.read().splitlines()[1:]]
    return {int(r[0]): [float(r[8]), float(r[9]), float(r[10])] for r in rows}



def rig_times(capdir):
    """samples.csv's rig_time_s column, in journal order."""
    with open(os.path.join(capdir, "samples.csv")) as f:
        return [float(l.split(",")[12]) for l in f.read().splitlines()[1:]]


def load_json(path):
    with open(path) as f:
        return json.load(f)



def catches_sigint(pid, exe):
    """Whether process pid runs exe and has its own SIGINT handler
    (/proc/PID/status, SigCgt): the moment from which SIGINT is the
    program's to handle, however long a loaded machine took to get there.
    Before the exec the forked test catches SIGINT too, so exe comes first."""
    try:
        if os.readlink("/proc/%d/exe" % pid) != os.path.realpath(exe):
            return False
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("SigCgt:"):
                    return bool(int(line.split()[1], 16) >> (signal.SIGINT - 1) & 1)
    except OSError:
        pass
    return False


def run_on_pty(argv, env, interrupt_at=None, interrupt_when_caught=False, timeout=120):
    """Run argv with a pseudo-terminal as its stdin, stdout and stderr (what
    an operator's terminal is). Send SIGINT once the output matches the
    regex interrupt_at, or with interrupt_when_caught as soon as the program
    has installed its SIGINT handler (catches_sigint).
    Returns (exit status, everything written to the terminal)."""
    pid, fd = pty.fork()
    if pid == 0:
        try:
            child_procs.die_with_parent()
            os.execve(argv[0], argv, env)
        finally:
            os._exit(127)
    out, sent = b"", False
    start = time.monotonic()
    while True:
        if not sent and interrupt_when_caught and catches_sigint(pid, argv[0]):
            os.kill(pid, signal.SIGINT)
            sent = True
        ready, _, _ = select.select([fd], [], [], 0.01 if interrupt_when_caught else 0.05)
        if ready:
            try:
                chunk = os.read(fd, 65536)
            except OSError:  # EIO: the child closed the terminal
                chunk = b""
            if not chunk:
                break
            out += chunk
            if not sent and interrupt_at and re.search(interrupt_at, out.decode(errors="replace")):
                os.kill(pid, signal.SIGINT)
                sent = True
        if time.monotonic() - start > timeout:
            os.kill(pid, signal.SIGKILL)
            raise AssertionError("timed out: %r" % out[-2000:])
    os.close(fd)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status), out.decode(errors="replace")
