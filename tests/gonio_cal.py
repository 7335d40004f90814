"""A calibration for tests that capture on a realistic scene (lab, bad-day),
whose detector gives counts: the chain an operator runs, `gonio calibrate
dark` then `gonio calibrate reference`, offline, once, into a folder of the
test's own. A capture then names it with --calibrations ROOT (the newest
valid reference for its rig and detector). The C tests' twin is
tests/gonio_test_cal.h."""
import csv
import json
import os
import re
import shutil
import statistics
import subprocess

BIN = os.environ.get("GONIO_BIN", "build/bin")
TESTS_BIN = os.environ.get("GONIO_TESTS_BIN", os.path.join(os.path.dirname(BIN), "tests"))


def calibrate(root, scene="lab", plan="ds3", rig=None, repeats=2):
    """Calibrate scene's detector (on rig, None: the scene's) into root for
    plan's points; the reference's id."""
    gonio = os.path.join(BIN, "gonio")
    rig_opt = ["--rig", rig] if rig else []
    for what, extra in (("dark", []), ("reference", ["--plan", plan, "--repeats", str(repeats)])):
        r = subprocess.run([gonio, "calibrate", what, "--offline", "--scene", scene, *rig_opt,
                            "--out", root, *extra], capture_output=True, text=True, timeout=300)
        if r.returncode != 0:
            raise AssertionError("gonio calibrate %s: %s" % (what, r.stderr))
    return r.stdout.strip()


METERED = """name: metered
material: default
rig: default
detector: {kind: rgb, responsivity: 1.0e6, target_e: 30000}
seed: 1
effects:
  - {name: lamp_drift, sigma: 0.005, tau_s: 1800}
  - {name: stray_light, floor: 0.0005}
  - {name: dark, rate_e_per_s: 500}
  - {name: shot_noise}
  - {name: read_noise, sigma_e: 12}
  - {name: saturation, full_well_e: 100000}
  - {name: jitter, sigma_deg: 0.02}
  - {name: backlash, deg: 0.05, axes: [sample, arm]}
"""


def metered_scene(folder):
    """The other way to BRDF on a noisy scene, which no shipped realistic
    scene takes: lab's light, noise and mechanics read by the simulator's
    ideal meter, no ADC, so the detector reports BRDF and chooses each
    reading's integration before it reads. For tests of what such a
    detector does to estimates and ETAs. Its path."""
    path = os.path.join(folder, "metered.yaml")
    with open(path, "w") as f:
        f.write(METERED)
    return path


# The DS1 captures' limits on the median |measured/true - 1| (chain_errors'
# "chain"), by kind of sample. The glossy plastic's values with SNR >= 100
# read at the rig's 0.25 s, its red peak at 25-33 % of full scale, at a
# median SNR of 146, where its own counting noise alone makes a median of
# 0.470 %; the calibrations' noise adds 0.013, and the scene's seed moves it
# by 0.02 (sd): 0.468-0.519 % over five seeds, 0.50 % on lab's
# (docs/radiometry.md, scripts/glossy_ds1_budget.py).
DS1_LIMIT = {"diffuse": 0.005, "glossy": 0.0055, "metal": 0.005}

# With the stray light calibrated and subtracted (gonio calibrate stray),
# the limit holds against the material alone, for every kind of sample.
DS1_STRAY_LIMIT = 0.005


def frames(path):
    """A calibration's frames.csv or a capture's samples.csv: its rows."""
    with open(path) as f:
        return list(csv.DictReader(f))


def stray_floor(scene="lab"):
    """The scene's stray light floor in 1/sr (0: none): an additive BRDF in
    every channel that no dark frame sees, in the sample's reading and the
    standard's alike (configs/scenes/NAME.yaml, docs/scenes.md)."""
    path = scene if scene.endswith(".yaml") else os.path.join(
        os.environ.get("GONIO_CONFIG", "configs"), "scenes", scene + ".yaml")
    with open(path) as f:
        m = re.search(r"name:\s*stray_light,\s*floor:\s*([0-9.eE+-]+)", f.read())
    return float(m.group(1)) if m else 0.0


def material_values(material, rows):
    """material's BRDF (r, g, b) at each row's recorded theta_i, theta_r, by
    brdf/material.h alone (tests/daemon/material_values.c)."""
    pairs = "".join("%s %s\n" % (x["theta_i"], x["theta_r"]) for x in rows)
    out = subprocess.run([os.path.join(TESTS_BIN, "material_values"), material], input=pairs,
                         capture_output=True, text=True, check=True).stdout
    return [[float(v) for v in line.split()] for line in out.splitlines()]


def chain_errors(rows, dark_rows, material, scene="lab", standard="standard:spectralon-99",
                 gain_adu_per_e=0.8):
    """How well a calibrated capture's rows recover material: the values
    with SNR >= 100 (the signal, counts over the dark of their integration,
    against its shot noise at the scene's ADC gain and the dark frames'
    spread), each against the truth at the rig's recorded angles. Two
    truths: the material's BRDF f alone, and what the chain measures when
    the scene adds a stray light floor s the dark does not see, to the
    sample's reading and the standard's (f_ref) alike:
    (f + s) f_ref / (f_ref + s). The chain does not remove stray light
    (docs/radiometry.md); the second truth holds the chain to what it does.
    A dict: n, and median |measured/true - 1| against each (material,
    chain)."""
    rows = [x for x in rows if not int(x["flags"]) & 2]
    truth, ref, s = material_values(material, rows), material_values(standard, rows), \
        stray_floor(scene)
    darks = {}
    for d in dark_rows:
        darks.setdefault(float(d["integration_s"]), []).append(float(d["g"]))
    e_mat, e_chain = [], []
    for k, x in enumerate(rows):
        t = float(x["integration_s"])
        dark_g = [v for ti, g in darks.items() if abs(ti - t) < 1e-6 * t for v in g]
        if len(dark_g) < 2:
            raise AssertionError("no dark frames at %g s" % t)
        for ch, name in enumerate("rgb"):
            signal = float(x["raw_" + name]) - statistics.mean(dark_g)
            noise = (gain_adu_per_e * max(signal, 0) + statistics.pstdev(dark_g) ** 2) ** 0.5
            if signal < 100 * noise:
                continue
            f, f_ref, got = truth[k][ch], ref[k][ch], float(x[name])
            e_mat.append(abs(got / f - 1))
            e_chain.append(abs(got / ((f + s) * f_ref / (f_ref + s)) - 1))
    if not e_mat:
        return {"n": 0, "material": float("nan"), "chain": float("nan")}
    return {"n": len(e_mat), "material": statistics.median(e_mat),
            "chain": statistics.median(e_chain)}


def without_a_step(root, ref_id, out_root):
    """Two calibrations that each leave a step of the chain out, from
    reference ref_id in root, under out_root: "nodark", its dark frames
    read as zero counts (nothing subtracted), and "lambertian", its standard
    without the angular shape (rho / pi: the certificate's reflectance and
    u, as docs/radiometry.md warns against). Their id (ref_id) serves
    gonio recalibrate --calibrations out_root/KIND; the stray light the
    reference names comes along. The two roots."""
    with open(os.path.join(root, ref_id, "calibration.json")) as f:
        ref_meta = json.load(f)
    dark_id = ref_meta["dark"]
    roots = {}
    for kind in ("nodark", "lambertian"):
        dest = os.path.join(out_root, kind)
        for cid in (dark_id, ref_id) + ((ref_meta["stray"],) if "stray" in ref_meta else ()):
            shutil.copytree(os.path.join(root, cid), os.path.join(dest, cid))
        roots[kind] = dest
    path = os.path.join(roots["nodark"], dark_id, "frames.csv")
    rows = frames(path)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        for x in rows:
            w.writerow(dict(x, r="0", g="0", b="0"))
    with open(os.path.join(os.environ.get("GONIO_CONFIG", "configs"), "standards",
                           "spectralon-99.yaml")) as f:
        text = f.read()
    flat = os.path.join(roots["lambertian"], "spectralon-99-lambertian.yaml")
    with open(flat, "w") as f:
        f.write(text[:text.index("\nangular:")].replace("name: spectralon-99",
                                                           "name: spectralon-99-lambertian")
                + "\n")
    meta_path = os.path.join(roots["lambertian"], ref_id, "calibration.json")
    with open(meta_path) as f:
        meta = json.load(f)
    meta["standard"] = flat
    with open(meta_path, "w") as f:
        json.dump(meta, f)
    return roots


def without_stray(root, ref_id, out_root):
    """A copy of reference ref_id of root, with its dark and stray light,
    under out_root, whose reference names no stray light: the same
    calibration with the stray light not subtracted. The root."""
    with open(os.path.join(root, ref_id, "calibration.json")) as f:
        meta = json.load(f)
    for cid in (meta["dark"], meta["stray"], ref_id):
        shutil.copytree(os.path.join(root, cid), os.path.join(out_root, cid))
    del meta["stray"]
    with open(os.path.join(out_root, ref_id, "calibration.json"), "w") as f:
        json.dump(meta, f)
    return out_root


def recalibrated_chain_errors(capdir, ref_id, cal_root, dark_rows, material, out):
    """capdir reduced again (gonio recalibrate) with ref_id of cal_root into
    out: its chain_errors."""
    r = subprocess.run([os.path.join(BIN, "gonio"), "recalibrate", capdir, "--calibration",
                        ref_id, "--calibrations", cal_root, "-o", out],
                       capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        raise AssertionError("gonio recalibrate %s: %s" % (capdir, r.stderr))
    return chain_errors(frames(os.path.join(out, "samples.csv")), dark_rows, material)


def recalibrated_material_error(capdir, ref_id, cal_root, dark_rows, material, out):
    """capdir reduced again with ref_id of cal_root into out: its
    chain_errors "material" median."""
    return recalibrated_chain_errors(capdir, ref_id, cal_root, dark_rows, material,
                                     out)["material"]


def recalibrated_errors(capdir, ref_id, roots, dark_rows, material, out_root, truth="chain"):
    """capdir reduced again (gonio recalibrate) with each calibration of
    without_a_step's roots: its chain_errors median against truth ("chain",
    or "material" for a reference that subtracts the stray light) by
    kind."""
    got = {}
    for kind, cal_root in roots.items():
        out = os.path.join(out_root, "%s-%s" % (os.path.basename(capdir), kind))
        got[kind] = recalibrated_chain_errors(capdir, ref_id, cal_root, dark_rows, material,
                                              out)[truth]
    return got
