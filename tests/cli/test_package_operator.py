"""The .deb as an operator without root uses it (docs/install.md): make
package's .deb extracted into a root folder, goniod from it on the simulated
rig, and the packaged gonio run as the user nobody (setpriv, no groups) with
no GONIO_* variable: a dry-run plan of an installed plan and of the
operator's own, gonio list, a capture of the operator's plan through
goniod, a fit of it and an offline capture. Each command runs in a private
mount namespace with empty /tmp, /var/tmp and /dev/shm, which must still be
empty after it: the operator's commands write only into the operator's
folder (and goniod into its capture root). Needs root, dpkg-deb, setpriv,
unshare and cpack; skipped, saying which is missing, otherwise."""
import json
import os
import pwd
import shutil
import subprocess
import tempfile

import pytest

import child_procs  # tests/, on PYTHONPATH

BUILD = os.path.abspath(os.environ.get("GONIO_BUILD", "build"))
SOURCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")

PLAN = """# the operator's own plan: no name, so it is named after the file
pairs:
  - [15, -35]
  - [15, 20]
  - [35, 40]
  - [50, -5]
order: as-written
stop: all
"""
PAIRS = [[15, -35], [15, 20], [35, 40], [50, -5]]

# Runs "$@" as nobody in the operator's folder, with fresh /tmp, /var/tmp and
# /dev/shm, then lists what is left in them into $LEFT.
OPERATOR = """
for d in /tmp /var/tmp /dev/shm; do
    mount -t tmpfs -o mode=1777 tmpfs "$d" || exit 90
done
cd "$OPDIR" || exit 91
setpriv --reuid=nobody --regid=nogroup --clear-groups \
    env -i HOME="$OPDIR/home" PATH=/usr/bin:/bin LANG=C.UTF-8 "$@"
rc=$?
ls -A /tmp /var/tmp /dev/shm > "$LEFT"
exit $rc
"""


def run(*args, **kw):
    kw.setdefault("timeout", 120)
    return subprocess.run(list(args), capture_output=True, text=True, **kw)


def missing_tool():
    if os.geteuid() != 0:
        return "needs root to run the package's programs as another user"
    for tool in ("cpack", "dpkg-deb", "setpriv", "unshare"):
        if not shutil.which(tool):
            return tool + " not installed"
    try:
        pwd.getpwnam("nobody")
    except KeyError:
        return "no user nobody"
    probe = run("unshare", "-m", "--propagation", "private", "true")
    if probe.returncode != 0:
        return "no mount namespace here: " + probe.stderr.strip()[:100]
    return None


@pytest.fixture(scope="module")
def pkg():
    why = missing_tool()
    if why:
        pytest.skip(why)
    # Under the build tree, not /tmp (which the operator's commands see
    # empty), in folders everyone may traverse.
    base = os.path.join(BUILD, "tmp")
    hidden = [d for d in ("/tmp", "/var/tmp", "/dev/shm")
              if os.path.realpath(base).startswith(d + "/")]
    if hidden:
        pytest.skip("the build tree is under %s, which the operator's commands see as a fresh "
                    "tmpfs: build outside it to run this test" % hidden[0])
    os.makedirs(base, exist_ok=True)
    top = tempfile.mkdtemp(prefix="pkgop", dir=base)
    os.chmod(top, 0o755)
    if run("setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups", "test", "-x",
           top).returncode != 0:
        shutil.rmtree(top, ignore_errors=True)
        pytest.skip("nobody cannot enter %s (a build tree nobody may not enter)" % top)
    try:
        # make package's content; uncompressed and without the dependency
        # scan (this test reads neither), which halves cpack's time
        r = run("cpack", "-G", "DEB", "--config", os.path.join(BUILD, "CPackConfig.cmake"),
                "-B", os.path.join(top, "deb"), "-D", "CPACK_DEBIAN_COMPRESSION_TYPE=none",
                "-D", "CPACK_DEBIAN_PACKAGE_SHLIBDEPS=OFF", cwd=BUILD, timeout=300)
        assert r.returncode == 0, r.stdout + r.stderr
        debs = [f for f in os.listdir(os.path.join(top, "deb")) if f.endswith(".deb")]
        assert len(debs) == 1, debs
        root = os.path.join(top, "root")
        r = run("dpkg-deb", "-x", os.path.join(top, "deb", debs[0]), root)
        assert r.returncode == 0, r.stderr
        os.chmod(root, 0o755)
        yield top, root
    finally:
        shutil.rmtree(top, ignore_errors=True)


@pytest.fixture
def goniod(pkg):
    """The packaged goniod (root here) on the simulated rig, its socket
    open to the group nogroup; the operator's folder beside it."""
    top, root = pkg
    folder = tempfile.mkdtemp(prefix="g", dir=top)
    os.chmod(folder, 0o755)
    config = os.path.join(folder, "goniod.yaml")
    with open(config, "w") as f:
        f.write("rig: default\ndriver:\n  kind: sim\n  scene: ideal\n  pace_s: 0\n"
                "capture_root: %s/cap\nsocket:\n  path: %s/s.sock\n  group: nogroup\n"
                % (folder, folder))
    env = {k: v for k, v in os.environ.items() if not k.startswith("GONIO_")}
    log = open(os.path.join(folder, "goniod.log"), "w")
    proc = subprocess.Popen([os.path.join(root, "usr/bin/goniod"), "--config", config],
                            stdout=log, stderr=log, env=env, cwd="/",
                            preexec_fn=child_procs.die_with_parent)
    sock = os.path.join(folder, "s.sock")
    try:
        for _ in range(500):
            if os.path.exists(sock) or proc.poll() is not None:
                break
            subprocess.run(["sleep", "0.02"])
        assert os.path.exists(sock), open(os.path.join(folder, "goniod.log")).read()
        nobody = pwd.getpwnam("nobody")
        opdir = os.path.join(folder, "op")
        for sub in ("", "home", "plans"):
            os.makedirs(os.path.join(opdir, sub), exist_ok=True)
            os.chown(os.path.join(opdir, sub), nobody.pw_uid, nobody.pw_gid)
        os.chmod(opdir, 0o700)
        with open(os.path.join(opdir, "plans", "mine.yaml"), "w") as f:
            f.write(PLAN)
        os.chown(os.path.join(opdir, "plans", "mine.yaml"), nobody.pw_uid, nobody.pw_gid)
        yield {"root": root, "folder": folder, "sock": sock, "opdir": opdir,
               "cap": os.path.join(folder, "cap")}
    finally:
        proc.terminate()
        proc.wait(timeout=60)
        log.close()


def as_operator(g, *argv):
    """argv (the packaged gonio's arguments) run as nobody: its result, and
    what it left in /tmp, /var/tmp and /dev/shm."""
    left = os.path.join(g["folder"], "left")
    env = {"PATH": os.environ["PATH"], "OPDIR": g["opdir"], "LEFT": left}
    r = run("unshare", "-m", "--propagation", "private", "sh", "-c", OPERATOR, "sh",
            os.path.join(g["root"], "usr/bin/gonio"), *argv, env=env, timeout=60)
    assert r.returncode not in (90, 91), r.stderr
    with open(left) as f:
        leftovers = [l for l in f.read().split() if not l.endswith(":")]
    return r, leftovers


def owned_by(path, uid):
    found = []
    for d, dirs, files in os.walk(path):
        for name in dirs + files:
            p = os.path.join(d, name)
            if os.lstat(p).st_uid == uid:
                found.append(os.path.relpath(p, path))
    return sorted(found)


def test_operator_without_root(goniod):
    g = goniod
    nobody = pwd.getpwnam("nobody").pw_uid
    sock = ("--socket", g["sock"])

    r, left = as_operator(g, "plan", "ds3", "--summary")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("plan ds3 (%s/etc/gonio/plans/ds3.yaml)" % g["root"]), r.stdout
    assert left == []

    r, left = as_operator(g, "plan", "plans/mine.yaml", "--summary")
    assert r.returncode == 0, r.stderr
    assert "count: 4 pairs" in r.stdout, r.stdout
    assert left == []

    r, left = as_operator(g, "capture", "--plan", "plans/mine.yaml", "--name", "op1", "--wait",
                          "--quiet", *sock)
    assert r.returncode == 0, r.stderr
    assert "stopped: complete, 4 samples" in r.stdout, r.stdout
    assert left == []
    capdir = os.path.join(g["cap"], "op1")
    with open(os.path.join(capdir, "plan.json")) as f:
        assert [[p["theta_i"], p["theta_r"]] for p in json.load(f)["pairs"]] == PAIRS

    r, left = as_operator(g, "list", "--json", *sock)
    assert r.returncode == 0, r.stderr
    listed = {e["id"]: e for e in json.loads(r.stdout)["captures"]}
    assert listed["op1"]["state"] == "complete", listed
    assert left == []

    # The capture directory is goniod's: the fit goes to the operator's folder.
    r, left = as_operator(g, "fit", capdir, "--model", "abc", "--quiet")
    assert r.returncode == 0, r.stderr
    assert os.path.exists(os.path.join(g["opdir"], "abc.model"))
    assert left == []

    r, left = as_operator(g, "capture", "--offline", "--scene", "ideal", "--plan", "ds4",
                          "--quiet", "--out", "run1")
    assert r.returncode == 0, r.stderr
    assert os.path.exists(os.path.join(g["opdir"], "run1", "results.json"))
    assert left == []

    # What nobody wrote is in the operator's folder and nowhere else.
    mine = owned_by(g["opdir"], nobody)
    assert "abc.model" in mine and "run1/results.json" in mine, mine
    assert owned_by(g["root"], nobody) == []
    assert owned_by(g["cap"], nobody) == []
    everything = [os.path.relpath(os.path.join(d, n), g["opdir"])
                  for d, dirs, files in os.walk(g["opdir"]) for n in dirs + files]
    assert sorted(everything) == mine
