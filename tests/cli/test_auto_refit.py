"""`gonio fit --model auto DIR` of a capture directory takes the premise
checks' verdicts the capture recorded in results.json as its evidence, in
the capture's own steps (fit_auto_settle): it chooses the model the
capture chose and says why in the same words. The out-of-plane replay's
latent candidate needs the shared decoder: skipped visibly without it."""
import json
import os
import shutil
import sys
import tempfile

import pytest

# The anisotropic material and three-azimuth plan of the capture checks.
from test_auto_checks import ANISO, AZ3, gonio


@pytest.fixture
def tmp():
    with tempfile.TemporaryDirectory(prefix="auto_refit_") as d:
        yield d


def capture(tmp, name, plan, check):
    out = os.path.join(tmp, name)
    r = gonio("capture", "--offline", "--quiet", "--scene", "ideal", "--rig", "rotating",
              "--plan", plan, "--material", ANISO, "--model", "auto", "--check", check,
              "--out", out)
    assert r.returncode == 0, r.stderr
    with open(os.path.join(out, "results.json")) as f:
        return out, json.load(f)


def refit(tmp, out):
    """gonio fit --model auto of the directory: its auto line and model file keys."""
    model = os.path.join(tmp, "refit.model")
    r = gonio("fit", out, "--model", "auto", "--quiet", "-o", model)
    assert r.returncode == 0, r.stderr
    assert "results.json" in r.stdout  # it says where its evidence came from
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("auto ")]
    assert len(line) == 1, r.stdout
    keys = {}
    with open(model, "rb") as f:
        for raw in f:
            text = raw.decode("utf-8", errors="replace").rstrip("\n")
            if text.startswith("data "):
                break
            k, _, v = text.partition(" ")
            keys[k] = v
    return line[0][len("auto"):].strip(), keys


def results_row(out):
    r = gonio("results", "--json", out)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)[0]


def test_refit_of_an_anisotropic_capture_chooses_as_it_did(tmp):
    plan = os.path.join(tmp, "ds2-az3.yaml")
    with open(plan, "w") as f:
        f.write(AZ3)
    out, res = capture(tmp, "aniso", plan, "isotropy")
    a = res["auto"]
    assert a["chosen"] == "aniso-ggx" and a["isotropy"] == "anisotropic"
    line, keys = refit(tmp, out)
    assert line == "%s; %s" % (a["chosen"], a["why"])
    assert keys["auto_why"] == a["why"]
    # the anisotropic verdict left the isotropic candidates out, as in the capture
    assert "auto_cv_aniso-ggx" in keys and "auto_cv_abc" not in keys
    row = results_row(out)
    assert (row["auto"], row["auto_why"]) == (a["chosen"], a["why"])
    # the Python client reads the same (python/gonio, docs/python.md)
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "python"))
    import gonio as gonio_py
    cap = gonio_py.read_capture(out)
    assert cap.auto == a and cap.checks == res["checks"]
    assert row["isotropy_sigma"] == pytest.approx(res["checks"]["isotropy"]["significance"])
    assert row["oop_full"] is None and row["oop_ratio"] is None  # no out-of-plane check
    refit_of_files(tmp, out)
    refit_of_a_malformed_results_json(tmp, out)


def fit_auto(tmp, samples):
    model = os.path.join(tmp, "files.model")
    return gonio("fit", samples, "--model", "auto", "--quiet", "-o", model), model


def refit_of_files(tmp, out):
    """A samples file is fitted without a capture's verdicts, even with a
    results.json beside it: only a capture directory's own are its evidence."""
    elsewhere = os.path.join(tmp, "elsewhere")
    os.mkdir(elsewhere)
    shutil.copy(os.path.join(out, "samples.csv"), os.path.join(elsewhere, "other.csv"))
    shutil.copy(os.path.join(out, "results.json"), elsewhere)
    for samples in (os.path.join(elsewhere, "other.csv"), os.path.join(out, "samples.csv")):
        r, model = fit_auto(tmp, samples)
        assert r.returncode == 0, r.stderr
        assert "results.json" not in r.stdout
        assert "evidence   none (a samples file" in r.stdout, r.stdout
        with open(model, "rb") as f:  # no anisotropic verdict left abc out
            assert b"auto_cv_abc " in f.read().split(b"\ndata ")[0]


def test_refit_replays_the_out_of_plane_verdicts(tmp):
    shared = os.environ.get("GONIO_SHARED", "../shared")
    if not os.path.isdir(shared):
        pytest.skip(f"shared data not found at {shared}: the latent candidate needs it")
    # one azimuth: every isotropic candidate was judged insufficient in turn
    out, res = capture(tmp, "oop", "ds2", "isotropy,out-of-plane")
    a = res["auto"]
    assert set(a["out_of_plane"].values()) == {"insufficient"} and len(a["out_of_plane"]) == 3
    line, keys = refit(tmp, out)
    assert line == "%s; %s" % (a["chosen"], a["why"])
    assert "no candidate sufficient" in line
    c = res["checks"]["out_of_plane"]
    row = results_row(out)
    assert row["oop_full"] == pytest.approx(c["error_full"])
    assert [row["oop_full_low"], row["oop_full_high"]] == pytest.approx(c["error_full_interval"])
    assert row["oop_ratio"] == pytest.approx(c["ratio"])
    table = gonio("results", out).stdout.splitlines()
    assert "est. full log" in table[0] and ("%.4f" % c["error_full"]) in table[1]


def refit_of_a_malformed_results_json(tmp, out):
    """A results.json that is not JSON, or whose verdict is not a string,
    is refused naming the file and what is wrong: never refitted without
    the evidence it was meant to give."""
    bad = os.path.join(tmp, "bad")
    shutil.copytree(out, bad)
    results = os.path.join(bad, "results.json")
    with open(results) as f:
        doc = json.load(f)
    with open(results, "w") as f:
        f.write(json.dumps(doc)[:-1])  # cut short
    r, _ = fit_auto(tmp, bad)
    assert r.returncode == 2 and results in r.stderr, (r.returncode, r.stderr)
    doc["checks"]["isotropy"]["verdict"] = 1
    with open(results, "w") as f:
        json.dump(doc, f)
    r, _ = fit_auto(tmp, bad)
    assert r.returncode == 2, r.stderr
    assert "%s: checks.isotropy.verdict: not a string" % results in r.stderr
