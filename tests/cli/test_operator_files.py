"""What an operator's files hold and where they go, offline: the capture's
metadata in setup.json and results.json; gonio fit, export and plot writing
into a directory -o names, and gonio fit into the current directory when the
capture directory is read-only (goniod's, to an operator)."""
import json
import os
import shutil
import subprocess
import tempfile

import pytest

BIN = os.environ.get("GONIO_BIN", "build/bin")
GONIO = os.path.join(BIN, "gonio")
META = {"sample": "PTFE puck 3", "operator": "Ana Lima", "note": "after cleaning, 21 C"}


def gonio(*args, cwd=None):
    return subprocess.run([os.path.abspath(GONIO), *args], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


def load(*path):
    with open(os.path.join(*path)) as f:
        return json.load(f)


@pytest.fixture
def root():
    with tempfile.TemporaryDirectory(prefix="opfiles_") as d:
        yield d


def capture(out, *more):
    r = gonio("capture", "--offline", "--scene", "ideal", "--plan", "ds4", "--out", out,
              "--quiet", *more)
    assert r.returncode == 0, r.stderr
    return r


def test_metadata_in_setup_and_results(root):
    out = os.path.join(root, "c1")
    capture(out, "--sample", META["sample"], "--operator", META["operator"], "--note",
            META["note"])
    for name in ("setup.json", "results.json"):
        got = load(out, name)
        assert {k: got[k] for k in META} == META, name
    # A resume (results.json written again) keeps what the capture began with.
    os.unlink(os.path.join(out, "results.json"))
    capture(out, "--note", "another")
    for name in ("setup.json", "results.json"):
        assert load(out, name)["note"] == META["note"], name


def test_metadata_absent_is_null(root):
    out = os.path.join(root, "c0")
    capture(out)
    for name in ("setup.json", "results.json"):
        got = load(out, name)
        assert [got[k] for k in META] == [None] * 3, name


def run_read_only(folder, cwd, *args):
    """gonio ARGS in cwd with folder read-only: chmod for a user, a
    read-only bind mount in a private mount namespace for root (whom
    permissions do not stop); skipped, visibly, when neither works."""
    gonio_bin = os.path.abspath(GONIO)
    if os.geteuid() != 0:
        os.chmod(folder, 0o555)
        try:
            return gonio(*args, cwd=cwd)
        finally:
            os.chmod(folder, 0o755)
    if not shutil.which("unshare"):
        pytest.skip("root without unshare: cannot make a read-only directory")
    probe = subprocess.run(["unshare", "-m", "--propagation", "private", "true"],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip("no mount namespace here: " + probe.stderr.strip()[:100])
    script = ('mount --bind "$1" "$1" && mount -o remount,bind,ro "$1" && '
              '! touch "$1/probe" 2>/dev/null && cd "$2" && shift 2 && exec "$@"')
    return subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c", script,
                           "sh", folder, cwd, gonio_bin, *args],
                          capture_output=True, text=True, timeout=300)


def test_fit_into_the_current_directory_when_the_capture_is_read_only(root):
    cap, here = os.path.join(root, "c1"), os.path.join(root, "here")
    os.mkdir(here)
    capture(cap)
    before = sorted(os.listdir(cap))
    r = run_read_only(cap, here, "fit", cap, "--model", "abc-prior")
    assert r.returncode == 0, r.stderr
    assert "%s is not writable here; writing abc-prior.model in the current directory" % cap \
        in r.stderr
    assert "wrote      ./abc-prior.model" in r.stdout
    assert os.path.getsize(os.path.join(here, "abc-prior.model")) > 0
    assert sorted(os.listdir(cap)) == before
    # Writable again, the default is the capture directory, and nothing is said.
    r = gonio("fit", cap, "--model", "abc-prior", cwd=here)
    assert r.returncode == 0 and "not writable" not in r.stderr, r.stderr
    assert os.path.exists(os.path.join(cap, "abc-prior.model"))


def test_o_names_a_directory(root):
    cap, out = os.path.join(root, "c1"), os.path.join(root, "out")
    os.mkdir(out)
    capture(cap)
    r = gonio("fit", cap, "--model", "abc-prior", "-o", out)
    assert r.returncode == 0, r.stderr
    assert "wrote      %s/abc-prior.model" % out in r.stdout
    r = gonio("export", "merl", "--material", "model:%s/abc-prior.model" % out, "-o", out)
    assert r.returncode == 0, r.stderr
    assert os.path.getsize(os.path.join(out, "abc-prior.binary")) > 1e6
    r = gonio("plot", "slices", "--samples", cap, "-o", out)
    assert r.returncode == 0, r.stderr
    with open(os.path.join(out, "slices.svg")) as f:
        assert f.read(200).lstrip().startswith("<")
    # -o FILE is still a file, and a file's suffix is still checked.
    r = gonio("plot", "slices", "--samples", cap, "-o", os.path.join(out, "x.txt"))
    assert r.returncode == 2 and "must end in .svg or .png" in r.stderr
    assert sorted(os.listdir(out)) == ["abc-prior.binary", "abc-prior.model", "slices.svg"]
