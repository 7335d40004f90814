"""A calibration for tests that capture on a realistic scene (lab, bad-day),
whose detector gives counts: the chain an operator runs, `gonio calibrate
dark` then `gonio calibrate reference`, offline, once, into a folder of the
test's own. A capture then names it with --calibrations ROOT (the newest
valid reference for its rig and detector). The C tests' twin is
tests/gonio_test_cal.h."""
import os
import subprocess

BIN = os.environ.get("GONIO_BIN", "build/bin")


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
