"""Drives restarted mid-capture, and devices that answer late, under goniod.

gonio-sim (the lab scene) is killed with SIGKILL during a DS2 capture and
started again on the same TCP port and pty link 0-0.5 s later, a power cycle
of the whole rig, over Modbus TCP and over RTU. Whatever the capture does
(carries on, or fails naming the restart, then `resume`), the journal ends
with every plan point measured once, every sample's axes within the
in-position band of its plan point, a rig clock that never goes back and
never had to be held back, and no rig time beyond what gonio-sim's clock
can have run during the capture (its wall time at the time scale: a
wrapped 32-bit clock difference reads 4.29e6 s). The rig time's ratio to
the plan's estimate is reported, not asserted: at time scale 50 the host's
own time counts 50 times over, so on a loaded machine it says more about
the load than about the drivers. A capture on a scene whose devices answer
late journals no backward rig-clock step.

RESTARTS_TCP / RESTARTS_RTU (environment) set how many captures with a
restart each; scripts/restart_matrix.sh runs 20 and 10. LATE_SCENE and
LATE_MINUTES set the late-replies run's scene (default lab) and how long it
captures back to back (default one capture); scripts/late_soak.sh runs the
bad-day scene for 15 minutes. Both scenes' detectors give counts: the
captures here are of the drives and the clock, taken uncalibrated (counts
journalled, nothing fitted)."""
import json
import os
import random
import re
import shutil
import signal
import subprocess
import time

import pytest

from conftest import tg

SCALE = 50
PLAN = "ds2"
BAND = 0.1  # configs/rigs/default.yaml mechanics.in_position_deg
RESUMES = 4  # resumes allowed per capture (each restart costs at most one)


class Sim:
    """gonio-sim on a TCP port and a pty link that survive its restarts."""

    def __init__(self, folder, scene):
        self.folder, self.scene = folder, scene
        self.link = os.path.join(folder, "rig-tty")
        self.port = 0
        self.proc = None
        self.start()

    def start(self):
        out = os.path.join(self.folder, "sim.out")
        self.proc = subprocess.Popen(
            tg.wrap([os.path.join(tg.BIN, "gonio-sim"), "--scene", self.scene, "--time-scale",
                     str(SCALE), "--tcp", "127.0.0.1:%d" % self.port, "--link", self.link],
                    self.folder),
            stdout=open(out, "w"), stderr=open(os.path.join(self.folder, "sim.err"), "a"),
            preexec_fn=tg.child_procs.die_with_parent)
        deadline = time.time() + tg.START_S
        text = ""
        while time.time() < deadline and "tcp" not in text:
            time.sleep(0.01)
            text = open(out).read()
        assert "tcp" in text, text
        self.port = int(text.splitlines()[1].rsplit(":", 1)[1])

    def power_cycle(self, down_s):
        self.proc.kill()
        self.proc.wait()
        time.sleep(down_s)
        self.start()

    def driver(self, transport):
        where = ("  kind: modbus-rtu\n  device: %s\n  baud: 115200\n" % self.link
                 if transport == "rtu" else
                 "  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %d\n" % self.port)
        return where + ("  time_scale: %d\n  timeout_s: %g\n  slaves: {sample: 1, arm: 2, "
                        "detector: 3, azimuth: 4}\n" % (SCALE, 0.2 * tg.SLOW))

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            self.proc.wait(timeout=2 * tg.START_S)


def journal(capdir):
    """samples.csv's samples as dicts, in journal order (dark frames apart)."""
    with open(os.path.join(capdir, "samples.csv")) as f:
        lines = f.read().splitlines()
    names = lines[0].split(",")
    rows = [dict(zip(names, line.split(","))) for line in lines[1:]]
    return [r for r in rows if not int(r["flags"]) & 2]


def check_journal(capdir, most_s, whole=True):
    """The journal's promises (no rig time beyond most_s; every plan point
    once unless whole is false); returns (samples, worst axis error, rig
    time)."""
    with open(os.path.join(capdir, "plan.json")) as f:
        pairs = json.load(f)["pairs"]
    rows = journal(capdir)
    worst, last_t = 0.0, -1.0
    for row in rows:
        p = pairs[int(row["point"])]
        err = max(abs(float(row["s"]) - p["s"]), abs(float(row["a"]) - p["a"]))
        assert err <= BAND + 1e-9, "point %s journalled at s %s a %s, planned %g %g" % (
            row["point"], row["s"], row["a"], p["s"], p["a"])
        worst = max(worst, err)
        t = float(row["rig_time_s"])
        assert t >= last_t, "rig time %g after %g (point %s)" % (t, last_t, row["point"])
        last_t = t
    points = sorted(int(r["point"]) for r in rows)
    assert points == (list(range(len(pairs))) if whole else sorted(set(points)))
    assert last_t <= most_s, "rig time %g s, at most %g s can have passed" % (last_t, most_s)
    return len(rows), worst, last_t


def clock_held(daemon):
    """The rig clock's warnings that it held a rig time that would have
    gone back (drivers/drv_modbus_clock.c), in goniod's log."""
    with open(daemon.log, errors="replace") as f:
        return [line for line in f if "would go back" in line]


def capture_with_restart(transport, seed):
    """One DS2 capture through goniod with a power cycle of the rig once
    the capture has run for a random 1-30 points; resumes until complete.
    Returns a dict of what happened."""
    rnd = random.Random(seed)
    folder = tg.tmpdir()
    sim = Sim(folder, "lab")
    d = tg.Daemon(folder, driver=sim.driver(transport))
    fails = []
    try:
        d.start()
        c = d.connect()
        c.request("watch")
        t0 = time.monotonic()
        assert c.request("capture", plan=PLAN, name="r", uncalibrated=True)["class"] == "OK"
        at, down = rnd.randint(1, 30), rnd.uniform(0.0, 0.5)
        estimate, cycled, docs = None, False, []
        while True:
            doc = c.read()
            assert doc is not None, docs[-3:]
            docs.append(doc)
            if doc.get("class") == "start" and estimate is None:
                estimate = doc["estimate_s"]
            if doc.get("class") == "event" and not cycled and doc["done"] >= at:
                sim.power_cycle(down)
                cycled = True
            if doc.get("class") == "stop":
                if doc["reason"] == "complete":
                    break
                fails.append(doc.get("message") or json.dumps(doc)[:300])
                assert len(fails) <= RESUMES, fails
                assert c.request("resume", capture_id="r")["class"] == "OK"
        assert cycled, "the capture ended before the restart"
        n, worst, rig_t = check_journal(os.path.join(d.root, "r"),
                                        (time.monotonic() - t0) * SCALE * 1.01 + 1)
        assert clock_held(d) == []
        return {"samples": n, "worst_deg": worst, "rig_time_s": rig_t, "estimate_s": estimate,
                "over_estimate": rig_t / estimate,
                "failures": fails, "at": at, "down_s": down}
    finally:
        d.stop()
        sim.stop()
        shutil.rmtree(folder, ignore_errors=True)


def restarts(kind, default):
    return int(os.environ.get("RESTARTS_" + kind.upper(), default))


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
def test_restart_mid_capture(transport):
    runs = [capture_with_restart(transport, seed) for seed in range(restarts(transport, 2))]
    for r in runs:
        print("%s: %s" % (transport, json.dumps(r)))
        # A failure names its cause: the restart as a device saw it, or a
        # rig still down when the retries ran out (a loaded host starts
        # gonio-sim again slowly).
        for msg in r["failures"]:
            assert "restarted" in msg or "IN-POS" in msg or "connection" in msg or \
                "serial port" in msg or "no answer within" in msg, msg


def test_late_replies_never_take_the_clock_back():
    folder = tg.tmpdir()
    scene = os.path.join(folder, "late.yaml")
    name = os.environ.get("LATE_SCENE", "lab")
    minutes = float(os.environ.get("LATE_MINUTES", "0"))
    with open(os.path.join(tg.SOURCE, "configs", "scenes", name + ".yaml")) as f:
        text = f.read()
    text = text.replace("name: %s" % name, "name: %s-late" % name)
    if "name: comm_faults" in text:  # the scene's own faults, made late more often
        text = re.sub(r"late: [0-9.e-]+", "late: 0.05", text)
    else:
        text += "  - {name: comm_faults, late: 0.05, timeout_s: 0.05}\n"
    with open(scene, "w") as f:
        f.write(text)
    sim = Sim(folder, scene)
    d = tg.Daemon(folder, driver=sim.driver("tcp"))
    try:
        d.start()
        c = d.connect()
        c.request("watch")
        end = time.monotonic() + minutes * 60
        k = 0
        while k == 0 or time.monotonic() < end:
            k += 1
            cap = "l%d" % k
            t0 = time.monotonic()
            assert c.request("capture", plan=PLAN, name=cap, uncalibrated=True)["class"] == "OK"
            docs = c.until_stop(cap)
            most = (time.monotonic() - t0) * SCALE * 1.01 + 1
            start = next(x for x in docs if x.get("class") == "start")
            # A scene's own faults (bad-day's stalling arm) may fail a
            # capture; the clock must hold whatever the ending.
            assert docs[-1]["reason"] == "complete" or name != "lab", docs[-1]
            n, _, rig_t = check_journal(os.path.join(d.root, cap), most, whole=False)
            print("late %s %d: %s, %d samples, rig time %.1f s, estimate %.1f s, comm %s" % (
                name, k, docs[-1]["reason"], n, rig_t, start["estimate_s"],
                json.dumps(docs[-1]["comm"])))
            assert clock_held(d) == []
    finally:
        d.stop()
        sim.stop()
        shutil.rmtree(folder, ignore_errors=True)
