"""The premise checks as an operator meets them: gonio capture --check
isotropy on the rotating rig says "anisotropic" for an anisotropic material
and "isotropic" for an isotropic one, with its evidence and rig time in
results.json and gonio results; a rig without a rotation axis and an
unknown check are refused (exit 2, nothing written); the MERL export
refuses an anisotropic material and a bad material parameter is named."""
import json
import os
import subprocess
import tempfile

import pytest

import gonio_cal

BIN = os.environ.get("GONIO_BIN", "build/bin")
GONIO = os.path.join(BIN, "gonio")
ANISO = "analytic:aniso-ggx?ax=0.08&ay=0.16&phi=30"


def gonio(*args):
    return subprocess.run([GONIO, *args], capture_output=True, text=True, timeout=300)


@pytest.fixture
def tmp():
    with tempfile.TemporaryDirectory(prefix="checks_") as d:
        yield d


def check(tmp, material, scene="ideal"):
    out = os.path.join(tmp, "cap")
    r = gonio("capture", "--offline", "--quiet", "--scene", scene, "--rig", "rotating",
              "--plan", "ds2", "--material", material, "--check", "isotropy", "--out", out)
    assert r.returncode == 0, r.stderr
    with open(os.path.join(out, "results.json")) as f:
        return out, r.stdout, json.load(f)


def test_anisotropic_material_found(tmp):
    out, text, res = check(tmp, ANISO)
    c = res["checks"]["isotropy"]
    assert c["verdict"] == "anisotropic"
    assert c["significance"] > c["threshold"] > 0
    assert c["max_deviation"] > 0.2
    assert c["worst"]["rotation_deg"] in (60, 120)
    assert c["pairs"] == 6 and c["measurements"] == 18
    assert c["false_alarm_rate"] == 0.01
    assert 0 < c["rig_time_s"] < 0.2 * res["rig_time_s"]
    assert "isotropy check: anisotropic" in text
    rows = json.loads(gonio("results", "--json", out).stdout)
    assert rows[0]["isotropy"] == "anisotropic"
    assert rows[0]["isotropy_s"] == pytest.approx(c["rig_time_s"])


def test_isotropic_material_passes(tmp):
    # With detector noise: lab's, read by the simulator's ideal meter (the
    # check's own readings on lab's counts are not reduced by a calibration)
    _, _, res = check(tmp, "analytic:plastic-ggx", scene=gonio_cal.metered_scene(tmp))
    c = res["checks"]["isotropy"]
    assert c["verdict"] == "isotropic", c["why"]
    assert c["significance"] < c["threshold"]


def test_rig_without_rotation_refused(tmp):
    out = os.path.join(tmp, "cap")
    r = gonio("capture", "--offline", "--scene", "ideal", "--plan", "ds3", "--check",
              "isotropy", "--out", out)
    assert r.returncode == 2
    assert "rotation" in r.stderr and "'default'" in r.stderr
    assert not os.path.exists(out)
    r = gonio("capture", "--offline", "--scene", "ideal", "--rig", "rotating", "--plan", "ds3",
              "--check", "planarity", "--out", out)
    assert r.returncode == 2 and "'planarity'" in r.stderr


def test_no_check_no_verdict(tmp):
    out = os.path.join(tmp, "cap")
    r = gonio("capture", "--offline", "--quiet", "--scene", "ideal", "--rig", "rotating",
              "--plan", "ds3", "--material", ANISO, "--out", out)
    assert r.returncode == 0, r.stderr
    with open(os.path.join(out, "results.json")) as f:
        assert json.load(f)["checks"] == {}


def test_material_errors(tmp):
    path = os.path.join(tmp, "a.binary")
    r = gonio("export", "merl", "--material", ANISO, "-o", path)
    assert r.returncode == 2 and "anisotropic" in r.stderr
    assert not os.path.exists(path)
    r = gonio("export", "merl", "--material", "analytic:aniso-ggx?ax=0.08&ay=zz", "-o", path)
    assert r.returncode == 2 and "'ay'" in r.stderr and "'zz'" in r.stderr
