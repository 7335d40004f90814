#!/usr/bin/env python3
"""Where a DS1 capture's median |measured/true - 1| comes from, on the raw
lab rig: the chain of tests/cli/test_calibrate_ds1.py (dark over the
ladder, stray light and reference on the 5-degree grid, then a DS1
capture, ranged) run over scene seeds, each step also run on a quiet copy
of the scene (no shot or read noise: its readings are their means), so
that each shared step's noise can be left out in turn, and the capture
itself read quietly to leave the systematic part alone.

Every variant is scored on the same values: those the full chain's
capture keeps with SNR >= 100 (tests/gonio_cal.py chain_errors), against
the material alone at the angles the rig recorded. The counting floor is
the median of |N(0, sigma_i)| over those values, sigma_i each value's own
shot and read noise (its counts at the scene's 0.8 ADU per electron and
the dark frames' spread), drawn 200 times.

Usage (from the repository root, after a build):
  python3 scripts/glossy_ds1_budget.py [--material SPEC] [--seeds 1,2,3]
      [--repeats 8] [--dark-frames 16] [--tmp DIR]
Prints a table in markdown; takes about 2.5 minutes a seed (--quick: the
chain alone, half a minute). --capture-scale K reads the capture on the
rig integrating K x 0.25 s (the reference still at 0.25 s, scaled by the
monitor's counts, its calibration.json marked as covering the capture's
integration). Figures: docs/radiometry.md, docs/notes/glossy-ds1.md."""
import argparse
import json
import os
import random
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests"))
os.environ.setdefault("GONIO_CONFIG", os.path.join(ROOT, "configs"))
os.environ.setdefault("GONIO_BIN", os.path.join(ROOT, "build", "bin"))
import gonio_cal  # noqa: E402

GONIO = os.path.join(os.environ["GONIO_BIN"], "gonio")
GAIN = 0.8


def run(*args):
    r = subprocess.run([GONIO, *args], capture_output=True, text=True, timeout=900)
    if r.returncode != 0:
        raise SystemExit("gonio %s: %s" % (" ".join(args), r.stderr))
    return r.stdout.strip()


def scenes(folder, seed):
    """lab with seed, and its quiet copy: their paths."""
    with open(os.path.join(os.environ["GONIO_CONFIG"], "scenes", "lab.yaml")) as f:
        text = re.sub(r"(?m)^seed: .*$", "seed: %d" % seed, f.read())
    quiet = "\n".join(x for x in text.splitlines()
                      if "shot_noise" not in x and "read_noise" not in x) + "\n"
    paths = {}
    for kind, body in (("noisy", text), ("quiet", quiet)):
        paths[kind] = os.path.join(folder, "lab-%s-%d.yaml" % (kind, seed))
        with open(paths[kind], "w") as f:
            f.write(body)
    return paths


def rig(folder, fixed_s=0.25):
    """The default rig integrating fixed_s (the tests' 0.25 s)."""
    with open(os.path.join(os.environ["GONIO_CONFIG"], "rigs", "default.yaml")) as f:
        text = f.read().replace("fixed_s: 0.05", "fixed_s: %g" % fixed_s)
    path = os.path.join(folder, "lab-rig-%g.yaml" % fixed_s)
    with open(path, "w") as f:
        f.write(text)
    return path


def calibrations(folder, scene, rig_file, args, plan="reference-grid", capture_rig=None):
    """dark, stray and reference of each of scene's kinds (noisy, quiet),
    each in a root of its own: {kind: (root, dark, stray, ref)}. With
    capture_rig (a rig integrating longer than rig_file), the dark covers
    its ladder too, and the stray light and the reference, read at
    rig_file's integration and scaled by the monitor's counts as every
    rung of the ladder is, are marked as covering its integration."""
    got = {}
    for kind, path in scene.items():
        root = os.path.join(folder, "cal-" + kind + "-" + plan)
        common = ["--offline", "--scene", path, "--out", root]
        if capture_rig:
            dark = run("calibrate", "dark", *common, "--rig", capture_rig, "--ladder",
                       "--integration", "0.25", "--frames", str(args.dark_frames))
        else:
            dark = run("calibrate", "dark", *common, "--rig", rig_file, "--ladder", "--frames",
                       str(args.dark_frames))
        grid = ["--rig", rig_file, "--plan", plan, "--repeats", str(args.repeats), "--dark",
                dark]
        stray = run("calibrate", "stray", *common, *grid)
        ref = run("calibrate", "reference", *common, *grid, "--stray", stray)
        for cid in (stray, ref) if capture_rig else ():
            meta = os.path.join(root, cid, "calibration.json")
            with open(meta) as f:
                m = json.load(f)
            m["integrations_s"] = sorted(set(m["integrations_s"] + [0.25 * args.capture_scale]))
            with open(meta, "w") as f:
                json.dump(m, f)
        got[kind] = (root, dark, stray, ref)
    return got


def mixed(folder, cals, dark_kind, stray_kind, ref_kind, name):
    """A root whose reference is ref_kind's frames with dark_kind's dark
    and stray_kind's stray light (their ids as the reference names them)."""
    dest = os.path.join(folder, name)
    if os.path.isdir(dest):
        shutil.rmtree(dest)
    _, dark, stray, ref = cals[ref_kind]
    for kind, cid, i in ((dark_kind, dark, 1), (stray_kind, stray, 2), (ref_kind, ref, 3)):
        src = os.path.join(cals[kind][0], cals[kind][i])
        shutil.copytree(src, os.path.join(dest, cid))
        if cals[kind][i] != cid:  # the other kind's id: rename its frames to this one's
            meta = os.path.join(dest, cid, "calibration.json")
            with open(meta) as f:
                m = json.load(f)
            m["id"] = cid
            for key in ("dark",):
                if key in m:
                    m[key] = dark
            with open(meta, "w") as f:
                json.dump(m, f)
    return dest, ref


def errors(rows, material):
    """{(point, channel): measured/true - 1} of a capture's kept rows."""
    rows = [x for x in rows if not int(x["flags"]) & 2]
    truth = gonio_cal.material_values(material, rows)
    out = {}
    for k, x in enumerate(rows):
        for ch, name in enumerate("rgb"):
            if x[name] != "":
                out[(x["point"], ch)] = float(x[name]) / truth[k][ch] - 1
    return out


def selected(rows, dark_rows):
    """{(point, channel): sigma} of the values chain_errors keeps (SNR >= 100),
    sigma the value's own counting noise, relative."""
    darks = {}
    for d in dark_rows:
        darks.setdefault(float(d["integration_s"]), []).append(float(d["g"]))
    out = {}
    for x in rows:
        if int(x["flags"]) & 2:
            continue
        t = float(x["integration_s"])
        g = [v for ti, vs in darks.items() if abs(ti - t) < 1e-6 * t for v in vs]
        for ch, name in enumerate("rgb"):
            signal = float(x["raw_" + name]) - statistics.mean(g)
            noise = (GAIN * max(signal, 0) + statistics.pstdev(g) ** 2) ** 0.5
            if signal >= 100 * noise:
                out[(x["point"], ch)] = noise / signal
    return out


def reported_snr(capdir, rows, material):
    """(n, median |measured/true - 1|) over the values whose reported value
    over u is at most 1/100, u first whole (systematic terms included),
    then its per-sample part: u less the systematic terms of results.json's
    budget, which are the same relative u for every sample of a channel."""
    with open(os.path.join(capdir, "results.json")) as f:
        budget = json.load(f)["calibration"]["budget"]
    sys_u2 = [sum(t["median_relative_u"][c] ** 2 for t in budget if t["kind"] == "systematic")
              for c in range(3)]
    rows = [x for x in rows if not int(x["flags"]) & 2]
    truth = gonio_cal.material_values(material, rows)
    got = {}
    for whole in (True, False):
        e = []
        for k, x in enumerate(rows):
            for c, name in enumerate("rgb"):
                if x[name] == "":
                    continue
                v, u = float(x[name]), float(x["u_" + name])
                if not whole:
                    u = max(u * u - sys_u2[c] * v * v, 0) ** 0.5
                if v >= 100 * u:
                    e.append(abs(v / truth[k][c] - 1))
        got["whole" if whole else "per sample"] = (len(e), statistics.median(e) if e else
                                                   float("nan"))
    return got


def capture(folder, name, scene, rig_file, cal_root, material):
    out = os.path.join(folder, name)
    run("capture", "--offline", "--scene", scene, "--rig", rig_file, "--material", material,
        "--plan", "ds1", "--out", out, "--calibrations", cal_root, "--quiet")
    rows = gonio_cal.frames(os.path.join(out, "samples.csv"))
    with open(os.path.join(out, "results.json")) as f:
        rig_time = json.load(f).get("rig_time_s", float("nan"))
    return rows, rig_time


def recal(folder, name, capdir, cal_root, ref):
    out = os.path.join(folder, name)
    run("recalibrate", capdir, "--calibration", ref, "--calibrations", cal_root, "-o", out)
    return gonio_cal.frames(os.path.join(out, "samples.csv"))


def med(errs, keys):
    return statistics.median(abs(errs[k]) for k in keys if k in errs)


def one_seed(folder, seed, args):
    scene = scenes(folder, seed)
    if args.quick:
        del scene["quiet"]
    rig_file = rig(folder)
    cap_rig = rig(folder, 0.25 * args.capture_scale) if args.capture_scale != 1 else None
    cals = calibrations(folder, scene, rig_file, args, capture_rig=cap_rig)
    noisy_root, dark = cals["noisy"][:2]
    dark_rows = gonio_cal.frames(os.path.join(noisy_root, dark, "frames.csv"))
    rows, rig_time = capture(folder, "cap", scene["noisy"], cap_rig or rig_file, noisy_root,
                             args.material)
    sel = selected(rows, dark_rows)
    keys = sorted(sel)
    capdir = os.path.join(folder, "cap")
    res = {"n": len(keys), "rig_time": rig_time}
    res["chain"] = med(errors(rows, args.material), keys)
    res["reported"] = reported_snr(capdir, rows, args.material)
    # The counting floor: each value's own noise alone.
    rnd = random.Random(seed)
    sig = [sel[k] for k in keys]
    res["floor"] = statistics.mean(statistics.median(abs(rnd.gauss(0, s)) for s in sig)
                                   for _ in range(200))
    res["snr_median"] = statistics.median(1 / s for s in sig)
    if args.quick:
        return res
    # Each shared step quiet in turn, the capture's own readings as taken.
    for label, kinds in (("dark quiet", ("quiet", "noisy", "noisy")),
                         ("stray quiet", ("noisy", "quiet", "noisy")),
                         ("reference quiet", ("noisy", "noisy", "quiet")),
                         ("calibration quiet", ("quiet", "quiet", "quiet"))):
        root, rid = mixed(folder, cals, *kinds, name="mix-" + label.replace(" ", "-"))
        got = recal(folder, "re-" + label.replace(" ", "-"), capdir, root, rid)
        res[label] = med(errors(got, args.material), keys)
    # Everything quiet: what is left is systematic (interpolation,
    # nonlinearity, angles, drift), scored on the same values.
    qroot = cals["quiet"][0]
    qrows, _ = capture(folder, "cap-quiet", scene["quiet"], rig_file, qroot, args.material)
    qerr = errors(qrows, args.material)
    res["all quiet"] = med(qerr, keys)
    res["all quiet mean"] = statistics.mean(qerr[k] for k in keys if k in qerr)
    # ... with the reference read at DS1's own points (no interpolation).
    dcals = calibrations(folder, {"quiet": scene["quiet"]}, rig_file, args, plan="ds1")
    drows, _ = capture(folder, "cap-quiet-ds1ref", scene["quiet"], rig_file, dcals["quiet"][0],
                       args.material)
    res["all quiet, reference at DS1"] = med(errors(drows, args.material), keys)
    return res


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--material", default="builtin:red-plastic")
    p.add_argument("--seeds", default="1,2,3")
    p.add_argument("--repeats", type=int, default=8)
    p.add_argument("--dark-frames", type=int, default=16)
    p.add_argument("--quick", action="store_true",
                   help="the chain alone, no quiet variants")
    p.add_argument("--capture-scale", type=float, default=1.0,
                   help="the capture's rig integrating this many times 0.25 s")
    p.add_argument("--tmp")
    args = p.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    per = []
    with tempfile.TemporaryDirectory(prefix="glossy_ds1_", dir=args.tmp) as tmp:
        for seed in seeds:
            folder = os.path.join(tmp, str(seed))
            os.makedirs(folder)
            per.append(one_seed(folder, seed, args))
            sys.stderr.write("seed %d: %s\n" % (seed, per[-1]))
    cols = ["chain", "floor"] + ([] if args.quick else [
        "dark quiet", "stray quiet", "reference quiet", "calibration quiet", "all quiet",
        "all quiet, reference at DS1"])
    print("%s on DS1 (lab, %d reference and stray repeats, %d dark frames, the capture "
          "integrating %g s), median |measured/true - 1| over the values with SNR >= 100, by "
          "seed:" % (args.material, args.repeats, args.dark_frames, 0.25 * args.capture_scale))
    print()
    print("| seed | values | median SNR | rig time | " + " | ".join(cols)
          + " | value/u >= 100 | value/u per sample >= 100 |")
    print("|---" * (len(cols) + 6) + "|")
    for seed, r in zip(seeds, per):
        print("| %d | %d | %.0f | %.0f s | " % (seed, r["n"], r["snr_median"], r["rig_time"])
              + " | ".join("%.3f %%" % (100 * r[c]) for c in cols)
              + "".join(" | %.3f %% (%d)" % (100 * r["reported"][w][1], r["reported"][w][0])
                        for w in ("whole", "per sample")) + " |")
    print("| mean | | | | " + " | ".join("%.3f %%" % (100 * statistics.mean(r[c] for r in per))
                                         for c in cols)
          + "".join(" | %.3f %%" % (100 * statistics.mean(r["reported"][w][1] for r in per))
                    for w in ("whole", "per sample")) + " |")


if __name__ == "__main__":
    main()
