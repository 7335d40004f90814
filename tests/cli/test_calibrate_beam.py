"""gonio calibrate beam, the absolute method, on the simulated lab whose arm
faces the source (configs/scenes/lab-beam.yaml, configs/rigs/beam.yaml): a
capture reduced with the direct beam and the rig profile's solid angle
recovers the material, exactly where the scene has no noise; agrees with the
relative method on the same capture within their combined uncertainty; and a
rig profile that states a wrong aperture shows up as the scale error its
solid angle makes. The refusals name the file, field and value."""
import json
import os
import statistics
import subprocess
import sys
import tempfile

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import gonio_cal  # noqa: E402

BIN = os.environ.get("GONIO_BIN", "build/bin")
GONIO = os.path.join(BIN, "gonio")
CONFIG = os.environ.get("GONIO_CONFIG", "configs")
MATERIAL = "analytic:rough-diffuse"
SCENE = "lab-beam"


def gonio(*args):
    return subprocess.run([GONIO, *args], capture_output=True, text=True, timeout=300)


def ok(r, what):
    assert r.returncode == 0, "%s: %s" % (what, r.stderr)
    return r.stdout.strip()


@pytest.fixture(scope="module")
def work():
    with tempfile.TemporaryDirectory(prefix="calibrate_beam_") as d:
        yield d


def calibrate(root, scene=SCENE, rig=None, repeats="16"):
    """A dark covering the beam's integration (0.05 s) and the rig's, then
    the beam: the beam calibration's id."""
    rig_opt = ["--rig", rig] if rig else []
    if not os.path.isdir(root) or not any(x.startswith("dark-") for x in os.listdir(root)):
        ok(gonio("calibrate", "dark", "--offline", "--scene", scene, *rig_opt, "--out", root,
                 "--integration", "0.05"), "dark")
    return ok(gonio("calibrate", "beam", "--offline", "--scene", scene, *rig_opt, "--out",
                    root, "--integration", "0.05", "--repeats", repeats), "beam")


def capture(root, cal_id, out, scene=SCENE):
    ok(gonio("capture", "--offline", "--scene", scene, "--plan", "ds3", "--material", MATERIAL,
             "--out", out, "--quiet", "--calibration", cal_id, "--calibrations", root),
       "capture")
    return out


def values(capdir):
    """(measured, true) per channel value of capdir's samples (dark frames
    and clipped readings apart), the truth at the recorded angles."""
    rows = [x for x in gonio_cal.frames(os.path.join(capdir, "samples.csv"))
            if not int(x["flags"]) & 2 and x["g"]]
    truth = gonio_cal.material_values(MATERIAL, rows)
    return rows, truth


def snr_values(capdir, cal_root):
    """The measured/true ratios of the values with SNR >= 100 (the chain's
    own test of counting noise, tests/gonio_cal.py), against the material
    alone and against the material plus the scene's stray-light floor,
    which the dark does not see and no standard divides out here."""
    rows, truth = values(capdir)
    dark = [d for d in os.listdir(cal_root) if d.startswith("dark-")][0]
    dark_rows = gonio_cal.frames(os.path.join(cal_root, dark, "frames.csv"))
    s = gonio_cal.stray_floor(SCENE)
    darks = [float(d["g"]) for d in dark_rows if abs(float(d["integration_s"]) - 0.25) < 1e-9]
    mean, sd = statistics.mean(darks), statistics.pstdev(darks)
    mat, chain = [], []
    for k, x in enumerate(rows):
        for c, name in enumerate("rgb"):
            signal = float(x["raw_" + name]) - mean
            if signal < 100 * (0.8 * max(signal, 0) + sd * sd) ** 0.5:
                continue
            got = float(x[name])
            mat.append(got / truth[k][c])
            chain.append(got / (truth[k][c] + s))
    return mat, chain


def test_beam_calibration_recovers_the_material(work):
    """On lab-beam (shot, read and dark noise, a drifting lamp and its
    monitor, stray light, the ADC's nonlinearity): DS3 of a diffuse sample
    reduced with the beam comes back within a few tenths of a per cent."""
    root = os.path.join(work, "cal")
    beam = calibrate(root)
    meta = json.load(open(os.path.join(root, beam, "calibration.json")))
    assert meta["kind"] == "beam" and meta["rig"] == "beam" and meta["spot"] == "underfilled"
    # Omega = pi (5 mm)^2 / (800 mm)^2 from the rig profile, with its u.
    assert abs(meta["beam"]["solid_angle_sr"] / 1.2271846303085129e-4 - 1) < 1e-9
    assert abs(meta["beam"]["solid_angle_relative_u"] - 2 ** 0.5 * 1e-3) < 1e-9
    assert meta["beam"]["attenuation"] == 1e-4 and meta["integrations_s"][0] == 0.05
    cap = capture(root, beam, os.path.join(work, "cap"))
    mat, chain = snr_values(cap, root)
    assert len(mat) >= 100, len(mat)
    med = statistics.median(abs(r - 1) for r in mat)
    # The values' own counting noise (0.5-0.7 %) makes most of it.
    assert med < 0.006, med
    # No scale error: against what the detector sees (the material plus
    # the stray light), the median ratio within 0.3 % of 1.
    assert abs(statistics.median(chain) - 1) < 0.003, statistics.median(chain)
    res = json.load(open(os.path.join(cap, "results.json")))["calibration"]
    terms = {t["term"]: t for t in res["budget"]}
    assert terms["reference"]["median_relative_u"] == [0.0, 0.0, 0.0]
    assert terms["solid_angle"]["kind"] == "systematic"
    assert abs(terms["solid_angle"]["median_relative_u"][1] - 2 ** 0.5 * 1e-3) < 1e-9
    assert abs(terms["attenuator"]["median_relative_u"][1] - 0.003) < 1e-9
    assert 0 < terms["reference_noise"]["median_relative_u"][1] < 0.005


EXACT = """name: exact-beam
material: default
rig: beam
detector: {kind: rgb, responsivity: 1.0e6, spot: underfilled,
           solid_angle_sr: 1.2271846303085129e-4, attenuator: 1.0e-4}
seed: 1
effects:
  - {name: dark, rate_e_per_s: 500}
  - {name: adc, gain_adu_per_e: 0.8, bits: 16, offset_adu: 1000, nonlinearity: 0.02}
"""


def test_absolute_equation_exact_without_noise(work):
    """The simulator's geometry and the rig profile's agree: with no noise,
    drift or stray light (an ADC with its offset, dark and nonlinearity
    still), every value is the material's to the ADC's rounding."""
    scene = os.path.join(work, "exact.yaml")
    with open(scene, "w") as f:
        f.write(EXACT)
    root = os.path.join(work, "exact-cal")
    beam = calibrate(root, scene=scene, repeats="4")
    rows, truth = values(capture(root, beam, os.path.join(work, "exact-cap"), scene=scene))
    err = [abs(float(x[n]) / truth[k][c] - 1) for k, x in enumerate(rows)
           for c, n in enumerate("rgb")]
    assert len(err) == 3 * 52
    assert max(err) < 3e-4, max(err)


def test_agrees_with_the_relative_method(work):
    """The same capture reduced by the relative method (a reference taken
    with the same dark, gonio recalibrate) agrees with the beam's within
    their combined standard uncertainty (k = 2): the systematic terms of
    both budgets and the two calibrations' reading noise."""
    root = os.path.join(work, "cal")
    cap = os.path.join(work, "cap")
    if not os.path.isdir(cap):
        pytest.skip("needs test_beam_calibration_recovers_the_material's capture")
    ref = ok(gonio("calibrate", "reference", "--offline", "--scene", SCENE, "--plan", "ds3",
                   "--out", root, "--repeats", "4", "--spot", "underfilled"), "reference")
    rel = os.path.join(work, "relative")
    ok(gonio("recalibrate", cap, "--calibration", ref, "--calibrations", root, "-o", rel),
       "recalibrate")
    a, _ = values(cap)
    b, _ = values(rel)
    budgets = [json.load(open(os.path.join(d, "results.json")))["calibration"]["budget"]
               for d in (cap, rel)]
    for c, name in enumerate("rgb"):
        ratio = statistics.median(float(x[name]) / float(y[name]) for x, y in zip(a, b))
        u2 = 0.0
        for budget in budgets:
            for t in budget:
                if t["kind"] == "systematic" or t["term"] == "reference_noise":
                    u2 += t["median_relative_u"][c] ** 2
        assert abs(ratio - 1) < 2 * u2 ** 0.5, (name, ratio, u2 ** 0.5)
        # and not by luck of a wide budget: the two differ by well under 1 %
        assert abs(ratio - 1) < 0.01, (name, ratio)


def beam_rig(folder, text_from, text_to):
    """configs/rigs/beam.yaml with one line changed (same rig name)."""
    text = open(os.path.join(CONFIG, "rigs", "beam.yaml")).read()
    assert text_from in text
    path = os.path.join(folder, "beam-%d.yaml" % abs(hash(text_to)))
    with open(path, "w") as f:
        f.write(text.replace(text_from, text_to))
    return path


def test_wrong_aperture_shows_as_its_scale_error(work):
    """A rig profile stating a 10.1 mm aperture where the detector's is
    10 mm: the beam calibration's solid angle is (10.1/10)^2 too large, and
    every value of the capture comes back that much too small."""
    root = os.path.join(work, "cal")
    cap = os.path.join(work, "cap")
    if not os.path.isdir(cap):
        pytest.skip("needs test_beam_calibration_recovers_the_material's capture")
    wrong = beam_rig(work, "aperture_diameter_mm: 10 ", "aperture_diameter_mm: 10.1 ")
    beam = calibrate(root, rig=wrong)
    out = os.path.join(work, "wrong")
    ok(gonio("recalibrate", cap, "--calibration", beam, "--calibrations", root, "-o", out),
       "recalibrate")
    mat, _ = snr_values(out, root)
    right, _ = snr_values(cap, root)
    expected = (10 / 10.1) ** 2  # -1.97 %
    got = statistics.median(mat) / statistics.median(right)
    # the two beam calibrations' own noise: ~0.1 % each
    assert abs(got / expected - 1) < 0.003, (got, expected)


def test_reference_after_refused_with_a_beam_calibration(work):
    """--reference-after reads the standard again and reduces it against
    the calibration's: a beam calibration has no standard, so the capture
    is refused before anything moves, naming the calibration."""
    root = os.path.join(work, "cal")
    beam = calibrate(root)
    out = os.path.join(work, "after")
    r = gonio("capture", "--offline", "--scene", SCENE, "--plan", "ds3", "--material", MATERIAL,
              "--out", out, "--quiet", "--calibration", beam, "--calibrations", root,
              "--reference-after")
    assert r.returncode == 2 and beam in r.stderr and "--reference-after" in r.stderr and \
        "reference calibration" in r.stderr, r.stderr
    assert not os.path.exists(os.path.join(out, "journal.csv"))


def test_spectral_detector_refused_when_selected(work):
    """A beam calibration of a spectral detector has no per-band reduction:
    the capture naming it is refused when it is selected, before anything
    moves, and not once the capture's points are spent."""
    root = os.path.join(work, "spectral")
    rig = os.path.join(CONFIG, "rigs", "beam.yaml")
    ok(gonio("calibrate", "dark", "--offline", "--scene", "spectral-lab", "--rig", rig, "--out",
             root, "--integration", "0.05"), "dark")
    beam = ok(gonio("calibrate", "beam", "--offline", "--scene", "spectral-lab", "--rig", rig,
                    "--out", root, "--integration", "0.05", "--repeats", "4"), "beam")
    out = os.path.join(work, "spectral-cap")
    r = gonio("capture", "--offline", "--scene", "spectral-lab", "--rig", rig, "--plan", "ds3",
              "--material", MATERIAL, "--out", out, "--quiet", "--calibration", beam,
              "--calibrations", root)
    assert r.returncode == 2 and beam in r.stderr and "no per-band reduction" in r.stderr, \
        r.stderr
    assert not os.path.exists(os.path.join(out, "journal.csv"))


def test_refusals(work):
    root = os.path.join(work, "refused")
    # the lab's rig states no beam geometry
    r = gonio("calibrate", "beam", "--offline", "--scene", "lab", "--out", root)
    assert r.returncode == 2 and "rig 'default' states no beam geometry" in r.stderr, r.stderr
    # a rig profile's beam section: file, field and value
    bad = beam_rig(work, "arm_deg: 180 ", "arm_deg: 200 ")
    r = gonio("calibrate", "beam", "--offline", "--scene", SCENE, "--rig", bad, "--out", root)
    assert r.returncode == 2 and bad in r.stderr and "arm_deg" in r.stderr and "200" in \
        r.stderr, r.stderr
    bad = beam_rig(work, "distance_mm: 800 ", "distance_mm: -800 ")
    r = gonio("calibrate", "beam", "--offline", "--scene", SCENE, "--rig", bad, "--out", root)
    assert r.returncode == 2 and bad in r.stderr and "distance_mm" in r.stderr and "-800" in \
        r.stderr, r.stderr
    both = beam_rig(work, "  distance_mm: 800 ", "  aperture_area_mm2: 78.5\n  distance_mm: 800 ")
    r = gonio("calibrate", "beam", "--offline", "--scene", SCENE, "--rig", both, "--out", root)
    assert r.returncode == 2 and both in r.stderr and "one of them" in r.stderr, r.stderr
    # an uncertainty for the other way of giving the aperture: file and key
    for frm, to, key in (("aperture_diameter_u_mm: 0.005", "aperture_area_u_mm2: 0.08",
                          "aperture_area_u_mm2"),
                         ("aperture_diameter_mm: 10 ", "aperture_area_mm2: 78.5 ",
                          "aperture_diameter_u_mm")):
        mixed = beam_rig(work, frm, to)
        r = gonio("calibrate", "beam", "--offline", "--scene", SCENE, "--rig", mixed, "--out",
                  root)
        assert r.returncode == 2 and mixed in r.stderr and key in r.stderr, r.stderr
    # goniod does not take it; say so before any connection
    r = gonio("calibrate", "beam")
    assert r.returncode == 2 and "offline only" in r.stderr, r.stderr
    # the beam is read at one integration
    r = gonio("calibrate", "beam", "--offline", "--scene", SCENE, "--out", root,
              "--integration", "0.05", "--integration", "0.2")
    assert r.returncode == 2 and "one --integration" in r.stderr and "2 given" in r.stderr, \
        r.stderr
    assert not os.path.exists(root) or os.listdir(root) == []
