"""An anisotropic material captured through goniod over Modbus: gonio-sim
serves the rotating rig (configs/rigs/rotating.yaml), whose rotation axis
turns the sample about its normal as the drive at slave 5
(docs/protocol-modbus.md), and reads its material turned by that drive's
position. goniod (driver.slaves.rotation: 5) captures an in-plane plan at
three sample azimuths (`sample_azimuths`, docs/plans.md) and fits aniso-ggx.

Held: every pair is measured at each planned turn once, and the turn the
journal records (phi_i = 360 - the rotation encoder's turn) is the plan's
within the rig profile's in-position band; gonio-sim's rotation drive went
to each turn; the fitted roughnesses and orientation are the material's,
and its full-domain error against the material is that of an exact fit on
ideal, within 1.25x the same model fitted to an out-of-plane reference
capture (in-process) on lab, calibrated through goniod; on ideal the
isotropy check, which turns the sample on the same drive, finds the
material anisotropic. goniod
refuses a rotating rig profile on a driver without the rotation drive, and
a plan that turns the sample on a rig profile without a rotation axis.

gonio-sim runs on its simulated clock: rig time is what it models,
whatever the host spends. Under make check-valgrind the ideal case runs over
TCP only and the lab case not (docs/testing-memory.md)."""
import json
import os
import shutil
import struct
import subprocess
import sys
import time

import pytest

import test_matrix as tm
import goniod_harness as tg

# roughness ratio 3, the lobe's tangent 35 deg off the plane of incidence
AX, AY, PHI = 0.06, 0.18, 35.0
MATERIAL = "analytic:aniso-ggx?ax=%g&ay=%g&phi=%g" % (AX, AY, PHI)
STANDARD = "standard:spectralon-99"  # lab's reference calibration reads it
TURNS = [0, 60, 130]  # not symmetric about any one of them
PAIRS = 52            # DS3's grid
PLAN = ("name: ds3-turned\n"
        "grid: {theta_i_step: 30, diffuse_step: 20, glossy_step: 3}\n"
        "sample_azimuths: [%s]\n" % ", ".join(str(t) for t in TURNS))
IN_POSITION_DEG = 0.1  # configs/rigs/rotating.yaml mechanics.in_position_deg
# The out-of-plane reference of the lab case: oop200k's first 5000 nodes
# (scripts/aniso_table.sh's oop5k).
REF_NODES = 5000


def daemon(folder, sim, transport):
    """goniod on gonio-sim with the rotating rig profile and its rotation
    drive (as configs/goniod/modbus-tcp-rotating.yaml), started."""
    text = sim.driver(transport)
    assert "azimuth: 4}" in text
    d = tg.Daemon(folder, driver=text.replace("azimuth: 4}", "azimuth: 4, rotation: 5}"))
    with open(d.config) as f:
        text = f.read()
    with open(d.config, "w") as f:
        f.write(text.replace("rig: default\n", "rig: rotating\n"))
    return d.start()


def model_params(path):
    """A model file's data block (docs/models.md, "Model file format")."""
    with open(path, "rb") as f:
        b = f.read()
    i = b.index(b"\ndata ") + 1
    j = b.index(b"\n", i)
    n = int(b[i:j].split()[1])
    return struct.unpack("<%dd" % n, b[j + 1:j + 1 + 8 * n])


def recorded_turn(phi_i):
    """The turn a journal row records (docs/formats.md: phi_i = 360 - turn),
    in (-180, 180]."""
    t = (360.0 - phi_i) % 360.0
    return t - 360.0 if t > 180.0 else t


def offline_calibration(folder, scene):
    """scene's in-process detector on the rotating rig, calibrated as
    scripts/lab_calibration.sh does (a dark at every rung of the ranging
    ladder, the reference on configs/plans/reference-grid.yaml) into a
    root of its own: for the in-process reference capture. Its root."""
    root = os.path.join(folder, "offline-calibrations")
    for what, extra in (("dark", ["--ladder"]), ("reference", ["--plan", "reference-grid"])):
        r = subprocess.run([os.path.join(tg.BIN, "gonio"), "calibrate", what, "--offline",
                            "--scene", scene, "--rig", "rotating", "--out", root] + extra,
                           capture_output=True, text=True, timeout=20 * tg.START_S)
        assert r.returncode == 0, r.stderr
    return root


def goniod_calibration(d):
    """The Modbus detector calibrated through goniod (docs/radiometry.md):
    a dark over the ranging ladder, then the reference on DS3's geometries
    (the turned plan's) with the standard mounted at goniod's pause, which
    gonio-sim measures from its start (STANDARD)."""
    env = dict(d.env, GONIO_SOCKET=d.sock)
    r = subprocess.run([tg.GONIO, "calibrate", "dark", "--ladder"], capture_output=True,
                       text=True, env=env, timeout=20 * tg.START_S)
    assert r.returncode == 0, r.stderr
    p = subprocess.Popen([tg.GONIO, "calibrate", "reference", "--plan", "ds3", "--repeats", "2"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                         preexec_fn=tg.child_procs.die_with_parent)
    c = d.connect()
    deadline = time.time() + 4 * tg.START_S
    while c.request("status")["state"] != "paused":  # "mount the standard"
        assert time.time() < deadline and p.poll() is None, "goniod never asked for the standard"
        time.sleep(0.05)
    assert d.gonio("resume").returncode == 0
    out, err = p.communicate(timeout=20 * tg.START_S)
    assert p.returncode == 0, err


def reference(folder, scene, root):
    """The full-domain log error of aniso-ggx fitted to REF_NODES
    out-of-plane pairs of oop200k's draw, captured in-process on scene."""
    with open(os.path.join(tg.SOURCE, "configs", "plans", "oop200k.yaml")) as f:
        text = f.read()
    assert "\n  n: 200000\n" in text
    plan = os.path.join(folder, "oop-ref.yaml")
    with open(plan, "w") as f:
        f.write(text.replace("name: oop200k", "name: oop-ref")
                .replace("\n  n: 200000\n", "\n  n: %d\n" % REF_NODES))
    out = os.path.join(folder, "ref")
    r = subprocess.run([os.path.join(tg.BIN, "gonio"), "capture", "--offline", "--quiet",
                        "--scene", scene, "--rig", "rotating", "--plan", plan, "--material",
                        MATERIAL, "--model", "aniso-ggx", "--calibration", "newest",
                        "--calibrations", root, "--out", out],
                       capture_output=True, text=True, timeout=40 * tg.START_S)
    assert r.returncode == 0, r.stderr
    return tm.results(out)["errors"]["full"]["log"]


def capture(folder, scene, transport, calibrated=False, **extra):
    """goniod over Modbus captures the turned plan of MATERIAL on scene:
    (stop document, capture dir, gonio-sim's stats). calibrated: the
    detector gives counts; goniod calibrates it first, on the standard."""
    sim = tm.Sim(folder, scene, scale=None,
                 extra=["--rig", "rotating", "--material", STANDARD if calibrated else MATERIAL])
    d = None
    try:
        d = daemon(folder, sim, transport)
        request = {}
        if calibrated:
            goniod_calibration(d)
            request["calibration"] = "newest"
            # the operator mounts the sample: gonio-sim measures it from now on
            d.stop()
            sim.stop()
            sim = tm.Sim(folder, scene, scale=None,
                         extra=["--rig", "rotating", "--material", MATERIAL])
            d = daemon(folder, sim, transport)
        c = d.connect()
        c.request("watch")
        reply = c.request("capture", plan="ds3-turned.yaml", plan_text=PLAN, name="az",
                          rig="rotating", material=MATERIAL, truth=MATERIAL, model="aniso-ggx",
                          **request, **extra)
        assert reply["class"] == "OK", reply
        stop = c.until_stop("az")[-1]
    finally:
        if d:
            d.stop()
        stats = sim.stop()
    tg.assert_valgrind_clean(folder)
    return stop, os.path.join(d.root, "az"), stats


def check_turns(capdir, stats):
    """Every pair at every turn once; each row's recorded turn the plan's
    within the band; gonio-sim's rotation drive driven to the turns."""
    points, rows = tm.read_rows(os.path.join(capdir, "samples.csv"))
    assert sorted(points) == list(range(len(TURNS) * PAIRS))
    with open(os.path.join(capdir, "plan.json")) as f:
        plan = json.load(f)["pairs"]
    worst = 0.0
    for p, r in rows.items():
        want = plan[p]["rotation"]
        got = recorded_turn(float(r["phi_i"]))
        worst = max(worst, abs(got - want))
        assert abs(got - want) <= IN_POSITION_DEG, (p, got, want)
    assert sorted({plan[p]["rotation"] for p in rows}) == TURNS
    rot = stats["axes"]["rotation"]
    assert rot["moves"] >= len(TURNS) - 1, rot
    assert rot["commanded"][0] <= TURNS[0] + IN_POSITION_DEG
    assert rot["positions"][1] >= TURNS[-1] - IN_POSITION_DEG, rot
    return worst


def fitted(capdir):
    """(ax, ay, phi_deg) of the capture's aniso-ggx fit."""
    v = model_params(os.path.join(capdir, "aniso-ggx.model"))
    return v[6], v[7], v[8]


def phi_off(a, b):
    """Orientation difference in degrees, a lobe being the same turned 180."""
    d = abs(a - b) % 180.0
    return min(d, 180.0 - d)


@pytest.mark.parametrize("transport", ["tcp", "rtu"] if not tg.VALGRIND else ["tcp"])
def test_ideal(transport):
    folder = tg.tmpdir()
    try:
        # the isotropy check turns the sample on the same drive after the last point
        stop, capdir, stats = capture(folder, "ideal", transport, check="isotropy")
        assert stop["exit_status"] == "success", stop
        iso = stop["checks"]["isotropy"]
        assert iso["verdict"] == "anisotropic", iso
        worst = check_turns(capdir, stats)
        res = tm.results(capdir)
        ax, ay, phi = fitted(capdir)
        sys.stderr.write("aniso over Modbus %s, ideal, %s: turns within %.3f deg; fitted ax "
                         "%.4f ay %.4f phi %.2f (material %g %g %g); full-domain log error %.2e; "
                         "rig time %.0f s; isotropy check %s, significance %.1f against %.1f\n"
                         % (transport.upper(), MATERIAL, worst, ax, ay, phi, AX, AY, PHI,
                            res["errors"]["full"]["log"], res["rig_time_s"], iso["verdict"],
                            iso["significance"], iso["threshold"]))
        assert res["model"] == "aniso-ggx"
        assert abs(ax / AX - 1) < 0.01 and abs(ay / AY - 1) < 0.01, (ax, ay)
        assert phi_off(phi, PHI) < 0.5, phi
        assert res["errors"]["full"]["log"] < 1e-3
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def lab():
    """lab (noise, drift, stray light, backlash, counts), calibrated: the
    fit is the material's to within what lab's noise leaves, and its
    full-domain error within 1.25x the out-of-plane reference's, floored
    at 0.001 where both are below what the chain resolves
    (scripts/aniso_table.sh's rule, docs/checks.md)."""
    folder = tg.tmpdir()
    try:
        stop, capdir, stats = capture(folder, "lab", "tcp", calibrated=True)
        assert stop["exit_status"] == "success", stop
        worst = check_turns(capdir, stats)
        res = tm.results(capdir)
        ax, ay, phi = fitted(capdir)
        ref = reference(folder, "lab", offline_calibration(folder, "lab"))
        full = res["errors"]["full"]["log"]
        sys.stderr.write("aniso over Modbus TCP, lab, %s: turns within %.3f deg; fitted ax "
                         "%.4f ay %.4f phi %.2f; full-domain log error %.5f, out-of-plane "
                         "reference (%d nodes) %.5f; rig time %.0f s\n" % (
                             MATERIAL, worst, ax, ay, phi, full, REF_NODES, ref,
                             res["rig_time_s"]))
        assert abs(ax / AX - 1) < 0.05 and abs(ay / AY - 1) < 0.05, (ax, ay)
        assert phi_off(phi, PHI) < 2, phi
        assert full <= 1.25 * max(ref, 0.001), (full, ref)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


# Under memcheck (make check-valgrind) lab's calibration through goniod and
# its capture take minutes; the ideal capture over TCP takes the same code
# there (docs/testing-memory.md). A skip would make the whole rig_python run
# read as skipped, so the case is left out instead, as test_matrix.py's are.
if not tg.VALGRIND:
    test_lab = lab


def test_refusals():
    """A rotating rig profile on a driver without the rotation drive: goniod
    --check, and a capture request naming it, refused naming the field; a
    plan that turns the sample on a rig profile without a rotation axis,
    refused naming the plan's key. Nothing is created."""
    folder = tg.tmpdir()
    sim = tm.Sim(folder, "ideal", scale=None, extra=["--rig", "rotating"])
    d = None
    try:
        d = tg.Daemon(folder, driver=sim.driver("tcp"))  # slaves without rotation
        with open(d.config) as f:
            text = f.read()
        bad = os.path.join(folder, "rotating-no-drive.yaml")
        with open(bad, "w") as f:
            f.write(text.replace("rig: default\n", "rig: rotating\n"))
        r = tg.run_wrapped([tg.GONIOD, "--config", bad, "--check"], folder)
        assert r.returncode == 2, r.stdout + r.stderr
        assert "driver.slaves.rotation is 0 (none), but rig profile 'rotating'" in r.stderr
        d.start()
        c = d.connect()
        r = c.request("capture", plan="ds3", name="x", rig="rotating")
        assert r["code"] == "bad-value", r
        assert "driver.slaves.rotation is 0" in r["message"], r
        r = c.request("capture", plan="ds3-turned.yaml", plan_text=PLAN, name="x",
                      material=MATERIAL)
        assert r["code"] == "bad-value", r
        assert "sample_azimuths" in r["message"] and "rig 'default'" in r["message"], r
        assert not os.path.exists(os.path.join(d.root, "x"))
    finally:
        if d and d.proc:
            d.stop()
        sim.stop()
        tg.assert_valgrind_clean(folder)
        shutil.rmtree(folder, ignore_errors=True)
