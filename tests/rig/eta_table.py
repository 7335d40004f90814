#!/usr/bin/python3
"""The ETA-over-Modbus table of docs/plans.md ("Estimates on a real day"):
goniod captures over Modbus RTU (gonio-sim's pty) and Modbus TCP against
gonio-sim on a scene (default lab), with the pre-scan goniod makes on a
Modbus rig, --uncalibrated (the ranging and the rig time are those of a
capture with a calibration over the ladder). For each plan and transport: the estimate goniod announces
before the first move (the fixed integration: goniod cannot meter the
material in advance; the pre-scan's detours included), the total the ETA gives right after the pre-scan
(the rig time so far plus the ETA), the same halfway through the points,
and the rig time the capture took (results.json).

A measurement on the rig tests' harness (goniod_harness, test_matrix), kept
beside them (Python is for tests only in gonio).

Usage: tests/rig/eta_table.py [BIN_DIR] (default build/bin); env PLANS
(default "ds4 ds3 ds2 ds1"), TRANSPORTS ("rtu tcp"), SCENE (lab),
TIME_SCALE (gonio-sim's, default 20: the rig clock runs on while goniod
talks on the bus, so a faster scale makes the bus cost more rig time than
on a real rig, which the overhead then learns). Prints the Markdown table
on stdout; with ETA_DOC=docs/plans.md it replaces the table between the
document's eta-table markers."""
import os
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
BIN = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build", "bin"))
os.environ["GONIO_BIN"] = BIN
sys.path.insert(0, os.path.join(ROOT, "tests", "daemon"))
sys.path.insert(0, HERE)
import goniod_harness as tg  # noqa: E402
import test_matrix as tm  # noqa: E402

tg.BIN = BIN
PLANS = os.environ.get("PLANS", "ds4 ds3 ds2 ds1").split()
TRANSPORTS = os.environ.get("TRANSPORTS", "rtu tcp").split()
SCENE = os.environ.get("SCENE", "lab")
SCALE = float(os.environ.get("TIME_SCALE", "20"))



def capture(plan, transport):
    """(pre-scan points, announced estimate, total after the pre-scan, total halfway,
    actual rig time)."""
    folder = tg.tmpdir()
    sim = tm.Sim(folder, SCENE, scale=SCALE)
    d = None
    try:
        d = tg.Daemon(folder, driver=sim.driver(transport)).start()
        c = d.connect()
        c.request("watch")
        # lab's detector gives counts: journalled as counts, ranged as a
        # calibrated capture ranges (the rig time is the same, docs/plans.md)
        reply = c.request("capture", plan=plan, name="e", uncalibrated=True)
        assert reply["class"] == "OK", reply
        docs = c.until_stop("e")
        d.stop()
        d = None
        sim.stop()
        sim = None
        start = next(x for x in docs if x.get("class") == "start")
        events = [x for x in docs if x.get("class") == "event" and "eta_s" in x]
        stop = docs[-1]
        assert stop["exit_status"] == "success", stop
        total = events[-1]["total"]
        after = next(e for e in events if e["done"] == max(start["prescan"], 1))
        half = next(e for e in events if e["done"] >= total / 2)
        res = tm.results(os.path.join(folder, "cap", "e"))
        return (start["prescan"], start["estimate_s"], after["rig_time_s"] + after["eta_s"],
                half["rig_time_s"] + half["eta_s"], res["rig_time_s"])
    finally:
        if d:
            d.stop()
        if sim:
            sim.stop()
        shutil.rmtree(folder, ignore_errors=True)


def pct(e, a):
    return "%+.1f %%" % (100 * (e - a) / a)


def main():
    rows = ["| plan | transport | pre-scan | fixed estimate (s) | after the pre-scan (s) | "
            "halfway (s) | actual (s) | fixed vs actual | pre-scan vs actual | halfway vs actual |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for plan in PLANS:
        for transport in TRANSPORTS:
            n, fixed, after, half, actual = capture(plan, transport)
            rows.append("| %s | %s | %d | %.1f | %.1f | %.1f | %.1f | %s | %s | %s |" % (
                plan, transport.upper(), n, fixed, after, half, actual, pct(fixed, actual),
                pct(after, actual), pct(half, actual)))
            sys.stderr.write(rows[-1] + "\n")
    table = "\n".join(rows) + "\n"
    doc = os.environ.get("ETA_DOC")
    if doc:
        with open(doc) as f:
            lines = f.read().split("\n")
        b = next(i for i, l in enumerate(lines) if l.startswith("<!-- eta-table begin"))
        e = next(i for i, l in enumerate(lines) if l.startswith("<!-- eta-table end"))
        lines[b + 1:e] = table.rstrip("\n").split("\n")
        with open(doc + ".new", "w") as f:
            f.write("\n".join(lines))
        os.replace(doc + ".new", doc)
    sys.stdout.write(table)


if __name__ == "__main__":
    main()
