"""The rig matrix: goniod over Modbus RTU (gonio-sim's pty) and Modbus TCP
against gonio-sim on the scenes ideal, lab and bad-day, plan DS3, beside the
in-process rig (`gonio capture --offline`) on the same scene and plan.

Every capture completes with every planned point exactly once; bad-day's
arm stall (alarm 0x10 on its 30th move command) is recovered, and
results.json counts as many recovered alarms as gonio-sim raised, as the
in-process rig does with its own stall; the ideal capture's samples equal
the in-process capture's: the angles bit for bit, the RGB bit for bit at
the bus's precision (binary32, docs/protocol-modbus.md). lab's and
bad-day's detectors give counts: their captures here are of mechanics, so
they are taken uncalibrated (counts journalled, nothing fitted), on every
backend alike. A calibrated lab capture through goniod over Modbus, against
its material's truth, is tests/daemon/test_goniod_calibrate.py's.

Under make check-valgrind (GONIO_WRAP) goniod and gonio-sim run on memcheck;
the matrix then runs its diagonal only (ideal over RTU, lab over TCP,
bad-day over RTU), which still takes every scene and transport through
memcheck (docs/testing-memory.md)."""
import json
import os
import shutil
import signal
import struct
import subprocess
import sys
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "daemon"))
import goniod_harness as tg  # noqa: E402  (Daemon, wrap, valgrind checks)

SCALE = 1000
PLAN = "ds3"
POINTS = 52
PRESCAN = 2  # goniod's default on a Modbus rig for DS3's 52 points (one in 25)
SCENES = ("ideal", "lab", "bad-day")
TRANSPORTS = ("rtu", "tcp")
CASES = ([("ideal", "rtu"), ("lab", "tcp"), ("bad-day", "rtu")] if tg.VALGRIND else
         [(s, t) for s in SCENES for t in TRANSPORTS])
# The scenes' material, named to goniod as the reference of the truth errors.
TRUTH = "default"


def read_rows(path):
    """samples.csv rows by point, as the text fields (exact values)."""
    with open(path) as f:
        lines = f.read().splitlines()
    header = lines[0].split(",")
    records = [dict(zip(header, l.split(","))) for l in lines[1:]]
    records = [r for r in records if not int(r["flags"]) & 2]  # dark frames apart
    points = [int(r["point"]) for r in records]
    rows = {int(r["point"]): r for r in records}
    return points, rows


class Sim:
    """gonio-sim on a scene, RTU on its pty and TCP on loopback; on wall time
    at a time scale, or with scale=None on its simulated clock (the drivers
    then pace nothing by a scale: theirs is 1)."""

    def __init__(self, folder, scene, scale=SCALE, extra=()):
        self.folder = folder
        self.scale = scale
        self.stats = os.path.join(folder, "sim-stats.json")
        out = os.path.join(folder, "sim.out")
        clock = (["--clock", "simulated"] if scale is None else ["--time-scale", str(scale)])
        self.proc = subprocess.Popen(
            tg.wrap([os.path.join(tg.BIN, "gonio-sim"), "--scene", scene] + clock +
                    ["--tcp", "127.0.0.1:0", "--stats", self.stats] + list(extra), folder),
            stdout=open(out, "w"), stderr=open(os.path.join(folder, "sim.err"), "w"),
            preexec_fn=tg.child_procs.die_with_parent)
        deadline = time.time() + tg.START_S
        text = ""
        while time.time() < deadline and "tcp" not in text:
            time.sleep(0.05)
            text = open(out).read()
        lines = text.splitlines()
        assert len(lines) == 2, text
        self.pty = lines[0]
        self.port = int(lines[1].rsplit(":", 1)[1])

    def driver(self, transport):
        where = ("  kind: modbus-rtu\n  device: %s\n  baud: 115200\n" % self.pty
                 if transport == "rtu" else
                 "  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %d\n" % self.port)
        return where + ("  time_scale: %d\n  timeout_s: %g\n  slaves: {sample: 1, arm: 2, "
                        "detector: 3, azimuth: 4}\n" % (self.scale or 1, 0.1 * tg.SLOW))

    def stop(self):
        """SIGTERM; gonio-sim's stats (it writes them at exit)."""
        self.proc.send_signal(signal.SIGTERM)
        assert self.proc.wait(timeout=2 * tg.START_S) == 0
        with open(self.stats) as f:
            return json.load(f)


def capture(folder, scene, transport):
    """One goniod capture of DS3; (stop document, capture dir, gonio-sim stats)."""
    sim = Sim(folder, scene)
    d = None
    try:
        d = tg.Daemon(folder, driver=sim.driver(transport)).start()
        c = d.connect()
        c.request("watch")
        reply = c.request("capture", plan=PLAN, name="m", truth=TRUTH,
                          **({} if scene == "ideal" else {"uncalibrated": True}))
        assert reply["class"] == "OK", reply
        stop = c.until_stop("m")[-1]
    finally:
        if d:
            d.stop()
        stats = sim.stop()
    tg.assert_valgrind_clean(folder)
    return stop, os.path.join(d.root, "m"), stats


def offline(folder, scene):
    """The in-process capture of DS3 on scene: its directory. With the
    pre-scan goniod makes by default on a Modbus rig (docs/plans.md), so
    that the drives get the in-process rig's commands in the same order."""
    out = os.path.join(folder, "offline-" + scene)
    r = subprocess.run([os.path.join(tg.BIN, "gonio"), "capture", "--offline", "--scene", scene,
                        "--plan", PLAN, "--out", out, "--quiet", "--prescan", str(PRESCAN)]
                       + ([] if scene == "ideal" else ["--uncalibrated"]),
                       capture_output=True, text=True,
                       timeout=4 * tg.START_S)
    assert r.returncode == 0, r.stderr
    return out


def kill9_and_resume(d, c, capture_id, done):
    """Follow the events on the watching connection c until `done` points
    are reported, SIGKILL goniod d, restart it and resume capture_id: every
    document from the resume's start to its stop."""
    while True:
        e = c.read()
        assert e is not None and e.get("class") != "stop", e
        if e.get("class") == "event" and e["done"] >= done:
            break
    d.kill9()
    d.start()
    c = d.connect()
    c.request("watch")
    assert c.request("resume", capture_id=capture_id)["class"] == "OK"
    return c.until_stop(capture_id)


def results(capdir):
    with open(os.path.join(capdir, "results.json")) as f:
        return json.load(f)


@pytest.fixture(scope="module")
def runs():
    """Captures by (scene, transport), transport "offline" for the in-process
    rig, each run once for all the module's tests: (stop, capture dir,
    gonio-sim stats), stop and stats None in-process."""
    done, folders = {}, []

    def run(scene, transport):
        if (scene, transport) not in done:
            folder = tg.tmpdir()
            folders.append(folder)
            done[scene, transport] = ((None, offline(folder, scene), None)
                                      if transport == "offline" else
                                      capture(folder, scene, transport))
        return done[scene, transport]
    yield run
    for folder in folders:
        shutil.rmtree(folder, ignore_errors=True)


def binary32(text):
    return struct.unpack("f", struct.pack("f", float(text)))[0]


@pytest.mark.parametrize("scene,transport", CASES)
def test_capture(runs, scene, transport):
    stop, capdir, sim_stats = runs(scene, transport)
    assert stop["reason"] == "complete", stop
    points, rows = read_rows(os.path.join(capdir, "samples.csv"))
    assert sorted(points) == list(range(POINTS))  # none lost, none twice
    mech = results(capdir)["mechanics"]
    raised = sum(ax["alarms"] for ax in sim_stats["axes"].values())
    assert mech["alarms_recovered"] == raised
    sent = sum(ax["moves"] + ax["refused"] for ax in sim_stats["axes"].values())
    assert mech["moves"] <= sent  # a retried command may reach the drive twice
    if scene == "bad-day":
        assert raised >= 1  # the arm's stall on its 30th move command
        assert sim_stats["axes"]["arm"]["alarms"] >= 1
    if scene != "bad-day":  # no faults: the drives got the in-process rig's commands
        assert mech == results(runs(scene, "offline")[1])["mechanics"], mech
    if scene == "ideal":
        assert mech["recommands"] == 0 and raised == 0
        want = read_rows(os.path.join(runs(scene, "offline")[1], "samples.csv"))[1]
        for p in range(POINTS):
            for key in ("theta_i", "theta_r", "phi_o", "s", "a"):
                assert rows[p][key] == want[p][key], (p, key, rows[p], want[p])
            for key in ("r", "g", "b"):
                assert float(rows[p][key]) == binary32(want[p][key]), (p, key)
    sys.stderr.write("matrix %s/%s: %d requests, mechanics %s\n" % (
        scene, transport, stop["comm"]["requests"], json.dumps(mech)))


@pytest.mark.parametrize("scene", SCENES)
def test_in_process_completes(runs, scene):
    """The in-process rig recovers what goniod's drivers recover: the same
    mechanics (drivers/drivers.h), every point once, bad-day's stall counted."""
    capdir = runs(scene, "offline")[1]
    points = read_rows(os.path.join(capdir, "samples.csv"))[0]
    assert sorted(points) == list(range(POINTS))
    mech = results(capdir)["mechanics"]
    assert mech["alarms_recovered"] == (1 if scene == "bad-day" else 0), mech
    assert mech["rehomes"] == 0
