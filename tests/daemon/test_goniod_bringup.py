#!/usr/bin/python3
"""goniod on a new rig: the configuration checked against the hardware it
names (a rig profile's axes the driver does not have, at --check, at start,
at a capture request and at resume), --check --probe, and an out-of-plane
capture over gonio-sim's Modbus drives (goniod_harness.py; gonio-sim through
test_goniod_modbus.ModbusRig).

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \
      python3 tests/daemon/test_goniod_bringup.py -v
"""
import glob
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import (GONIO, GONIOD, SLOW, SOURCE, START_S, Daemon,  # noqa: E402
                            run_wrapped, shipped_config, tmpdir)
import test_goniod_modbus  # noqa: E402  (ModbusRig)
import child_procs  # noqa: E402

# configs/rigs/default.yaml with the azimuth axis taken away: an in-plane rig.
with open(os.path.join(SOURCE, "configs", "rigs", "default.yaml")) as _f:
    DEFAULT_RIG = _f.read()
INPLANE_RIG = (DEFAULT_RIG.replace("out_of_plane: true", "out_of_plane: false")
               .replace("name: default", "name: inplane"))
assert "out_of_plane: false" in INPLANE_RIG

# Three out-of-plane pairs [theta_i, phi_i, theta_o, phi_o]: the azimuth
# drive turns to phi_o - phi_i - 180 = -90, -60 and -120 deg.
OOP_PLAN = ("name: oop-mini\ndescription: three out-of-plane pairs\n"
            "pairs:\n  - [30, 0, 40, 90]\n  - [30, 0, 40, 120]\n  - [20, 0, 50, 60]\n"
            "order: as-written\n")
OOP_PHI_O = {0: 90.0, 1: 120.0, 2: 60.0}


def samples_phi(path):
    """samples.csv's recorded phi_o (column 5) by point."""
    with open(path) as f:
        rows = [l.split(",") for l in f.read().splitlines()[1:]]
    return {int(r[0]): float(r[5]) for r in rows}


class ConfigRigTests(unittest.TestCase):
    """The rig profile against the driver's axes, at --check and at start."""
    TCP = ("rig: %s\ndriver:\n  kind: modbus-tcp\n  host: 127.0.0.1\n  port: 1502\n"
           "  slaves:\n    sample: 1\n    arm: 2\n    detector: 3\n%s"
           "capture_root: caps\nsocket:\n  path: g.sock\n")

    def setUp(self):
        self.folder = tmpdir()
        with open(os.path.join(self.folder, "inplane.yaml"), "w") as f:
            f.write(INPLANE_RIG)

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def write(self, rig, azimuth):
        path = os.path.join(self.folder, "c.yaml")
        with open(path, "w") as f:
            f.write(self.TCP % (rig, "    azimuth: %d\n" % azimuth if azimuth else ""))
        return path

    def test_out_of_plane_rig_without_azimuth_refused(self):
        path = self.write("default", 0)
        r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertEqual(r.stdout, "")
        # The file, where (the slaves mapping, from line 7), the field, the value.
        self.assertIn("%s:7:" % path, r.stderr)
        self.assertIn("driver.slaves.azimuth is 0", r.stderr)
        self.assertIn("rig profile 'default' is out of plane", r.stderr)
        # And goniod does not start on it either (nothing created).
        r = run_wrapped([GONIOD, "--config", path], self.folder, timeout=30)
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("driver.slaves.azimuth is 0", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.folder, "caps")))

    def test_consistent_pairs_accepted(self):
        for rig, az in (("default", 4), ("inplane.yaml", 0), ("inplane.yaml", 4)):
            r = run_wrapped([GONIOD, "--config", self.write(rig, az), "--check"], self.folder)
            self.assertEqual(r.returncode, 0, (rig, az, r.stderr))
            self.assertIn("    azimuth: %d\n" % az, r.stdout)

    def test_sample_changer_not_wired_refused(self):
        """A rig profile with a sample changer on a driver without its
        drive: refused at --check and at start, naming the field; wired,
        accepted and printed."""
        with open(os.path.join(self.folder, "changer.yaml"), "w") as f:
            f.write(INPLANE_RIG.replace("name: inplane", "name: changer")
                    + "sample_changer: true\n")
        path = self.write("changer.yaml", 0)
        r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertEqual(r.stdout, "")
        self.assertIn("%s:7:" % path, r.stderr)
        self.assertIn("key 'sample_changer'", r.stderr)
        self.assertIn("driver.slaves.sample_changer is 0 (none), but rig profile '%s' has a "
                      "sample changer" % os.path.join(self.folder, "changer.yaml"), r.stderr)
        r = run_wrapped([GONIOD, "--config", path], self.folder, timeout=30)
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("driver.slaves.sample_changer is 0", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.folder, "caps")))
        with open(path) as f:
            text = f.read()
        with open(path, "w") as f:
            f.write(text.replace("    detector: 3\n", "    detector: 3\n    sample_changer: 5\n"))
        r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("    sample_changer: 5\n", r.stdout)
        # its own slave id, as every device
        with open(path, "w") as f:
            f.write(text.replace("    detector: 3\n", "    detector: 3\n    sample_changer: 2\n"))
        r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("every device needs its own slave id", r.stderr)
        self.assertIn("sample_changer 2", r.stderr)

    def test_every_shipped_config(self):
        """Every configs/goniod/*.yaml with the rig profile it names passes
        --check (modbus-tcp.yaml once named the out-of-plane default rig
        without an azimuth drive)."""
        names = sorted(os.path.basename(p) for p in
                       glob.glob(os.path.join(SOURCE, "configs", "goniod", "*.yaml")))
        self.assertIn("modbus-tcp.yaml", names)
        for name in names:
            path = shipped_config(name, self.folder)
            r = run_wrapped([GONIOD, "--config", path, "--check"], self.folder)
            if r.returncode != 0 and "built without" in r.stderr:
                continue  # a backend this build lacks (the USB spectrometer)
            self.assertEqual(r.returncode, 0, name + ": " + r.stderr)
        r = run_wrapped([GONIOD, "--config", shipped_config("modbus-tcp.yaml", self.folder),
                         "--check"], self.folder)
        self.assertIn("    azimuth: 4\n", r.stdout)


class RequestRigTests(unittest.TestCase):
    """A request whose rig or plan needs an axis the driver lacks: refused
    before anything is created (no device is opened for it)."""

    def setUp(self):
        self.folder = tmpdir()
        # A Modbus rig with no azimuth drive, in plane: valid as configured.
        self.d = Daemon(self.folder, driver="  kind: modbus-tcp\n  host: 127.0.0.1\n"
                        "  port: 1\n  slaves: {sample: 1, arm: 2, detector: 3}\n")
        with open(self.d.config) as f:
            text = f.read()
        with open(self.d.config, "w") as f:
            f.write(text.replace("rig: default", "rig: inplane.yaml"))
        with open(os.path.join(self.folder, "inplane.yaml"), "w") as f:
            f.write(INPLANE_RIG)
        os.makedirs(self.d.root)
        with open(os.path.join(self.d.root, "oop.yaml"), "w") as f:
            f.write(OOP_PLAN)
        self.d.start()

    def tearDown(self):
        self.d.stop()
        shutil.rmtree(self.folder, ignore_errors=True)

    def test_out_of_plane_rig_refused_at_request(self):
        c = self.d.connect()
        r = c.request("capture", plan="ds3", rig="default", name="x")
        self.assertEqual(r["class"], "ERROR", r)
        self.assertIn(self.d.config, r["message"])
        self.assertIn("driver.slaves.azimuth is 0", r["message"])
        self.assertIn("'default' is out of plane", r["message"])
        self.assertFalse(os.path.exists(os.path.join(self.d.root, "x")))

    def test_sample_changer_rig_refused_at_request(self):
        with open(os.path.join(self.d.root, "changer.yaml"), "w") as f:
            f.write(INPLANE_RIG.replace("name: inplane", "name: changer")
                    + "sample_changer: true\n")
        c = self.d.connect()
        r = c.request("capture", plan="ds3", rig="changer.yaml", name="z")
        self.assertEqual((r["class"], r["code"]), ("ERROR", "bad-value"), r)
        self.assertIn(self.d.config, r["message"])
        self.assertIn("driver.slaves.sample_changer is 0", r["message"])
        self.assertIn("has a sample changer", r["message"])
        self.assertFalse(os.path.exists(os.path.join(self.d.root, "z")))

    def test_out_of_plane_plan_refused_on_inplane_rig(self):
        c = self.d.connect()
        r = c.request("capture", plan="oop.yaml", name="y")
        self.assertEqual(r["class"], "ERROR", r)
        self.assertIn("needs an out-of-plane axis", r["message"])
        self.assertFalse(os.path.exists(os.path.join(self.d.root, "y")))


class OutOfPlaneTests(test_goniod_modbus.ModbusRig):
    """An out-of-plane plan on the Modbus rig with its azimuth drive:
    every sample's recorded phi_o within the in-position band of the plan;
    a resume on a configuration that lost the drive is refused."""

    def test_out_of_plane_capture_and_resume_refused(self):
        self.d = Daemon(self.folder, driver=self.tcp_driver(self.SIM_SCALE))
        os.makedirs(self.d.root)
        with open(os.path.join(self.d.root, "oop.yaml"), "w") as f:
            f.write(OOP_PLAN)
        self.d.start()
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("capture", plan="oop.yaml", name="oop")["class"], "OK")
        stop = c.until_stop("oop")[-1]
        self.assertEqual(stop["reason"], "complete", stop)
        band = float(DEFAULT_RIG.split("in_position_deg:")[1].split()[0])
        phi = samples_phi(os.path.join(self.d.root, "oop", "samples.csv"))
        self.assertEqual(sorted(phi), sorted(OOP_PHI_O))
        for p, want in OOP_PHI_O.items():
            self.assertLessEqual(abs(phi[p] - want), band + 1e-9, (p, phi[p], want))
        # The same daemon's config without the azimuth drive: the capture
        # (rig default, out of plane) is refused at resume, before it runs.
        self.d.stop()
        with open(self.d.config) as f:
            text = f.read()
        with open(self.d.config, "w") as f:
            f.write(text.replace(", azimuth: 4", "").replace("rig: default",
                                                            "rig: inplane.yaml"))
        with open(os.path.join(self.folder, "inplane.yaml"), "w") as f:
            f.write(INPLANE_RIG)
        self.d.start()
        r = self.d.connect().request("resume", capture_id="oop")
        self.assertEqual(r["class"], "ERROR", r)
        self.assertIn("driver.slaves.azimuth is 0", r["message"])


class ProbeTests(test_goniod_modbus.ModbusRig):
    """goniod --check --probe against gonio-sim over its pty and TCP: a line
    per device saying what it answered, exit 2 naming the first that did
    not (a wrong slave id, a port nothing listens on)."""

    def probe(self, driver):
        path = os.path.join(self.folder, "probe.yaml")
        with open(path, "w") as f:
            f.write("rig: default\ndriver:\n%scapture_root: cap\nsocket:\n  path: p.sock\n"
                    % driver)
        return run_wrapped([GONIOD, "--config", path, "--check", "--probe"], self.folder,
                           timeout=60)

    def driver(self, rtu, slaves="sample: 1, arm: 2, detector: 3, azimuth: 4", port=None):
        where = ("  kind: modbus-rtu\n  device: %s\n" % self.pty if rtu else
                 "  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %d\n" % (port or self.port))
        return where + ("  time_scale: %g\n  timeout_s: %g\n  retries: 1\n  slaves: {%s}\n"
                        % (self.SIM_SCALE, 0.1 * SLOW, slaves))

    def test_every_device_answers(self):
        for rtu in (False, True):
            r = self.probe(self.driver(rtu))
            self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
            lines = [l for l in r.stdout.splitlines() if l.startswith("# probe: ")]
            self.assertEqual(len(lines), 4, r.stdout)
            for who in ("axis sample (slave 1)", "axis arm (slave 2)",
                        "axis azimuth (slave 4)"):
                line = [l for l in lines if who in l]
                self.assertEqual(len(line), 1, (who, lines))
                self.assertIn("answered: at 0.00 deg, READY, alarm none", line[0])
            self.assertIn("answered: 3 channels", [l for l in lines if "detector" in l][0])

    def test_wrong_slave_and_port(self):
        r = self.probe(self.driver(False, "sample: 1, arm: 2, detector: 3, azimuth: 9"))
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertIn("goniod: probe: axis azimuth (slave 9)", r.stderr)
        self.assertRegex(r.stdout, r"# probe: axis arm \(slave 2\) +answered")
        self.assertRegex(r.stdout, r"# probe: detector \(slave 3\) +answered: 3 channels")
        # The detector's slave id given to an axis drive: not a detector.
        r = self.probe(self.driver(True, "sample: 1, arm: 2, detector: 4, azimuth: 3"))
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertIn("goniod: probe: axis azimuth (slave 3)", r.stderr)
        self.assertRegex(r.stdout, r"# probe: detector \(slave 4\) +did not answer")
        # A port nothing listens on: the first device names it.
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        free = s.getsockname()[1]
        s.close()
        r = self.probe(self.driver(False, port=free))
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertIn("goniod: probe: ", r.stderr)
        self.assertIn(str(free), r.stderr)


def axes_by_name(reply):
    return {a["axis"]: a for a in reply["axes"]}


class BringupTests(test_goniod_modbus.ModbusRig):
    """gonio home, move, where, limits through goniod on gonio-sim's drives
    (TCP): positions within the in-position band, soft limits refused by
    name, and refusals while a capture runs."""
    BAND = float(DEFAULT_RIG.split("in_position_deg:")[1].split()[0])

    def start(self):
        self.d = Daemon(self.folder, driver=self.tcp_driver(self.SIM_SCALE)).start()
        return self.d.connect()

    def test_move_where_limits_home(self):
        c = self.start()
        r = c.request("where")
        self.assertEqual(r["class"], "OK", r)
        ax = axes_by_name(r)
        self.assertEqual(sorted(ax), ["arm", "azimuth", "sample"])
        self.assertEqual([ax[n]["slave"] for n in ("sample", "arm", "azimuth")], [1, 2, 4])
        for a in ax.values():
            self.assertEqual((a["position_deg"], a["ready"], a["alarm"]), (0, True, 0), a)
        r = c.request("move", axis="arm", deg=140)
        self.assertEqual(r["class"], "OK", r)
        self.assertLessEqual(abs(axes_by_name(r)["arm"]["position_deg"] - 140), self.BAND)
        self.assertLessEqual(abs(axes_by_name(c.request("where"))["arm"]["position_deg"] - 140),
                             self.BAND)
        # Beyond a soft limit: refused before anything moves, naming it.
        r = c.request("move", axis="arm", deg=175)
        self.assertEqual((r["class"], r["code"]), ("ERROR", "bad-value"), r)
        self.assertIn("axes.arm.max 170 deg of rig profile 'default'", r["message"])
        r = c.request("move", axis="sample", deg=-91)
        self.assertIn("axes.sample.min -90 deg", r["message"])
        # limits: each soft limit reached, and back where it started.
        r = c.request("limits", axis="sample")
        self.assertEqual(r["class"], "OK", r)
        lim = r["limits"]
        self.assertLessEqual(abs(lim["reached_min_deg"] + 90), self.BAND, lim)
        self.assertLessEqual(abs(lim["reached_max_deg"] - 90), self.BAND, lim)
        self.assertLessEqual(abs(lim["back_at_deg"]), self.BAND, lim)
        # home: every axis at 0 with HOME-END.
        r = c.request("home")
        self.assertEqual(r["class"], "OK", r)
        for a in r["axes"]:
            self.assertEqual((a["position_deg"], a["home_end"]), (0, True), a)
        # The CLI prints the table, and refuses a limit with exit 2.
        g = self.d.gonio("move", "azimuth", "-45")
        self.assertEqual(g.returncode, 0, g.stderr)
        row = [l for l in g.stdout.splitlines() if l.startswith("azimuth")][0]
        self.assertLessEqual(abs(float(row.split()[2]) + 45), self.BAND, row)
        g = self.d.gonio("move", "azimuth", "181")
        self.assertEqual(g.returncode, 2, g.stdout + g.stderr)
        self.assertIn("axes.azimuth.max 180 deg", g.stderr)

    def test_capture_refused_outside_the_limits(self):
        """An arm left at 160 deg (an earlier profile allowed it) and a rig
        profile limiting it to 150 (DS3 reaches 140): the capture fails before any move,
        saying where the arm is and what to do; after gonio home it runs."""
        c = self.start()
        self.assertEqual(c.request("move", axis="arm", deg=160)["class"], "OK")
        self.d.stop()
        with open(os.path.join(self.folder, "arm150.yaml"), "w") as f:
            f.write(DEFAULT_RIG.replace("min: -170, max: 170", "min: -150, max: 150")
                    .replace("name: default", "name: arm150"))
        with open(self.d.config) as f:
            text = f.read()
        with open(self.d.config, "w") as f:
            f.write(text.replace("rig: default", "rig: arm150.yaml"))
        self.d.start()
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("capture", plan="ds3", name="far")["class"], "OK")
        stop = c.until_stop("far")[-1]
        self.assertEqual(stop["exit_status"], "fail", stop)
        self.assertIn("axis arm is at 160.00 deg, outside rig profile 'arm150''s limits "
                      "axes.arm -150..150 deg", stop["message"])
        self.assertIn("gonio home arm", stop["message"])
        self.assertEqual(c.request("home", axis="arm")["class"], "OK")
        self.assertEqual(c.request("capture", plan="ds3", name="near")["class"], "OK")
        self.assertEqual(c.until_stop("near")[-1]["reason"], "complete")

    def test_refused_while_a_capture_runs(self):
        c = self.start()
        self.assertEqual(c.request("capture", plan="ds3", name="busy")["class"], "OK")
        for cmd, args in (("move", {"axis": "arm", "deg": 10}), ("home", {}), ("where", {}),
                          ("limits", {"axis": "arm"})):
            r = c.request(cmd, **args)
            self.assertEqual((r["class"], r["code"]), ("ERROR", "busy"), r)
            self.assertIn("capture 'busy' is running", r["message"])
        c.request("abort")


class BringupSlowTests(test_goniod_modbus.ModbusRig):
    """A limits run long enough to watch (gonio-sim at 20 x): the socket
    serves other clients meanwhile, and refuses a capture and another
    bring-up command by name."""
    SIM_SCALE = 20

    def test_socket_served_while_limits_runs(self):
        self.d = Daemon(self.folder, driver=self.tcp_driver(self.SIM_SCALE)).start()
        c = self.d.connect()
        # 360 deg at a quarter of 20 deg/s: 72 s of rig time, 3.6 s here.
        c.send(dict(cmd="limits", axis="sample", id="lim"))
        other = self.d.connect()
        st = other.request("status")
        self.assertEqual(st["bringup"], "limits sample", st)
        r = other.request("capture", plan="ds3", name="x")
        self.assertEqual((r["class"], r["code"]), ("ERROR", "busy"), r)
        # goniod's own check before the capture is prepared (the worker
        # would refuse it too, after creating and removing its directory).
        self.assertTrue(r["message"].startswith("capture: bring-up 'limits sample' is "
                                                "running"), r)
        r = other.request("move", axis="arm", deg=5)
        self.assertEqual((r["class"], r["code"]), ("ERROR", "busy"), r)
        self.assertFalse(os.path.exists(os.path.join(self.d.root, "x")))
        r = c.read()
        self.assertEqual((r["class"], r["id"]), ("OK", "lim"), r)
        self.assertIsNone(other.request("status")["bringup"])


class BringupAbortTests(test_goniod_modbus.ModbusRig):
    """gonio abort ends a limits run (gonio-sim at 5 x: 360 deg at 5 deg/s
    of rig time take 14 s here): the axis stops where it is, gonio limits
    says aborted with that table and exits 1."""
    SIM_SCALE = 5

    def test_abort_stops_limits(self):
        self.d = Daemon(self.folder, driver=self.tcp_driver(self.SIM_SCALE)).start()
        c = self.d.connect()
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        lim = subprocess.Popen([GONIO, "limits", "sample"], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=env,
                               preexec_fn=child_procs.die_with_parent)
        self.addCleanup(lim.kill)
        deadline = time.time() + START_S
        while c.request("status")["bringup"] != "limits sample":
            self.assertLess(time.time(), deadline, "the limits run never started")
            time.sleep(0.05)
        time.sleep(0.3)  # the sample is on its way to -90
        ab = self.d.gonio("abort")
        self.assertEqual(ab.returncode, 0, ab.stderr)
        self.assertIn("abort bring-up 'limits sample'", ab.stdout)
        out, err = lim.communicate(timeout=2 * START_S)
        self.assertEqual(lim.returncode, 1, out + err)
        self.assertIn("limits sample: aborted; the axes stopped where they stand", err)
        row = [l for l in out.splitlines() if l.startswith("sample")][0]
        self.assertNotIn("MOVE", row)
        # Stopped, not still running its move to a limit: two readings apart
        # agree, short of both limits.
        first = axes_by_name(c.request("where"))["sample"]
        time.sleep(0.5)
        second = axes_by_name(c.request("where"))["sample"]
        self.assertFalse(first["moving"], first)
        self.assertEqual(first["position_deg"], second["position_deg"])
        self.assertLess(abs(first["position_deg"]), 85, first)
        self.assertAlmostEqual(float(row.split()[2]), first["position_deg"], delta=0.01)
        # Nothing runs now: abort is refused as before.
        r = c.request("abort")
        self.assertEqual((r["class"], r["code"]), ("ERROR", "not-running"), r)


class BringupInterruptTests(test_goniod_modbus.ModbusRig):
    """Ctrl-C on gonio limits or move (gonio-sim at 5 x): gonio sends goniod
    abort, waits for the reply, prints where the axes stopped and exits
    130; the axis stands there, short of where it was going (closing the
    connection alone left goniod driving it)."""
    SIM_SCALE = 5

    def interrupt(self, args, what):
        c = self.d.connect()
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        p = subprocess.Popen([GONIO, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, env=env, preexec_fn=child_procs.die_with_parent)
        self.addCleanup(p.kill)
        deadline = time.time() + START_S
        while c.request("status")["bringup"] != what:
            self.assertLess(time.time(), deadline, "%s never started" % what)
            time.sleep(0.05)
        time.sleep(0.3)  # on its way
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=2 * START_S)
        self.assertEqual(p.returncode, 130, out + err)
        self.assertIn("gonio %s: SIGINT: asking goniod to abort" % args[0], err)
        self.assertIn("%s: aborted; the axes stopped where they stand" % what, err)
        row = [l for l in out.splitlines() if l.startswith(args[1])][0]
        self.assertNotIn("MOVE", row)
        # Stopped: two readings apart agree, and say what the table said.
        first = axes_by_name(c.request("where"))[args[1]]
        time.sleep(0.5)
        second = axes_by_name(c.request("where"))[args[1]]
        self.assertFalse(first["moving"], first)
        self.assertEqual(first["position_deg"], second["position_deg"])
        self.assertAlmostEqual(float(row.split()[2]), first["position_deg"], delta=0.01)
        self.assertIsNone(c.request("status")["bringup"])
        return first["position_deg"]

    def test_ctrl_c_stops_limits_and_move(self):
        self.d = Daemon(self.folder, driver=self.tcp_driver(self.SIM_SCALE)).start()
        at = self.interrupt(["limits", "sample"], "limits sample")
        self.assertLess(abs(at), 85)
        # 160 deg at 15 deg/s of rig time: 2 s here
        at = self.interrupt(["move", "arm", "160"], "move arm")
        self.assertGreater(at, 0)
        self.assertLess(at, 150)


class BringupSimTests(unittest.TestCase):
    """The in-process rig has no drives: bring-up is refused, saying so."""

    def test_sim_driver_refuses(self):
        folder = tmpdir()
        d = Daemon(folder).start()
        try:
            r = d.connect().request("where")
            self.assertEqual((r["class"], r["code"]), ("ERROR", "bad-value"), r)
            self.assertIn("driver 'sim' has no drives", r["message"])
        finally:
            d.stop()
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    unittest.main()
