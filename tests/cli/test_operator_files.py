"""What an operator's files hold and where they go, offline: the capture's
metadata in setup.json and results.json."""
import json
import os
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
