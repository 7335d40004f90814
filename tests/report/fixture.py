"""A small study directory for the report tests, made by hand.

results.json follows docs/study.md (format gonio-study-1). The numbers are
made up except where a test reads them back; the ds4/ideal job of the
embedded default material is a real capture with real fitted models (gonio
capture --offline, gonio fit), so the slices are drawn from real files. A
renders/ folder holds a real grid drawn by gonio render (docs/render.md).
"""
import json
import os
import subprocess

MATERIALS = [("default", "default"), ("other", "builtin:does-not-exist")]
SCENES = ["ideal", "lab"]
PLANS = ["ds1", "ds2", "ds3", "ds4", "inplane-full", "oop200k"]
MODELS = ["abc", "mlp", "latent"]
POINTS = {"ds1": 912, "ds2": 160, "ds3": 52, "ds4": 6, "inplane-full": 8710,
          "oop200k": 190038}
RIG_S = {"ds1": 950.0, "ds2": 196.0, "ds3": 70.0, "ds4": 12.5, "inplane-full": 9200.0,
         "oop200k": 262000.0}


def error(material, scene, plan, model, domain, metric):
    """A made-up but distinct error for every cell: the tests find them."""
    base = {"ds1": 0.02, "ds2": 0.025, "ds3": 0.04, "ds4": 0.09, "inplane-full": 0.018,
            "oop200k": 0.015}[plan]
    base *= {"abc": 1.0, "mlp": 0.8, "latent": 1.3}[model]
    base *= {"ideal": 1.0, "lab": 1.2}[scene]
    base *= {"default": 1.0, "other": 2.0}[material]
    base *= {"plan": 0.7, "inplane": 1.0, "full": 1.1}[domain]
    return round(base * (1.0 if metric == "log" else 3.0), 6)


def run(cmd, **kw):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, **kw)


def make_study(bin_dir, out):
    gonio = os.path.join(bin_dir, "gonio")
    job = os.path.join(out, "jobs", "default.ideal.ds4")
    run([gonio, "capture", "--offline", "--scene", "ideal", "--plan", "ds4", "--material",
         "default", "--out", job])
    for model in ("abc", "latent"):
        run([gonio, "fit", job, "--model", model, "--quiet", "-o",
             os.path.join(job, model + ".model")])
    rows = []
    for material, spec in MATERIALS:
        for scene in SCENES:
            for plan in PLANS:
                for model in MODELS:
                    row = {"row_id": ".".join((material, scene, plan, model)),
                           "material": material, "material_spec": spec, "scene": scene,
                           "plan": plan, "model": model, "status": "ok",
                           "samples": POINTS[plan], "plan_points": POINTS[plan],
                           "stop_reason": "complete", "rig_time_s": RIG_S[plan],
                           "move_s": 0.6 * RIG_S[plan], "settle_s": 0.3 * RIG_S[plan],
                           "integration_s": 0.1 * RIG_S[plan], "fit_wall_s": 0.5,
                           "fit_cpu_s": 0.4, "fit_converged": 1,
                           "model_file": "jobs/%s.%s.%s/%s.model" % (material, scene, plan,
                                                                     model),
                           "samples_file": "jobs/%s.%s.%s/samples.csv" % (material, scene,
                                                                          plan),
                           "note": "fixture"}
                    for domain in ("plan", "inplane", "full"):
                        for metric in ("log", "rel_rmse"):
                            row["%s_%s" % (domain, metric)] = error(material, scene, plan,
                                                                    model, domain, metric)
                        row[domain + "_n"] = 100
                    if model == "mlp":  # in-plane only: no full-domain error
                        row["full_log"] = row["full_rel_rmse"] = None
                        row["full_skipped"] = 889726
                    rows.append(row)
    study = {"format": "gonio-study-1", "quick": False,
             "materials": [{"name": m, "spec": s} for m, s in MATERIALS],
             "scenes": SCENES, "plans": PLANS, "models": MODELS, "shard": [1, 1],
             "jobs": len(MATERIALS) * len(SCENES) * len(PLANS)}
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump({"format": "gonio-study-1", "study": study, "complete": True,
                   "missing": [], "rows": rows}, f)
    # Renderings: gonio render's grid of the truth and the ds4 fits, small.
    renders = os.path.join(out, "renders", "default")
    run([gonio, "render", "--grid", "--truth", "default",
         "--model", "model:" + os.path.join(job, "abc.model"), "--label", "ds4/abc",
         "--model", "model:" + os.path.join(job, "latent.model"), "--label", "ds4/latent",
         "--size", "32", "--out", renders])
    return rows
