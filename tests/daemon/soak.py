#!/usr/bin/python3
"""Fault soak: captures through goniod's Modbus drivers on gonio-sim (RTU
on its pty, and TCP) while the scene's comm_faults drops, garbles and
delays a share of the exchanges (a third of the rate each).

For each run it reports the faults gonio-sim injected (its --stats), the
drivers' requests, retries, timeouts and bad replies (the stop document's
`comm`), and the points lost: a point whose exchange failed after every
retry fails the capture with a message naming it, and the soak resumes
the capture from its journal (up to a bound). At the end every planned
point must be in the journal exactly once, at the planned angles, with the
material's value (float32 on the bus), and gonio-sim must never have been
asked to go, or gone, outside an axis's limits. A `stall` run jams the arm
(gonio-sim --stall): the capture must stop with a message, the axes
stopped, and the daemon still serving.

  python3 tests/daemon/soak.py --plan ds2 --rates 1,5,20 --transports rtu,tcp
(scripts/soak.sh). ctest runs SoakTests: 5 % on a 24-point plan, both
transports, and the stall.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import goniod_harness as tg  # noqa: E402
import torture  # noqa: E402  (truth, read_journal)

SIM = os.path.join(tg.BIN, "gonio-sim")
MATERIAL = "builtin:nylon"
SCALE = 200          # simulated seconds per wall second
# The drivers' response timeout: 50 ms, 200 ms under valgrind, where a
# daemon and a gonio-sim on memcheck answer in tens of milliseconds.
TIMEOUT_S = 0.05 * (4 if tg.VALGRIND else 1)
# The quiet window the drivers wait for after a failed exchange (driver key
# drain_s), and a late reply's delay: in the middle of that window, a
# quarter second from either end, so a loaded host that starts goniod's wait
# late or gonio-sim's reply late moves it neither inside the timeout nor
# past the drain; it is flushed, not taken for the next answer.
DRAIN_S = 0.5 * (4 if tg.VALGRIND else 1)
LATE_S = TIMEOUT_S + DRAIN_S / 2
MAX_RESUMES = 200


class Rig:
    """gonio-sim with a comm_faults scene, and goniod on it."""

    def __init__(self, folder, rate, transport, retries, seed, stall=None):
        self.folder = folder
        scene = os.path.join(folder, "soak.yaml")
        third = rate / 300.0
        with open(scene, "w") as f:
            f.write("name: soak\nmaterial: %s\nrig: default\nseed: %d\neffects:\n" %
                    (MATERIAL, seed))
            if rate > 0:
                f.write("  - {name: comm_faults, drop: %.6g, corrupt: %.6g, late: %.6g, "
                        "timeout_s: %g}\n" % (third, third, third, LATE_S))
            else:
                f.write("  []\n")
        self.stats_path = os.path.join(folder, "sim-stats.json")
        args = [SIM, "--scene", scene, "--time-scale", str(SCALE), "--tcp", "127.0.0.1:0",
                "--stats", self.stats_path]
        if stall:
            args += ["--stall", stall]
        out = os.path.join(folder, "sim.out")
        self.sim = subprocess.Popen(tg.wrap(args, folder), stdout=open(out, "w"),
                                    stderr=open(os.path.join(folder, "sim.err"), "w"),
                                    preexec_fn=tg.child_procs.die_with_parent)
        deadline = time.time() + 2 * tg.START_S
        text = ""
        while time.time() < deadline and "tcp" not in text:
            time.sleep(0.05)
            text = open(out).read()
        lines = text.splitlines()
        if len(lines) != 2:
            raise AssertionError("gonio-sim did not start: %r" % text)
        where = ("  kind: modbus-rtu\n  device: %s\n" % lines[0] if transport == "rtu" else
                 "  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %s\n" %
                 lines[1].rsplit(":", 1)[1])
        driver = (where + "  time_scale: %g\n  timeout_s: %g\n  drain_s: %g\n  retries: %d\n"
                  "  slaves: {sample: 1, arm: 2, detector: 3, azimuth: 4}\n"
                  % (SCALE, TIMEOUT_S, DRAIN_S, retries))
        self.d = tg.Daemon(folder, driver=driver).start()

    def stop(self):
        self.d.stop()
        self.sim.terminate()
        rc = self.sim.wait(timeout=2 * tg.START_S)
        tg.assert_valgrind_clean(self.folder)
        if rc != 0:
            raise AssertionError("gonio-sim exited %d on SIGTERM" % rc)
        with open(self.stats_path) as f:
            return json.load(f)


def axes_within_limits(stats):
    """Problems with what gonio-sim was asked and where its axes went."""
    bad = []
    for name, ax in stats["axes"].items():
        lo, hi = ax["limits"]
        if ax["refused"]:
            bad.append("%s: %d commands beyond the limits" % (name, ax["refused"]))
        for key in ("commanded", "positions"):
            a, b = ax[key]
            if a is not None and not lo <= a <= b <= hi:
                bad.append("%s: %s range [%g, %g] outside [%g, %g]" % (name, key, a, b, lo, hi))
    return bad


def check_values(capdir):
    """(present, duplicated, wrong) of a capture held against the truth."""
    with open(os.path.join(capdir, "plan.json")) as f:
        plan = json.load(f)["pairs"]
    points = tg.journal_points(os.path.join(capdir, "samples.csv"))
    rows = torture.read_journal(os.path.join(capdir, "samples.csv"))
    old = torture.MATERIAL
    torture.MATERIAL = MATERIAL
    want = torture.truth([(p["theta_i"], p["theta_r"]) for p in plan])
    torture.MATERIAL = old
    wrong = []
    for r in rows:
        k = int(r["point"])
        # Positions travel as whole steps (100 a degree): the plan's angles
        # are whole steps, so they come back exactly up to rounding.
        if (abs(r["theta_i"] - plan[k]["theta_i"]) > 1e-6 or
                abs(r["theta_r"] - plan[k]["theta_r"]) > 1e-6):
            wrong.append((k, "angles", r["theta_i"], r["theta_r"]))
            continue
        for g, w in zip((r["r"], r["g"], r["b"]), want[k]):
            if not abs(g - w) <= 1e-6 * abs(w) + 1e-12:  # binary32 on the bus
                wrong.append((k, "rgb", g, w))
                break
    missing = len(plan) - len(set(points) & set(range(len(plan))))
    return len(plan), len(points), len(points) - len(set(points)), missing, wrong


def soak(folder, rate, transport, plan, retries=4, seed=11, log=lambda s: None):
    """One soak run; returns its row of the table."""
    t0 = time.time()
    rig = Rig(folder, rate, transport, retries, seed)
    if plan == "small":
        plan = torture.write_small_plan(rig.d.root)
    comm = dict(requests=0, retries=0, timeouts=0, bad_replies=0, exceptions=0, failed=0)
    lost, other, messages, runs = 0, 0, [], 0
    try:
        c = rig.d.connect()
        c.request("watch")
        r = c.request("capture", plan=plan, name="soak", material=MATERIAL)
        if r["class"] != "OK":
            raise AssertionError(r)
        while True:
            c.s.settimeout(3600)
            stop = c.until_stop("soak")[-1]
            runs += 1
            for k in comm:
                comm[k] += stop.get("comm", {}).get(k, 0)
            if stop["exit_status"] == "success":
                break
            if stop["exit_status"] != "fail" or runs > MAX_RESUMES:
                raise AssertionError("soak %s %d%%: %r" % (transport, rate, stop))
            # A point gave up after every retry: reported, then resumed. A
            # failure outside a point (opening the devices) loses none.
            lost += stop["message"].startswith("point ")
            other += not stop["message"].startswith("point ")
            messages.append(stop["message"])
            log("  %s %d%%: %s" % (transport, rate, stop["message"]))
            # Before its first sample the capture left no directory: sent again.
            if "nothing was measured" in stop["message"]:
                r = c.request("capture", plan=plan, name="soak", material=MATERIAL)
            else:
                r = c.request("resume", capture_id="soak")
            if r["class"] != "OK":
                raise AssertionError(r)
        if c.request("status")["state"] != "idle":
            raise AssertionError("goniod not idle after the capture")
    finally:
        stats = rig.stop()
    planned, present, dup, missing, wrong = check_values(os.path.join(rig.d.root, "soak"))
    return dict(transport=transport, rate=rate, plan=plan, points=planned,
                exchanges=stats["exchanges"], injected=stats["faults"], comm=comm,
                lost=lost, other_failures=other, present=present, duplicated=dup,
                missing=missing, wrong=len(wrong), wrong_first=wrong[:3], limits=axes_within_limits(stats), messages=messages[:5],
                wall_s=round(time.time() - t0, 1))


def stall_run(folder, transport="rtu"):
    """A jammed arm: the capture must stop with a message, the daemon idle."""
    rig = Rig(folder, 0, transport, 4, 1, stall="2:40")
    try:
        c = rig.d.connect()
        c.request("watch")
        c.request("capture", plan="ds3", name="stall", material=MATERIAL)
        c.s.settimeout(600)
        stop = c.until_stop("stall")[-1]
        state = c.request("status")["state"]
    finally:
        stats = rig.stop()
    return stop, state, stats


def table(rows):
    head = ("| transport | rate | points | exchanges | injected (drop/corrupt/late) | "
            "requests | retries (timeouts/bad) | failed requests | points lost | "
            "other failures | wrong | missing/dup | axes in limits | wall s |")
    out = [head, "|" + "---|" * 14]
    for r in rows:
        i, c = r["injected"], r["comm"]
        out.append("| %s | %d %% | %d | %d | %d (%d/%d/%d) | %d | %d (%d/%d) | %d | %d | %d | "
                   "%d | %d/%d | %s | %.0f |" % (
                       r["transport"], r["rate"], r["points"], r["exchanges"],
                       i["dropped"] + i["corrupted"] + i["late"], i["dropped"], i["corrupted"],
                       i["late"], c["requests"], c["retries"], c["timeouts"], c["bad_replies"],
                       c["failed"], r["lost"], r["other_failures"], r["wrong"], r["missing"],
                       r["duplicated"],
                       "yes" if not r["limits"] else "NO", r["wall_s"]))
    return "\n".join(out)


class SoakTests(unittest.TestCase):
    """make check's soak: 5 % faults on a 24-point plan over RTU and TCP,
    and a stall."""

    def setUp(self):
        if not os.path.exists(SIM):
            self.skipTest("gonio-sim not built")
        self.folder = tg.tmpdir()

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def check_row(self, r):
        self.assertEqual((r["lost"], r["other_failures"]), (0, 0), r)
        self.assertEqual((r["wrong"], r["missing"], r["duplicated"]), (0, 0, 0), r)
        self.assertEqual(r["limits"], [], r)
        injected = sum(r["injected"].values())
        self.assertGreater(injected, 0, r)
        # Every injected fault cost the drivers an attempt, and each was
        # retried (none gave up). A loaded machine adds timeouts of its own
        # (and may turn a garbled answer into a late one), never fewer.
        self.assertGreaterEqual(r["comm"]["retries"], injected, r)
        self.assertEqual(r["comm"]["failed"], 0, r)

    def test_rtu_5_percent(self):
        self.check_row(soak(self.folder, 5, "rtu", "small"))

    def test_tcp_5_percent(self):
        self.check_row(soak(self.folder, 5, "tcp", "small"))

    def test_stall_stops_the_capture(self):
        stop, state, stats = stall_run(self.folder)
        self.assertEqual(stop["exit_status"], "fail", stop)
        self.assertIn("stall", stop["message"])
        self.assertEqual(state, "idle")
        self.assertEqual(axes_within_limits(stats), [])
        # The capture kept what it measured before the jam.
        pts = tg.journal_points(os.path.join(self.folder, "cap", "stall", "samples.csv"))
        self.assertEqual(len(pts), len(set(pts)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--plan", default="ds2")
    ap.add_argument("--rates", default="1,5,20")
    ap.add_argument("--transports", default="rtu,tcp")
    ap.add_argument("--retries", type=int, default=4)
    ap.add_argument("--seed", type=int, default=11)
    a = ap.parse_args()
    rows = []
    for transport in a.transports.split(","):
        for rate in (int(x) for x in a.rates.split(",")):
            folder = tg.tmpdir()
            try:
                print("soak %s %d%% on %s ..." % (transport, rate, a.plan), file=sys.stderr,
                      flush=True)
                r = soak(folder, rate, transport, a.plan, a.retries, a.seed,
                         log=lambda s: print(s, file=sys.stderr, flush=True))
                rows.append(r)
                print(json.dumps(r), file=sys.stderr, flush=True)
            finally:
                shutil.rmtree(folder, ignore_errors=True)
    folder = tg.tmpdir()
    try:
        stop, state, stats = stall_run(folder)
        stall_line = "stall (arm jammed at 40 deg, RTU): %s, %s; daemon %s; axes in limits: %s" % (
            stop["exit_status"], stop.get("message"), state,
            "yes" if not axes_within_limits(stats) else "NO")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(table(rows))
    print()
    print(stall_line)
    bad = [r for r in rows if r["wrong"] or r["missing"] or r["duplicated"] or r["limits"] or
           (r["rate"] <= 5 and (r["lost"] or r["other_failures"]))]
    return 1 if bad else 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1].startswith("Soak"):
        unittest.main()
    sys.exit(main())
