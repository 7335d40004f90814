"""The estimate and the first ETA from the axes' present positions
(docs/plans.md, "Estimates on a real day"): a capture starts wherever the
last one, or a bring-up move, left the axes. goniod over Modbus TCP on
gonio-sim's simulated clock (rig time is what the simulator models, so the
figures hold under any load): the arm and the sample are moved far from
home with `move`, then DS2 and DS3 are captured on the ideal scene (fixed
integration, so the estimate is the capture's rig time but for the
simulator's bus time). The start document's estimate, and the ETA as the
first point ends (rig time so far plus ETA), are within TOLERANCE of the
rig time the capture took; counted from home they were off by the axes'
way back."""
import os
import shutil
import sys

import pytest

import test_matrix as tm
import goniod_harness as tg

TOLERANCE = 0.05  # the ETA's target
FAR = {"arm": -165, "sample": 85}  # within the default profile's limits


@pytest.mark.parametrize("plan", ["ds2", "ds3"])
def test_estimate_from_present_position(plan):
    folder = tg.tmpdir()
    sim = tm.Sim(folder, "ideal", scale=None)
    d = None
    try:
        d = tg.Daemon(folder, driver=sim.driver("tcp")).start()
        c = d.connect()
        for axis, deg in FAR.items():
            r = c.request("move", axis=axis, deg=deg)
            assert r["class"] == "OK", r
        c.request("watch")
        reply = c.request("capture", plan=plan, name="far")
        assert reply["class"] == "OK", reply
        docs = c.until_stop("far")
    finally:
        if d:
            d.stop()
        sim.stop()
    try:
        start = next(x for x in docs if x.get("class") == "start")
        assert docs[-1]["exit_status"] == "success", docs[-1]
        first = next(x for x in docs if x.get("class") == "event")
        actual = tm.results(os.path.join(d.root, "far"))["rig_time_s"]
        eta = first["rig_time_s"] + first["eta_s"]
        sys.stderr.write("%s from arm %g, sample %g: estimate %.1f s, first ETA %.1f s, "
                         "actual %.1f s (%+.1f %%)\n" % (
                             plan, FAR["arm"], FAR["sample"], start["estimate_s"], eta, actual,
                             100 * (start["estimate_s"] - actual) / actual))
        assert abs(start["estimate_s"] - actual) <= TOLERANCE * actual
        assert abs(eta - actual) <= TOLERANCE * actual
    finally:
        shutil.rmtree(folder, ignore_errors=True)
