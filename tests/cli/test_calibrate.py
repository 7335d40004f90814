"""gonio calibrate as an operator runs it on the simulated raw rig: a dark,
then a reference taken with it, written where a capture looks; and the
refusals: a detector that reports BRDF, a reference without a dark, a bad
option."""
import csv
import json
import os
import subprocess
import tempfile
import time

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
    d = gonio("calibrate", "dark", "--offline", "--scene", "lab", "--out", root,
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
    r = gonio("calibrate", "reference", "--offline", "--scene", "lab", "--plan", "ds3",
              "--out", root, "--repeats", "2")
    assert r.returncode == 0, r.stderr
    ref = json.load(open(os.path.join(root, r.stdout.strip(), "calibration.json")))
    assert ref["kind"] == "reference" and ref["dark"] == dark_id
    assert ref["standard"] == "spectralon-99" and ref["frames"] == 2 * 52
    rows = list(csv.DictReader(open(os.path.join(root, r.stdout.strip(), "frames.csv"))))
    assert min(float(x["g"]) for x in rows) > 3000  # the standard, lit


def test_refusals(root):
    r = gonio("calibrate", "dark", "--offline", "--scene", "ideal", "--out", root)
    assert r.returncode == 2 and "reports BRDF, not counts" in r.stderr, r.stderr
    r = gonio("calibrate", "reference", "--offline", "--scene", "lab", "--plan", "ds3",
              "--out", root)
    assert r.returncode == 2 and "no valid dark calibration" in r.stderr, r.stderr
    r = gonio("calibrate", "dark", "--offline", "--scene", "lab", "--out", root,
              "--frames", "-3")
    assert r.returncode == 2 and "--frames: not a positive number: '-3'" in r.stderr
    r = gonio("calibrate", "white", "--offline")
    assert r.returncode == 2 and "dark, stray or reference" in r.stderr
    assert os.listdir(root) == []


def rig(folder, name, integration):
    """The default rig profile under another name and integration."""
    src = os.path.join(os.environ.get("GONIO_CONFIG", "configs"), "rigs", "default.yaml")
    text = open(src).read().replace("fixed_s: 0.05", "fixed_s: %g" % integration)
    text = text.replace("name: default", "name: %s" % name)
    path = os.path.join(folder, "%s.yaml" % name)
    with open(path, "w") as f:
        f.write(text)
    return path


def calibrate(root, rig_path, *extra):
    d = gonio("calibrate", "dark", "--offline", "--scene", "lab", "--rig", rig_path,
              "--out", root)
    assert d.returncode == 0, d.stderr
    r = gonio("calibrate", "reference", "--offline", "--scene", "lab", "--rig", rig_path,
              "--plan", "ds3", "--out", root, "--repeats", "2", *extra)
    assert r.returncode == 0, r.stderr
    return r.stdout.strip()


def capture(root, rig_path, out, cal="newest"):
    return gonio("capture", "--offline", "--scene", "lab", "--rig", rig_path, "--plan",
                 "ds3", "--material", "analytic:rough-diffuse", "--out", out, "--quiet",
                 "--calibration", cal, "--calibrations", root)


def test_capture_reduced_with_its_calibration(root):
    lab = rig(root, "lab", 0.25)
    cal_id = calibrate(os.path.join(root, "cal"), lab)
    out = os.path.join(root, "cap")
    c = capture(os.path.join(root, "cal"), lab, out)
    assert c.returncode == 0, c.stderr
    rows = [r for r in csv.DictReader(open(os.path.join(out, "samples.csv")))
            if not int(r["flags"]) & 2]  # dark frames apart
    assert len(rows) == 52
    for r in rows:
        assert r["unit"] == "counts" and float(r["raw_g"]) > 1000
        g, u = float(r["g"]), float(r["u_g"])
        assert 0.05 < g < 0.3 and 0 < u < 0.02 * g, r  # BRDF with a ~1 % u
    res = json.load(open(os.path.join(out, "results.json")))
    cal = res["calibration"]
    assert cal["id"] == cal_id and cal["standard"] == "spectralon-99"
    terms = {t["term"]: t for t in cal["budget"]}
    assert terms["reference"]["kind"] == "systematic"
    assert 0.005 < terms["reference"]["median_relative_u"][1] < 0.01
    assert 0.002 < terms["counting"]["median_relative_u"][1] < 0.02


def test_dark_over_the_ladder_lets_a_calibrated_capture_range(root):
    """A sharp specular peak clips at the fixed integration; a dark taken at
    every rung of the ranging ladder lets the calibrated capture shorten
    there (and lengthen in the dark tail), so nothing is left clipped and
    the fit is the better for it."""
    sharp = "analytic:aniso-ggx?ax=0.05&ay=0.05&phi=0"
    res = {}
    for ladder in (True, False):
        cal = os.path.join(root, "ladder" if ladder else "fixed")
        d = gonio("calibrate", "dark", "--offline", "--scene", "lab", "--out", cal,
                  *(["--ladder"] if ladder else []))
        assert d.returncode == 0, d.stderr
        ints = json.load(open(os.path.join(cal, d.stdout.strip(), "calibration.json")))[
            "integrations_s"]
        assert (len(ints) == 7) == ladder, ints  # 0.001 s to 2 s in steps of 4
        r = gonio("calibrate", "reference", "--offline", "--scene", "lab", "--plan", "ds3",
                  "--out", cal)
        assert r.returncode == 0, r.stderr
        out = os.path.join(root, "cap-" + os.path.basename(cal))
        c = gonio("capture", "--offline", "--quiet", "--scene", "lab", "--plan", "ds3",
                  "--material", sharp, "--calibration", r.stdout.strip(), "--calibrations",
                  cal, "--out", out)
        assert c.returncode == 0, c.stderr
        rows = [x for x in csv.DictReader(open(os.path.join(out, "samples.csv")))
                if not int(x["flags"]) & 2]
        res[ladder] = (sum(int(x["flags"]) & 1 for x in rows),
                       sorted({float(x["integration_s"]) for x in rows}),
                       json.load(open(os.path.join(out, "results.json")))["errors"]["full"]["log"])
    clipped, ints, err = res[True]
    assert clipped == 0 and ints[0] < 0.05 < ints[-1], res
    clipped_fixed, ints_fixed, err_fixed = res[False]
    assert clipped_fixed > 10 and ints_fixed == [0.05], res
    assert err < 0.02 < 0.1 < err_fixed, res


def test_capture_refuses_a_calibration_it_cannot_use(root):
    cal = os.path.join(root, "cal")
    lab = rig(root, "lab", 0.25)
    calibrate(cal, lab)
    cases = [
        (rig(root, "bench", 0.25), "newest", "for rig 'bench'"),
        (lab, "reference-none", "calibration reference-none: not found"),
        (rig(root, "lab-long", 0.5), "newest", "rig 'lab'"),
    ]
    # The same rig name, another integration: not covered.
    slow = rig(os.path.join(root), "lab", 0.5)
    for rig_path, cal_id, needle in cases:
        out = os.path.join(root, "cap")
        c = capture(cal, rig_path, out, cal_id)
        assert c.returncode == 2 and needle in c.stderr, (needle, c.stderr)
        assert not os.path.exists(out), "refused before anything was written"
    c = capture(cal, slow, os.path.join(root, "cap"))
    assert c.returncode == 2 and "does not cover integration 0.5 s (it has 0.25 s)" in c.stderr, \
        c.stderr
    r = gonio("capture", "--offline", "--scene", "lab", "--plan", "ds3", "--out",
              os.path.join(root, "cap"), "--calibration", "x")
    assert r.returncode == 2 and "--calibration needs --calibrations ROOT" in r.stderr


def test_expired_calibration_refused(root):
    cal = os.path.join(root, "cal")
    lab = rig(root, "lab", 0.25)
    calibrate(cal, lab, "--valid", "0.02")  # the reference for 1.2 s
    time.sleep(2.5)
    c = capture(cal, lab, os.path.join(root, "cap"))
    assert c.returncode == 2 and "expired at" in c.stderr, c.stderr


def test_resume_keeps_its_calibration(root):
    """setup.json names the calibration: a capture resumed with another is
    refused, naming both."""
    cal = os.path.join(root, "cal")
    lab = rig(root, "lab", 0.25)
    first = calibrate(cal, lab)
    out = os.path.join(root, "cap")
    c = capture(cal, lab, out, first)
    assert c.returncode == 0, c.stderr
    assert json.load(open(os.path.join(out, "setup.json")))["calibration"] == first
    time.sleep(1.1)  # a new id: ids are to the second
    second = calibrate(cal, lab)
    assert second != first
    c = capture(cal, lab, out, second)
    assert c.returncode == 2, c.stderr
    assert "setup.json has calibration '%s', this capture asks for '%s'" % (first, second) \
        in c.stderr, c.stderr


def digest(folder):
    """Every file of a capture directory, by name, as bytes."""
    return {f: open(os.path.join(folder, f), "rb").read() for f in sorted(os.listdir(folder))
            if os.path.isfile(os.path.join(folder, f))}


def test_recalibrate_equals_capturing_with_that_calibration(root):
    """A capture reduced again with calibration B equals, byte for byte,
    the same seeded capture taken with B; the original is left as it was."""
    cal = os.path.join(root, "cal")
    lab = rig(root, "lab", 0.25)
    first = calibrate(cal, lab)
    time.sleep(1.1)  # a new id: ids are to the second
    r = gonio("calibrate", "reference", "--offline", "--scene", "lab", "--rig", lab,
              "--plan", "ds3", "--out", cal, "--repeats", "3")  # other frames, another gain
    assert r.returncode == 0, r.stderr
    second = r.stdout.strip()
    cap_a, cap_b = os.path.join(root, "a"), os.path.join(root, "b")
    assert capture(cal, lab, cap_a, first).returncode == 0
    assert capture(cal, lab, cap_b, second).returncode == 0
    before = digest(cap_a)
    out = os.path.join(root, "re")
    r = gonio("recalibrate", cap_a, "--calibration", second, "--calibrations", cal, "-o", out)
    assert r.returncode == 0, r.stderr
    assert digest(cap_a) == before, "the original record is never written"
    a = list(csv.DictReader(open(os.path.join(cap_a, "samples.csv"))))
    b = list(csv.DictReader(open(os.path.join(cap_b, "samples.csv"))))
    re = list(csv.DictReader(open(os.path.join(out, "samples.csv"))))
    cols = ["r", "g", "b", "u_r", "u_g", "u_b"]
    # The two calibrations reduce the same raw counts differently ...
    assert [x["raw_g"] for x in a] == [x["raw_g"] for x in b]
    assert sum(x["g"] != y["g"] for x, y in zip(a, b)) > 40
    # ... and recalibrating with B gives B's values exactly, as text.
    assert [[x[c] for c in cols] for x in re] == [[x[c] for c in cols] for x in b]
    assert open(os.path.join(out, "samples.csv"), "rb").read() == \
        open(os.path.join(cap_b, "samples.csv"), "rb").read()
    assert open(os.path.join(out, "abc.model"), "rb").read() == \
        open(os.path.join(cap_b, "abc.model"), "rb").read()
    assert open(os.path.join(out, "abc.model"), "rb").read() != \
        open(os.path.join(cap_a, "abc.model"), "rb").read()
    setup = json.load(open(os.path.join(out, "setup.json")))
    assert setup["calibration"] == second and setup["recalibrated_from"] == cap_a
    res = json.load(open(os.path.join(out, "results.json")))
    assert res["calibration"]["id"] == second
    assert res["calibration"]["budget"] == \
        json.load(open(os.path.join(cap_b, "results.json")))["calibration"]["budget"]
    # Beside the capture by default, and never over another.
    r = gonio("recalibrate", cap_a, "--calibration", second, "--calibrations", cal)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == os.path.join(cap_a, "recalibrated-" + second)
    r = gonio("recalibrate", cap_a, "--calibration", second, "--calibrations", cal, "-o", out)
    assert r.returncode == 2 and "already holds a capture" in r.stderr, r.stderr


def test_recalibrate_refusals(root):
    cal = os.path.join(root, "cal")
    lab = rig(root, "lab", 0.25)
    cal_id = calibrate(cal, lab)
    other = calibrate(os.path.join(root, "cal2"), rig(root, "bench", 0.25))
    cap = os.path.join(root, "cap")
    assert capture(cal, lab, cap, cal_id).returncode == 0
    r = gonio("recalibrate", cap, "--calibration", other, "--calibrations",
              os.path.join(root, "cal2"), "-o", os.path.join(root, "x"))
    assert r.returncode == 2 and "is for rig 'bench'" in r.stderr \
        and "taken on rig 'lab'" in r.stderr, r.stderr
    brdf = os.path.join(root, "brdf")  # a detector that reports BRDF: nothing raw
    c = gonio("capture", "--offline", "--scene", "ideal", "--plan", "ds4", "--out", brdf,
              "--quiet")
    assert c.returncode == 0, c.stderr
    r = gonio("recalibrate", brdf, "--calibration", cal_id, "--calibrations", cal, "-o",
              os.path.join(root, "y"))
    assert r.returncode == 2 and "no record holds raw counts" in r.stderr, r.stderr
    r = gonio("recalibrate", cap, "--calibrations", cal)
    assert r.returncode == 2 and "--calibration ID" in r.stderr
    assert not os.path.exists(os.path.join(root, "x")) and not os.path.exists(
        os.path.join(root, "y"))


def test_bad_day_reference_over_ds1_geometries(root):
    """bad-day's drives settle 0.08 deg (sd) about their targets, so about
    one move in five rests outside the default rig's 0.1 deg band and is
    re-commanded, each try a fresh draw (no side, no bias). A reference
    over DS1's geometries or reference-grid makes hundreds of moves; on the
    scene's seed the sample axis misses six times in a row at 50 deg (DS1)
    and 70 deg (reference-grid), so the rig's tries must outlast such a run
    (docs/plans.md, "Rig profile"): both references read, every point."""
    d = gonio("calibrate", "dark", "--offline", "--scene", "bad-day", "--out", root)
    assert d.returncode == 0, d.stderr
    for plan, incidence in (("ds1", 50), ("reference-grid", 70)):
        r = gonio("calibrate", "reference", "--offline", "--scene", "bad-day", "--plan", plan,
                  "--out", root)
        assert r.returncode == 0, r.stderr
        folder = os.path.join(root, r.stdout.strip())
        meta = json.load(open(os.path.join(folder, "calibration.json")))
        rows = list(csv.DictReader(open(os.path.join(folder, "frames.csv"))))
        assert meta["frames"] == len(rows) > 0
        assert any(float(x["theta_i"]) == incidence for x in rows)
        assert min(float(x["g"]) for x in rows) > 2000  # the standard, lit, above the offset


def test_offline_runs_as_event_model_documents(root):
    """Each offline calibration writes its run as event-model documents
    (documents.jsonl), valid against Bluesky's schemas, an event per frame
    with its counts (a spectral detector's bands too), a results event per
    integration (dark) or geometry (reference) with the frames' mean and
    spread, and the reference's start naming its dark's run."""
    import sys
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    import gonio_cal_events as ev
    v, why = ev.validators()
    if v is None:
        pytest.skip(why)
    d = gonio("calibrate", "dark", "--offline", "--scene", "spectral-lab", "--out", root,
              "--integration", "0.2", "--frames", "4")
    assert d.returncode == 0, d.stderr
    dark_id = d.stdout.strip()
    pairs = ev.read_documents(os.path.join(root, dark_id))
    start, stop, streams = ev.check_run(pairs, os.path.join(root, dark_id), v)
    assert (start["kind"], start["detector"], stop["exit_status"]) == ("dark", "spectral", "success")
    assert start["integrations"] == [0.05, 0.2] and start["continues"] is None
    assert len(streams["primary"][1]) == 8 and len(streams["results"][1]) == 2
    assert streams["primary"][0]["data_keys"]["bands"]["shape"] == [31]
    assert streams["primary"][0]["configuration"]["detector"]["data"]["bands_nm"][0] == 400
    dark_uid = open(os.path.join(root, dark_id, "run-uids.txt")).read().split()
    assert dark_uid == [start["uid"]]
    r = gonio("calibrate", "reference", "--offline", "--scene", "spectral-lab", "--plan", "ds3",
              "--out", root, "--repeats", "2")
    assert r.returncode == 0, r.stderr
    ref_dir = os.path.join(root, r.stdout.strip())
    start, stop, streams = ev.check_run(ev.read_documents(ref_dir), ref_dir, v)
    assert (start["kind"], start["dark"], start["dark_uid"]) == ("reference", dark_id,
                                                                 dark_uid[0])
    assert start["standard"] == "spectralon-99" and start["plan"] == "ds3"
    assert len(streams["primary"][1]) == 104 and len(streams["results"][1]) == 52
