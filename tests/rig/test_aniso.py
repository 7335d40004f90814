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
capture (in-process) on lab, calibrated (tests/gonio_cal.py). goniod
refuses a rotating rig profile on a driver without the rotation drive, and
a plan that turns the sample on a rig profile without a rotation axis.

gonio-sim runs on its simulated clock: rig time is what it models,
whatever the host spends."""
import json
import os
import shutil
import struct
import subprocess
import sys

import pytest

import test_matrix as tm
import goniod_harness as tg
import gonio_cal

# roughness ratio 3, the lobe's tangent 35 deg off the plane of incidence
AX, AY, PHI = 0.06, 0.18, 35.0
MATERIAL = "analytic:aniso-ggx?ax=%g&ay=%g&phi=%g" % (AX, AY, PHI)
TURNS = [0, 60, 130]  # not symmetric about any one of them
PAIRS = 52            # DS3's grid
PLAN = ("name: ds3-turned\n"
        "grid: {theta_i_step: 30, diffuse_step: 20, glossy_step: 3}\n"
        "sample_azimuths: [%s]\n" % ", ".join(str(t) for t in TURNS))
IN_POSITION_DEG = 0.1  # configs/rigs/rotating.yaml mechanics.in_position_deg
# The out-of-plane reference of the lab case: oop200k's first 5000 nodes
# (scripts/aniso_table.sh's oop5k).
REF_NODES = 5000


def driver(sim, transport):
    """goniod's driver block for gonio-sim, with its rotation drive."""
    text = sim.driver(transport)
    assert "azimuth: 4}" in text
    return text.replace("azimuth: 4}", "azimuth: 4, rotation: 5}")


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


def capture(folder, scene, transport, calibrate=False):
    """goniod over Modbus captures the turned plan of MATERIAL on scene:
    (stop document, capture dir, gonio-sim's stats)."""
    sim = tm.Sim(folder, scene, scale=None, extra=["--rig", "rotating", "--material", MATERIAL])
    d = None
    try:
        plan_path = os.path.join(folder, "ds3-turned.yaml")
        with open(plan_path, "w") as f:
            f.write(PLAN)
        request = {}
        if calibrate:  # into goniod's calibration root, beside its capture root
            gonio_cal.calibrate(os.path.join(folder, "calibrations"), scene, plan_path,
                                rig="rotating")
            request["calibration"] = "newest"
        d = tg.Daemon(folder, driver=driver(sim, transport)).start()
        c = d.connect()
        c.request("watch")
        reply = c.request("capture", plan="ds3-turned.yaml", plan_text=PLAN, name="az",
                          rig="rotating", material=MATERIAL, truth=MATERIAL, model="aniso-ggx",
                          **request)
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
        stop, capdir, stats = capture(folder, "ideal", transport)
        assert stop["exit_status"] == "success", stop
        worst = check_turns(capdir, stats)
        res = tm.results(capdir)
        ax, ay, phi = fitted(capdir)
        sys.stderr.write("aniso over Modbus %s, ideal, %s: turns within %.3f deg; fitted ax "
                         "%.4f ay %.4f phi %.2f (material %g %g %g); full-domain log error %.2e; "
                         "rig time %.0f s\n" % (transport.upper(), MATERIAL, worst, ax, ay, phi,
                                                AX, AY, PHI, res["errors"]["full"]["log"],
                                                res["rig_time_s"]))
        assert res["model"] == "aniso-ggx"
        assert abs(ax / AX - 1) < 0.01 and abs(ay / AY - 1) < 0.01, (ax, ay)
        assert phi_off(phi, PHI) < 0.5, phi
        assert res["errors"]["full"]["log"] < 1e-3
    finally:
        shutil.rmtree(folder, ignore_errors=True)
