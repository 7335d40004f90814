"""gonio calibrate as an operator runs it on the simulated raw rig: a dark,
then a reference taken with it, written where a capture looks; and the
refusals: a detector that reports BRDF, a reference without a dark, a bad
option."""
import csv
import json
import os
import subprocess
import tempfile

import pytest

BIN = os.environ.get("GONIO_BIN", "build/bin")
GONIO = os.path.join(BIN, "gonio")


def gonio(*args):
    return subprocess.run([GONIO, *args], capture_output=True, text=True, timeout=300)


@pytest.fixture
def root():
    with tempfile.TemporaryDirectory(prefix="calibrate_") as d:
        yield d


def test_dark_then_reference(root):
    d = gonio("calibrate", "dark", "--offline", "--scene", "lab-raw", "--out", root,
              "--integration", "0.2", "--frames", "8")
    assert d.returncode == 0, d.stderr
    dark_id = d.stdout.strip()
    meta = json.load(open(os.path.join(root, dark_id, "calibration.json")))
    assert meta["kind"] == "dark" and meta["rig"] == "default" and meta["detector"] == "rgb"
    assert meta["integrations_s"] == [0.05, 0.2] and meta["valid_s"] == 3600
    rows = list(csv.DictReader(open(os.path.join(root, dark_id, "frames.csv"))))
    assert len(rows) == 16 and all(r["kind"] == "dark" for r in rows)
    # The shutter was closed: offset and dark only, far below a lit reading.
    assert max(float(r["g"]) for r in rows) < 1200
    r = gonio("calibrate", "reference", "--offline", "--scene", "lab-raw", "--plan", "ds3",
              "--out", root, "--repeats", "2")
    assert r.returncode == 0, r.stderr
    ref = json.load(open(os.path.join(root, r.stdout.strip(), "calibration.json")))
    assert ref["kind"] == "reference" and ref["dark"] == dark_id
    assert ref["standard"] == "spectralon-99" and ref["frames"] == 2 * 52
    rows = list(csv.DictReader(open(os.path.join(root, r.stdout.strip(), "frames.csv"))))
    assert min(float(x["g"]) for x in rows) > 3000  # the standard, lit


def test_refusals(root):
    r = gonio("calibrate", "dark", "--offline", "--scene", "lab", "--out", root)
    assert r.returncode == 2 and "reports BRDF, not counts" in r.stderr, r.stderr
    r = gonio("calibrate", "reference", "--offline", "--scene", "lab-raw", "--plan", "ds3",
              "--out", root)
    assert r.returncode == 2 and "no valid dark calibration" in r.stderr, r.stderr
    r = gonio("calibrate", "dark", "--offline", "--scene", "lab-raw", "--out", root,
              "--frames", "-3")
    assert r.returncode == 2 and "--frames: not a positive number: '-3'" in r.stderr
    r = gonio("calibrate", "white", "--offline")
    assert r.returncode == 2 and "dark or reference" in r.stderr
    assert os.listdir(root) == []
