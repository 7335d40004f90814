#!/usr/bin/python3
"""The plan, rig and scene files gonio capture sends with its request
(docs/protocol.md, "Files sent with a request"), end to end on the simulated
rig: an operator's own plan, named from the operator's working directory,
is captured as written and kept in the capture directory (SentTests); a bad
one is refused naming the file as the operator named it, the field and the
value, and creates nothing; a resume reads the kept copy after the
operator's file is gone. SceneTests does the same for an operator's scene
on goniod's in-process simulated rig. UnreadableTests runs goniod as nobody, so that the
plan lies in a folder goniod cannot read (root and setpriv needed, else
skipped).

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \\
      python3 tests/daemon/test_request_files.py -v
"""
import os
import pwd
import shutil
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import (GONIO, GONIOD, START_S, Daemon, DaemonTest,  # noqa: E402
                            journal_points, load_json, wrap)

# An operator's plan: pairs no shipped plan has, in the order written, and
# no name of its own (the plan's name is the file's).
CUSTOM = """# an operator's own plan
pairs:
  - [10, -40]
  - [10, 25]
  - [25, 35]
  - [40, -10]
  - [40, 55]
order: as-written
stop: all
"""
CUSTOM_PAIRS = [[10, -40], [10, 25], [25, 35], [40, -10], [40, 55]]

# An operator's rig profile: the default's, under another name and with a
# narrower arm (which the pairs above stay inside).
RIG = """name: bench-arm
out_of_plane: false
blind_deg: 5
settle_s: 0.3
integration: {fixed_s: 0.05, auto_min_s: 0.001, auto_max_s: 2}
axes:
  sample: {speed: 20, accel: 40, min: -90, max: 90}
  arm: {speed: 15, accel: 30, min: -120, max: 120}
"""


def pairs_of(capdir):
    pairs = load_json(os.path.join(capdir, "plan.json"))["pairs"]
    return [[p["theta_i"], p["theta_r"]] for p in pairs]


def operator_folder(test):
    """A folder of the operator's files, outside goniod's folder and root."""
    op = tempfile.mkdtemp(prefix="op")
    test.addCleanup(shutil.rmtree, op, True)
    os.makedirs(os.path.join(op, "plans"))
    return op


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def run_gonio(d, cwd, *args):
    env = dict(d.env, GONIO_SOCKET=d.sock)
    return subprocess.run([GONIO] + list(args), capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=2 * START_S)


class SentTests(DaemonTest):
    def setUp(self):
        super().setUp()
        self.op = operator_folder(self)
        write(os.path.join(self.op, "plans", "mine.yaml"), CUSTOM)

    def assert_nothing_created(self):
        self.assertEqual(os.listdir(self.d.root) if os.path.isdir(self.d.root) else [], [])

    def test_relative_plan_from_the_operators_folder(self):
        """plans/mine.yaml means the operator's file: goniod runs in another
        folder, where no such file is, and it is outside the capture root."""
        r = run_gonio(self.d, self.op, "capture", "--plan", "plans/mine.yaml", "--rig",
                      "plans/bench.yaml", "--name", "m1")
        self.assertEqual(r.returncode, 2)  # the rig file is not there yet
        self.assertIn("--rig 'plans/bench.yaml': cannot read", r.stderr)
        write(os.path.join(self.op, "plans", "bench.yaml"), RIG)
        r = run_gonio(self.d, self.op, "capture", "--plan", "plans/mine.yaml", "--rig",
                      "plans/bench.yaml", "--name", "m1", "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("stopped: complete, 5 samples", r.stdout)
        capdir = os.path.join(self.d.root, "m1")
        self.assertEqual(pairs_of(capdir), CUSTOM_PAIRS)
        self.assertEqual(load_json(os.path.join(capdir, "plan.json"))["plan"], "mine")
        self.assertEqual(sorted(journal_points(os.path.join(capdir, "samples.csv"))),
                         list(range(5)))
        self.assertEqual(load_json(os.path.join(capdir, "setup.json"))["rig"]["name"], "bench-arm")
        self.assertEqual(load_json(os.path.join(capdir, "setup.json"))["rig"]["axes"]["arm"]["max"],
                         120)
        # the copies the capture read, as sent
        with open(os.path.join(capdir, "request", "plan", "mine.yaml")) as f:
            self.assertEqual(f.read(), CUSTOM)
        with open(os.path.join(capdir, "request", "rig", "bench.yaml")) as f:
            self.assertEqual(f.read(), RIG)
        # without a name the capture's id comes from the file's
        r = run_gonio(self.d, self.op, "capture", "--plan", "plans/mine.yaml")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertRegex(r.stdout, r"^capture \d{8}T\d{6}Z-mine started")

    def test_bad_plan_is_refused_naming_file_field_value(self):
        cases = (
            ("bad.yaml", "grid:\n  theta_i_step: banana\n",
             ["plans/bad.yaml:2:", "theta_i_step", "banana"]),
            ("far.yaml", "pairs:\n  - [10, 20]\n  - [80, 95]\n",
             ["plans/far.yaml:3:", "theta_r", "'95'"]),
            ("levels.yaml", "pairs: [[10, 20]]\nprogressive: [/etc/passwd]\n",
             ["plan 'plans/levels.yaml'", "progressive", "/etc/passwd"]),
        )
        for name, text, wanted in cases:
            write(os.path.join(self.op, "plans", name), text)
            r = run_gonio(self.d, self.op, "capture", "--plan", "plans/" + name, "--name", "b")
            self.assertEqual(r.returncode, 2, (name, r.stdout, r.stderr))
            for w in wanted:
                self.assertIn(w, r.stderr, name)
            self.assertNotIn(self.d.root, r.stderr, name)  # not the copy's path
            self.assertNotIn("started", r.stdout)
            self.assert_nothing_created()
        # a bad rig, named as the operator named it
        write(os.path.join(self.op, "plans", "rig.yaml"), RIG.replace("speed: 15", "speed: fast"))
        r = run_gonio(self.d, self.op, "capture", "--plan", "plans/mine.yaml", "--rig",
                      "plans/rig.yaml", "--name", "b")
        self.assertEqual(r.returncode, 2, r.stderr)
        for w in ("plans/rig.yaml:", "speed", "fast"):
            self.assertIn(w, r.stderr)
        self.assert_nothing_created()

    def test_size_limit(self):
        """A file larger than goniod takes: gonio refuses it before sending,
        goniod refuses it when another client sends it; neither creates
        anything."""
        big = CUSTOM + "#" * 16384 + "\n"
        write(os.path.join(self.op, "plans", "big.yaml"), big)
        r = run_gonio(self.d, self.op, "capture", "--plan", "plans/big.yaml", "--name", "b")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("--plan 'plans/big.yaml': larger than 16384 bytes", r.stderr)
        c = self.d.connect()
        rep = c.request("capture", plan="big.yaml", plan_text=big, name="b")
        self.assertEqual((rep["class"], rep["code"]), ("ERROR", "bad-value"), rep)
        self.assertIn("'plan_text' of %d bytes is too long: at most 16384" % len(big),
                      rep["message"])
        rep = c.request("capture", plan="ds4", rig_text=RIG, name="b")
        self.assertEqual(rep["class"], "ERROR", rep)
        self.assertIn("'rig_text' needs 'rig'", rep["message"])
        rep = c.request("capture", plan="my plan.yaml", plan_text=CUSTOM, name="b")
        self.assertEqual(rep["class"], "ERROR", rep)
        self.assertIn("plan 'my plan.yaml'", rep["message"])
        self.assert_nothing_created()

    def test_resume_reads_the_kept_copy(self):
        """An aborted capture resumes from the copy in its directory: the
        operator's file is gone by then."""
        self.d.stop()
        self.d = Daemon(self.folder, pace_s=1.0)  # the abort lands mid-way on a loaded machine
        self.d.start()
        c = self.d.connect()
        c.request("watch")
        r = run_gonio(self.d, self.op, "capture", "--plan", "plans/mine.yaml", "--name", "rs")
        self.assertEqual(r.returncode, 0, r.stderr)
        while c.read()["class"] != "event":
            pass
        self.assertEqual(self.d.gonio("abort").returncode, 0)
        c.until_stop("rs")
        os.unlink(os.path.join(self.op, "plans", "mine.yaml"))
        capdir = os.path.join(self.d.root, "rs")
        before = journal_points(os.path.join(capdir, "samples.csv"))
        self.assertLess(len(before), 5)
        r = run_gonio(self.d, "/", "resume", "rs")
        self.assertEqual(r.returncode, 0, r.stderr)
        docs = c.until_stop("rs")
        self.assertEqual(docs[-1]["reason"], "complete", docs[-1])
        self.assertEqual(sorted(journal_points(os.path.join(capdir, "samples.csv"))),
                         list(range(5)))
        self.assertEqual(pairs_of(capdir), CUSTOM_PAIRS)
        self.assertEqual(load_json(os.path.join(capdir, "request.json"))["plan"],
                         os.path.join(os.path.realpath(capdir), "request", "plan", "mine.yaml"))


# An operator's scene: the ideal rig's, under its own name and seed, with a
# little jitter, so that setup.json shows which scene the capture read.
SCENE = """name: op-bench
material: default
rig: default
detector: rgb
seed: 7
effects:
  - {name: jitter, sigma_deg: 0.01}
"""


class SceneTests(DaemonTest):
    pace_s = 1.0  # the abort lands after the first point on a loaded machine

    def setUp(self):
        super().setUp()
        self.op = operator_folder(self)
        os.makedirs(os.path.join(self.op, "scenes"))
        write(os.path.join(self.op, "scenes", "bench.yaml"), SCENE)

    def test_scene_travels_and_resume_reads_the_copy(self):
        c = self.d.connect()
        c.request("watch")
        r = run_gonio(self.d, self.op, "capture", "--plan", "ds4", "--scene",
                      "scenes/bench.yaml", "--name", "sc")
        self.assertEqual(r.returncode, 0, r.stderr)
        while c.read()["class"] != "event":
            pass
        self.assertEqual(self.d.gonio("abort").returncode, 0)
        c.until_stop("sc")
        capdir = os.path.join(self.d.root, "sc")
        with open(os.path.join(capdir, "request", "scene", "bench.yaml")) as f:
            self.assertEqual(f.read(), SCENE)
        scene = load_json(os.path.join(capdir, "setup.json"))["scene"]
        self.assertEqual((scene["name"], scene["seed"], scene["effects"]), ("op-bench", 7, 1))
        total = len(load_json(os.path.join(capdir, "plan.json"))["pairs"])
        self.assertLess(len(journal_points(os.path.join(capdir, "samples.csv"))), total)
        os.unlink(os.path.join(self.op, "scenes", "bench.yaml"))
        r = run_gonio(self.d, "/", "resume", "sc")
        self.assertEqual(r.returncode, 0, r.stderr)
        docs = c.until_stop("sc")
        self.assertEqual(docs[-1]["reason"], "complete", docs[-1])
        self.assertEqual(sorted(journal_points(os.path.join(capdir, "samples.csv"))),
                         list(range(total)))
        self.assertEqual(load_json(os.path.join(capdir, "setup.json"))["scene"]["name"],
                         "op-bench")
        self.assertEqual(load_json(os.path.join(capdir, "request.json"))["scene"],
                         os.path.join(os.path.realpath(capdir), "request", "scene", "bench.yaml"))

    def test_bad_scene_is_refused_naming_file_field_value(self):
        cases = (
            ("seed.yaml", SCENE.replace("seed: 7", "seed: banana"),
             ["scenes/seed.yaml:5:", "seed", "banana"]),
            ("merl.yaml", SCENE.replace("material: default", "material: merl:/etc/passwd"),
             ["scene 'scenes/merl.yaml'", "material", "merl:/etc/passwd"]),
            ("rig.yaml", SCENE.replace("rig: default", "rig: /etc/passwd"),
             ["scene 'scenes/rig.yaml'", "'rig'", "/etc/passwd"]),
        )
        for name, text, wanted in cases:
            write(os.path.join(self.op, "scenes", name), text)
            r = run_gonio(self.d, self.op, "capture", "--plan", "ds4", "--scene",
                          "scenes/" + name, "--name", "b")
            self.assertEqual(r.returncode, 2, (name, r.stdout, r.stderr))
            for w in wanted:
                self.assertIn(w, r.stderr, name)
            self.assertNotIn(self.d.root, r.stderr, name)
            self.assertEqual(os.listdir(self.d.root) if os.path.isdir(self.d.root) else [], [])


def nobody():
    try:
        return pwd.getpwnam("nobody")
    except KeyError:
        return None


@unittest.skipUnless(os.geteuid() == 0 and shutil.which("setpriv") and nobody(),
                     "needs root, setpriv and the user nobody to run goniod as another user")
class UnreadableTests(unittest.TestCase):
    """goniod as nobody; the operator's plan in a folder only root reads."""

    def setUp(self):
        self.setpriv = ["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups"]
        config = os.environ.get("GONIO_CONFIG", os.path.join(os.path.dirname(GONIOD), "..",
                                                             "..", "configs"))
        probe = subprocess.run(self.setpriv + ["sh", "-c", 'test -x "$0" && test -r "$1"',
                                               GONIOD, os.path.join(config, "plans", "ds4.yaml")])
        if probe.returncode != 0:
            self.skipTest("nobody cannot run %s or read %s (a checkout nobody may not enter)"
                          % (GONIOD, config))
        self.folder = tempfile.mkdtemp(prefix="gd")
        self.addCleanup(shutil.rmtree, self.folder, True)
        who = nobody()
        os.chown(self.folder, who.pw_uid, who.pw_gid)
        os.chmod(self.folder, 0o755)
        self.d = Daemon(self.folder, command=self.setpriv + wrap([GONIOD], self.folder))
        self.d.start()
        self.addCleanup(self.d.stop)
        self.op = tempfile.mkdtemp(prefix="op")
        self.addCleanup(shutil.rmtree, self.op, True)
        os.chmod(self.op, 0o700)
        write(os.path.join(self.op, "mine.yaml"), CUSTOM)

    def test_plan_goniod_cannot_read(self):
        plan = os.path.join(self.op, "mine.yaml")
        # the premise: goniod's user cannot read the file
        self.assertNotEqual(subprocess.run(self.setpriv + ["cat", plan],
                                           capture_output=True).returncode, 0)
        r = run_gonio(self.d, "/", "capture", "--plan", plan, "--name", "u1", "--wait",
                      "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        capdir = os.path.join(self.d.root, "u1")
        self.assertEqual(pairs_of(capdir), CUSTOM_PAIRS)
        self.assertEqual(sorted(journal_points(os.path.join(capdir, "samples.csv"))),
                         list(range(5)))
        self.assertEqual(os.stat(os.path.join(capdir, "request", "plan", "mine.yaml")).st_uid,
                         nobody().pw_uid)
        # A bad plan there: refused naming the operator's path, field and value.
        write(plan, "grid:\n  theta_i_step: banana\n")
        r = run_gonio(self.d, "/", "capture", "--plan", plan, "--name", "u2")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn(plan + ":2:", r.stderr)
        self.assertIn("'banana'", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.d.root, "u2")))


if __name__ == "__main__":
    unittest.main()
