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
import json
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


def axis_time(d, speed, accel):
    """rig/motion.c's rig_axis_time: a trapezoidal move of d degrees."""
    d = abs(d)
    if d == 0:
        return 0.0
    if d <= speed * speed / accel:
        return 2 * (d / accel) ** 0.5
    return d / speed + speed / accel


def move_time(start, pair):
    """rig_move_time on the default profile: the slowest axis."""
    return max(axis_time(pair["s"] - start["s"], 20, 40), axis_time(pair["a"] - start["a"], 15, 30))


def test_order_from_present_position():
    """A capture that finds the arm far from home orders its travel from
    there: plan.json records that start and the order used (not the one
    from home), and the first point measured is plan.json's first, the one
    nearest the axes in the greedy order."""
    folder = tg.tmpdir()
    sim = tm.Sim(folder, "ideal", scale=None)
    d = None
    try:
        d = tg.Daemon(folder, driver=sim.driver("tcp")).start()
        c = d.connect()
        c.request("watch")
        plans = {}
        for name, far in (("home", {}), ("far", FAR)):
            for axis, deg in far.items():
                assert c.request("move", axis=axis, deg=deg)["class"] == "OK"
            reply = c.request("capture", plan="ds3", order="greedy", name=name)
            assert reply["class"] == "OK", reply
            assert c.until_stop(name)[-1]["exit_status"] == "success"
            with open(os.path.join(d.root, name, "plan.json")) as f:
                plans[name] = json.load(f)
        home, far = plans["home"], plans["far"]
        assert "start" not in home
        start = far["start"]
        assert abs(start["a"] - FAR["arm"]) < 0.2 and abs(start["s"] - FAR["sample"]) < 0.2, start
        key = lambda p: (p["theta_i"], p["theta_r"])
        assert sorted(map(key, home["pairs"])) == sorted(map(key, far["pairs"]))
        assert list(map(key, home["pairs"])) != list(map(key, far["pairs"]))
        # the greedy order's first point: the nearest to where the axes stood
        times = [move_time(start, p) for p in far["pairs"]]
        assert times[0] == min(times), (far["pairs"][0], min(times))
        assert move_time(start, home["pairs"][0]) > times[0]
        # what was measured first is plan.json's first pair (the pre-scan's
        # first point, the soonest reached in its stretch), then every one
        with open(os.path.join(d.root, "far", "samples.csv")) as f:
            rows = [l.split(",") for l in f.read().splitlines()[1:]]
        points = [int(r[0]) for r in rows]
        assert points[0] == 0, points
        assert sorted(points) == list(range(len(far["pairs"]))), points
    finally:
        if d:
            d.stop()
        sim.stop()
        shutil.rmtree(folder, ignore_errors=True)


def journal_points(path):
    """The points of samples.csv, in record order."""
    with open(path) as f:
        return [int(l.split(",")[0]) for l in f.read().splitlines()[1:]]


def test_resume_travels_from_the_present_position():
    """A capture aborted far from home and resumed after `home`: the points
    left are travelled from where the axes stand, not from where the
    journal left them. The first point the resume measures is the one the
    greedy order takes first from home (nearer than the one the recorded
    order had next); the point numbers stay plan.json's, which is
    unchanged, every point is measured once, and the ETA at the resume's
    first point is within TOLERANCE of the rig time the capture took."""
    folder = tg.tmpdir()
    sim = tm.Sim(folder, "ideal", scale=None)
    d = None
    try:
        d = tg.Daemon(folder, driver=sim.driver("tcp")).start()
        c = d.connect()
        c.request("watch")
        home = {"s": 0.0, "a": 0.0}
        # The abort lands a few points after the first event, more on a
        # loaded host. Where it lands on the point nearest home, the
        # recorded order's next point is the nearest too and the first
        # point cannot tell the orders apart: the capture is taken again.
        for attempt in range(3):
            cut = "cut%d" % attempt
            for axis, deg in FAR.items():
                assert c.request("move", axis=axis, deg=deg)["class"] == "OK"
            r = c.request("capture", plan="ds3", order="greedy", name=cut, prescan=0)
            assert r["class"] == "OK", r
            while c.read().get("class") != "event":
                pass
            c.request("abort")
            assert c.until_stop(cut)[-1]["reason"] == "aborted"
            path = os.path.join(d.root, cut, "plan.json")
            with open(path) as f:
                before = f.read()
            journal = os.path.join(d.root, cut, "samples.csv")
            done = journal_points(journal)
            pairs = json.loads(before)["pairs"]
            left = [k for k in range(len(pairs)) if k not in done]
            times = {k: move_time(home, pairs[k]) for k in left}
            if times[min(left)] > min(times.values()):
                break
        else:
            pytest.fail("three aborts landed where the recorded order's next point is the "
                        "nearest to home: the orders cannot be told apart")
        assert c.request("home")["class"] == "OK"
        assert c.request("resume", capture_id=cut)["class"] == "OK"
        docs = c.until_stop(cut)
        assert docs[-1]["exit_status"] == "success", docs[-1]
        with open(path) as f:
            assert f.read() == before
        points = journal_points(journal)
        assert sorted(points) == list(range(len(pairs))), points
        assert points[:len(done)] == done
        first = points[len(done)]
        # the nearest to home, where the recorded order's next is farther
        assert times[first] == min(times.values()), (first, times)
        assert times[min(left)] > times[first], (min(left), first, times)
        event = next(x for x in docs if x.get("class") == "event")
        actual = tm.results(os.path.join(d.root, cut))["rig_time_s"]
        eta = event["rig_time_s"] + event["eta_s"]
        sys.stderr.write("resume from home: first ETA %.1f s, actual %.1f s\n" % (eta, actual))
        assert abs(eta - actual) <= TOLERANCE * actual
    finally:
        if d:
            d.stop()
        sim.stop()
        shutil.rmtree(folder, ignore_errors=True)
