"""--model auto with the premise checks (fit/auto_evidence.h,
docs/model-choice.md): an isotropy verdict of "anisotropic" on samples at
three sample azimuths makes the anisotropic model the choice; "isotropic"
keeps it out of the candidates; a chosen model the out-of-plane check
judges insufficient is checked against the others in turn, each measured
once, and results.json's `auto` says what was chosen and why, with the
check's rig time that of every candidate checked. The latent candidate
needs the shared decoder: skipped visibly without it."""
import json
import os
import subprocess
import tempfile

import pytest

BIN = os.environ.get("GONIO_BIN", "build/bin")
GONIO = os.path.join(BIN, "gonio")
ANISO = "analytic:aniso-ggx?ax=0.08&ay=0.16&phi=30"
AZ3 = """name: ds2-az3
grid: {theta_i_step: 15, diffuse_step: 10, glossy_step: 2, glossy_half_width: 15}
sample_azimuths: 3
"""


def gonio(*args):
    return subprocess.run([GONIO, *args], capture_output=True, text=True, timeout=600)


def shared_or_skip():
    shared = os.environ.get("GONIO_SHARED", "../shared")
    if not os.path.isdir(shared):
        pytest.skip(f"shared data not found at {shared}: the latent candidate needs it")


@pytest.fixture
def tmp():
    with tempfile.TemporaryDirectory(prefix="auto_checks_") as d:
        yield d


def capture(tmp, name, plan, material, model, check):
    out = os.path.join(tmp, name)
    r = gonio("capture", "--offline", "--quiet", "--scene", "ideal", "--rig", "rotating",
              "--plan", plan, "--material", material, "--model", model, "--check", check,
              "--out", out)
    assert r.returncode == 0, r.stderr
    with open(os.path.join(out, "results.json")) as f:
        res = json.load(f)
    res["stdout"] = r.stdout
    return out, res


def model_keys(out):
    """The model file's header keys (binary data follows them)."""
    keys = {}
    with open(os.path.join(out, "auto.model"), "rb") as f:
        for raw in f:
            line = raw.decode("utf-8", errors="replace").rstrip("\n")
            if line.startswith("data "):
                break
            k, _, v = line.partition(" ")
            keys[k] = v
    return keys


def test_anisotropic_verdict_chooses_the_anisotropic_model(tmp):
    plan = os.path.join(tmp, "ds2-az3.yaml")
    with open(plan, "w") as f:
        f.write(AZ3)
    out, res = capture(tmp, "aniso", plan, ANISO, "auto", "isotropy")
    assert res["auto"]["why"] in res["stdout"] and "auto: aniso-ggx; " in res["stdout"]
    assert res["checks"]["isotropy"]["verdict"] == "anisotropic"
    a = res["auto"]
    assert a["chosen"] == "aniso-ggx" and a["isotropy"] == "anisotropic"
    assert "anisotropic" in a["why"] and "aniso-ggx only" in a["why"]
    keys = model_keys(out)
    assert keys["auto_why"] == a["why"]
    # the anisotropic model alone was cross-validated: no isotropic figure
    assert "auto_cv_aniso-ggx" in keys and "auto_cv_abc" not in keys


def test_isotropic_verdict_leaves_the_anisotropic_model_out(tmp):
    shared_or_skip()
    plan = os.path.join(tmp, "ds2-az3.yaml")
    with open(plan, "w") as f:
        f.write(AZ3)
    out, res = capture(tmp, "iso", plan, "analytic:plastic-ggx", "auto", "isotropy")
    assert res["checks"]["isotropy"]["verdict"] == "isotropic"
    a = res["auto"]
    assert a["isotropy"] == "isotropic" and a["chosen"] != "aniso-ggx"
    assert "isotropic candidates only" in a["why"]
    keys = model_keys(out)
    assert "auto_cv_abc" in keys and "auto_cv_aniso-ggx" not in keys


def test_insufficient_choice_checks_the_others(tmp):
    shared_or_skip()
    # one azimuth of an anisotropic material: no isotropic model holds out
    # of the plane, so every candidate is checked once and the lowest CV
    # error stays, saying so
    out, res = capture(tmp, "oop", "ds2", ANISO, "auto", "isotropy,out-of-plane")
    a = res["auto"]
    assert "sample_azimuths" in a["why"]
    assert a["out_of_plane"] == {"abc": "insufficient", "abc-prior": "insufficient",
                                 "latent": "insufficient"}
    assert "no candidate sufficient" in a["why"]
    keys = model_keys(out)
    cv = {m: float(keys["auto_cv_" + m]) for m in ("abc", "abc-prior", "latent")}
    assert a["chosen"] == min(cv, key=cv.get)
    c = res["checks"]["out_of_plane"]
    assert c["verdict"] == "insufficient"
    # the check's rig time is every candidate's: against one check of abc
    _, one = capture(tmp, "abc", "ds2", ANISO, "abc", "out-of-plane")
    single = one["checks"]["out_of_plane"]["rig_time_s"]
    assert c["rig_time_s"] > 2 * single
    assert one["auto"] is None
