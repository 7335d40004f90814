"""An adaptive capture through goniod over Modbus TCP and RTU
against gonio-sim on a scene whose detector meters its integration (lab's
noise read by the simulator's ideal meter, tests/gonio_cal.py: the policy
needs BRDF, and lab's counts would need a calibration goniod can name):
the policy chooses from the
inplane-1deg pool within a small rig-time budget, while the rig settles and
integrates. gonio-sim runs on its simulated clock: the rig time is what it
models (moves, settles, integrations), never the host's, so the time the
engine spends deciding, which a loaded host or memcheck stretches 20-50x,
takes nothing from the budget, and the capture (its points and its rig
time) is the same on any host. It completes with the policy's stop, every journalled point
distinct and in the pool, the events carrying the policy's prediction, and
results.json its figures, and its rig time within the budget; the decision
time per point beside the rig's settle time is printed (a bench figure:
timing is not asserted). And goniod killed with SIGKILL in the middle of an
adaptive capture: the resumed capture keeps every sample the journal held,
goes on with the same policy, model and budget, and measures no point
twice."""
import json
import os
import shutil
import sys

import pytest

import test_matrix as tm
import goniod_harness as tg
import gonio_cal

BUDGET_MIN = 2
POOL = 12322  # inplane-1deg on the default rig
SCALE = None  # the simulated clock
# under valgrind one transport (the matrix's diagonal runs RTU's framing)
TRANSPORTS = ("tcp",) if tg.VALGRIND else ("tcp", "rtu")


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_adaptive_over_modbus(transport):
    folder = tg.tmpdir()
    sim = tm.Sim(folder, gonio_cal.metered_scene(folder), scale=SCALE)
    d = None
    try:
        d = tg.Daemon(folder, driver=sim.driver(transport)).start()
        c = d.connect()
        c.request("watch")
        reply = c.request("capture", plan="inplane-1deg", order="adaptive", stop="all",
                          budget=BUDGET_MIN, name="ad", truth=tm.TRUTH)
        assert reply["class"] == "OK", reply
        docs = c.until_stop("ad")
    finally:
        if d:
            d.stop()
        sim.stop()
    try:
        tg.assert_valgrind_clean(folder)
        stop = docs[-1]
        assert stop["exit_status"] == "success", stop
        assert stop["reason"] in ("budget", "converged", "target", "exhausted"), stop
        capdir = os.path.join(d.root, "ad")
        points, _ = tm.read_rows(os.path.join(capdir, "samples.csv"))
        assert len(points) == stop["samples"] >= 6
        assert len(set(points)) == len(points)
        assert all(0 <= p < POOL for p in points)
        events = [e for e in docs if e.get("class") == "event"]
        assert any("predicted_error" in e for e in events), events[-1]
        res = tm.results(capdir)
        ad = res["adaptive"]
        assert res["stop_reason"] == stop["reason"] == ad["stop"]
        assert ad["decisions"] == len(points)
        assert res["errors"]["full"]["log"] > 0  # the truth is known: checkable
        # The metering detector integrates longer where the material is dark than
        # the rig profile says, which goniod cannot know in advance: the
        # policy learns it from the journal and the budget still holds.
        assert res["rig_time_s"] <= 60 * BUDGET_MIN, res["rig_time_s"]
        with open(os.path.join(capdir, "setup.json")) as f:
            settle = json.load(f)["rig"]["settle_s"]
        sys.stderr.write(
            "adaptive over Modbus %s, metered, inplane-1deg pool, %.1f min budget: %d samples, "
            "rig time %.1f s, stop %s; decision %.4f s mean, %.4f s max per point (settle "
            "%.2f s), the rig waited %.3f s wall for them; predicted full-domain log error "
            "%.4f, true %.4f\n" % (
                transport.upper(), BUDGET_MIN, len(points), res["rig_time_s"], stop["reason"],
                ad["decision_mean_s"], ad["decision_max_s"], settle, ad["decision_wait_s"],
                ad["predicted_error"], res["errors"]["full"]["log"]))
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def test_kill9_during_adaptive_then_resume():
    folder = tg.tmpdir()
    sim = tm.Sim(folder, gonio_cal.metered_scene(folder), scale=SCALE)
    d = None
    cut_at = 8 if tg.VALGRIND else 12  # past the six seeds: the policy's own picks
    # The kill must land before the capture ends: a budget of about 100
    # points (the over-Modbus runs take 97 in 2 min), so that after the
    # cut the capture still has some 85 decisions to make (1-5 s of wall
    # time here) while the test reads the event and kills (milliseconds).
    budget_min = 2
    try:
        d = tg.Daemon(folder, driver=sim.driver("tcp")).start()
        c = d.connect()
        c.request("watch")
        reply = c.request("capture", plan="ds1", order="adaptive", model="abc",
                          budget=budget_min, name="cut", truth=tm.TRUTH)
        assert reply["class"] == "OK", reply
        docs = tm.kill9_and_resume(d, c, "cut", cut_at)
    finally:
        if d:
            d.stop()
        sim.stop()
    try:
        tg.assert_valgrind_clean(folder)
        assert docs[0]["class"] == "start", docs[0]
        kept = docs[0]["already_done"]  # what the journal held after the kill
        assert kept >= cut_at, kept  # every sample reported done was journalled
        stop = docs[-1]
        assert stop["exit_status"] == "success", stop
        capdir = os.path.join(d.root, "cut")
        points, _ = tm.read_rows(os.path.join(capdir, "samples.csv"))
        assert len(points) == stop["samples"] > kept  # the policy went on choosing
        assert len(set(points)) == len(points)  # no point measured twice
        assert all(0 <= p < 912 for p in points)  # all from DS1's pool
        res = tm.results(capdir)
        ad = res["adaptive"]
        assert res["stop_reason"] == stop["reason"] == ad["stop"]
        assert ad["model"] == "abc" and ad["budget_s"] == 60 * budget_min, ad  # the same policy
        assert ad["decisions"] == len(points) - kept  # this run's (docs/formats.md)
        assert res["rig_time_s"] <= 60 * budget_min, res["rig_time_s"]  # the budget spans the kill
        sys.stderr.write("adaptive capture killed at %d samples: resumed from %d, ended with %d "
                         "(%s) in %.1f s of rig time\n" % (cut_at, kept, len(points),
                                                           stop["reason"], res["rig_time_s"]))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
