#!/usr/bin/python3
"""gonio calibrate through goniod over Modbus TCP, as an operator runs it on
a rig: gonio-sim serves the raw lab scene (lab, counts) on the simulated
clock, with the standard mounted (--material standard:spectralon-99) for the
dark and the reference and the sample mounted for the capture (gonio-sim
started again: the operator swapped what sits in the sample's place).

- dark and reference through goniod, then a capture through goniod with
  --calibration newest: its BRDF is the material's (median |measured/true-1|
  at most 0.5 % over the values with SNR >= 100, as tests/unit/capture/
  test_chain.c holds the offline chain);
- the operator's pause: a reference waits for the standard to be mounted, a
  dark on a rig profile without a shutter for the detector to be covered;
  status says what to do and gonio resume continues;
- goniod killed (SIGKILL) mid-calibration: nothing measured is lost and
  gonio resume ID finishes it, its frames those of a calibration that ran
  through;
- requests refused with exit 2 naming the field, nothing created.
"""
import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import child_procs  # noqa: E402
import gonio_cal  # noqa: E402
from goniod_harness import (BIN, GONIO, SLOW, START_S, TESTS_BIN, VALGRIND, Daemon,
                            assert_valgrind_clean, tmpdir, wrap)

SIM = os.path.join(BIN, "gonio-sim")
MATERIAL_VALUES = os.path.join(TESTS_BIN, "material_values")
CONFIG = os.environ.get("GONIO_CONFIG", "configs")
STANDARD = "standard:spectralon-99"
SAMPLE = "analytic:rough-diffuse"
GAIN_ADU_PER_E = 0.8  # lab's ADC (configs/scenes/lab.yaml)


def rig_profile(folder, name, integration, shutter=True):
    """The default rig profile under another name and integration (0.25 s:
    a diffuse sample reads at SNR > 100 on lab), with or without a
    shutter."""
    with open(os.path.join(CONFIG, "rigs", "default.yaml")) as f:
        text = f.read()
    text = text.replace("fixed_s: 0.05", "fixed_s: %g" % integration)
    text = text.replace("name: default", "name: %s" % name)
    if not shutter:
        text += "shutter: false\n"
    path = os.path.join(folder, "%s.yaml" % name)
    with open(path, "w") as f:
        f.write(text)
    return path


def journal_lines(path):
    with open(path) as f:
        return f.read().count("\n")


def frames(path):
    with open(path) as f:
        return list(csv.DictReader(f))


class CalibrateRig(unittest.TestCase):
    """gonio-sim (lab, simulated clock) on a TCP port that survives its
    restarts, and goniod on it with the lab rig profile."""

    def setUp(self):
        if not os.path.exists(SIM):
            self.skipTest("gonio-sim not built")
        self.folder = tmpdir()
        self.port = None
        self.sim = None
        self.start_sim(STANDARD)
        self.rig = rig_profile(self.folder, "lab", 0.25)
        self.d = None

    def tearDown(self):
        try:
            if self.d:
                self.d.stop()
            self.assertEqual(self.stop_sim(), 0, "gonio-sim's exit status on SIGTERM")
            assert_valgrind_clean(self.folder)
        finally:
            if os.environ.get("GONIO_KEEP"):
                sys.stderr.write("kept %s\n" % self.folder)
            else:
                shutil.rmtree(self.folder, ignore_errors=True)

    def start_sim(self, material, time_scale=None):
        """gonio-sim measuring material: what is mounted in the sample's place;
        on its simulated clock, or on wall time at time_scale."""
        self.launch_sim(["--scene", "lab", "--material", material] +
                        (["--time-scale", str(time_scale)] if time_scale
                         else ["--clock", "simulated"]))

    def launch_sim(self, args):
        """gonio-sim with args on TCP, on the port of the one before it (a
        fresh one the first time), as an operator swaps what is mounted."""
        self.stop_sim()
        out_path = os.path.join(self.folder, "sim.out")
        open(out_path, "w").close()
        self.sim = subprocess.Popen(
            wrap([SIM] + args + ["--tcp", "127.0.0.1:%d" % (self.port or 0)], self.folder),
            stdout=open(out_path, "w"), stderr=open(os.path.join(self.folder, "sim.err"), "a"),
            preexec_fn=child_procs.die_with_parent)
        deadline = time.time() + START_S
        text = ""
        while time.time() < deadline and "tcp" not in text:
            time.sleep(0.05)
            text = open(out_path).read()
        self.assertIn("tcp", text, open(os.path.join(self.folder, "sim.err")).read())
        self.port = int(text.splitlines()[1].rsplit(":", 1)[1])

    def stop_sim(self):
        if not self.sim:
            return 0
        if self.sim.poll() is None:
            self.sim.terminate()
        rc = self.sim.wait(timeout=2 * START_S)
        self.sim = None
        return rc

    def start_daemon(self, rig=None, time_scale=1):
        driver = ("  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %d\n  timeout_s: %g\n"
                  "  time_scale: %d\n  slaves: {sample: 1, arm: 2, detector: 3, azimuth: 4}\n"
                  % (self.port, 0.5 * SLOW, time_scale))
        self.d = Daemon(self.folder, driver=driver)
        text = open(self.d.config).read().replace("rig: default", "rig: %s" % (rig or self.rig))
        with open(self.d.config, "w") as f:
            f.write(text)
        self.d.start()
        self.cal_root = os.path.join(self.folder, "calibrations")
        return self.d

    def status(self):
        c = self.d.connect()
        st = c.request("status")
        c.close()
        self.d.conns.remove(c)
        return st

    def wait_state(self, state, what):
        """status until goniod is in state (the operator's pause); the
        status document."""
        deadline = time.time() + 2 * START_S
        while time.time() < deadline:
            st = self.status()
            if st["state"] == state:
                return st
            time.sleep(0.05)
        raise AssertionError("goniod never %s (%s): %r" % (state, what, st))

    def calibrate(self, *args, operator=None):
        """gonio calibrate ARGS through goniod; operator(status) runs at
        goniod's pause, then gonio resume. Returns the finished command."""
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        p = subprocess.Popen([GONIO, "calibrate", *args], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=env,
                             preexec_fn=child_procs.die_with_parent)
        if operator:
            st = self.wait_state("paused", "asking the operator")
            operator(st)
            r = self.d.gonio("resume")
            self.assertEqual(r.returncode, 0, r.stderr)
        out, err = p.communicate(timeout=30 * START_S)  # a hang, not a slow or sanitized host
        return subprocess.CompletedProcess(p.args, p.returncode, out, err)

    def mount_standard(self, st):
        self.assertIn("mount the standard 'spectralon-99'", st["capture"]["message"])
        self.assertEqual(st["capture"]["kind"], "reference")

    def remove_sample(self, st):
        """The stray light's pause: the operator has put a light trap in
        the sample's place (gonio-sim started with the material trap)."""
        self.assertEqual(st["capture"]["kind"], "stray")
        self.assertIn("stray light: remove the sample (a light trap in its place)",
                      st["capture"]["message"])
        out = self.d.gonio("status").stdout
        self.assertIn("stray calibration %s: paused" % st["capture_id"], out)

    def dark_and_reference(self):
        d = self.calibrate("dark")
        self.assertEqual(d.returncode, 0, d.stderr)
        r = self.calibrate("reference", "--plan", "ds3", "--repeats", "2",
                           operator=self.mount_standard)
        self.assertEqual(r.returncode, 0, r.stderr)
        return d.stdout.strip(), r.stdout.strip()


class CalibrateTests(CalibrateRig):

    def test_calibrated_capture_through_goniod(self):
        self.start_daemon()
        dark_id, ref_id = self.dark_and_reference()
        dark = json.load(open(os.path.join(self.cal_root, dark_id, "calibration.json")))
        ref = json.load(open(os.path.join(self.cal_root, ref_id, "calibration.json")))
        self.assertEqual((dark["kind"], dark["rig"], dark["detector"]), ("dark", "lab", "modbus"))
        self.assertEqual((ref["kind"], ref["dark"], ref["frames"]), ("reference", dark_id, 104))
        dark_rows = frames(os.path.join(self.cal_root, dark_id, "frames.csv"))
        self.assertEqual(len(dark_rows), 16)
        # The shutter closed: offset and dark only, far below the lit standard.
        self.assertLess(max(float(x["g"]) for x in dark_rows), 1500)
        ref_rows = frames(os.path.join(self.cal_root, ref_id, "frames.csv"))
        self.assertGreater(min(float(x["g"]) for x in ref_rows), 3000)

        # The operator mounts the sample (gonio-sim measures it from now on).
        self.start_sim(SAMPLE)
        r = self.d.gonio("capture", "--plan", "ds3", "--name", "cap", "--calibration", "newest",
                         "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr + r.stdout)
        capdir = os.path.join(self.d.root, "cap")
        self.assertEqual(json.load(open(os.path.join(capdir, "setup.json")))["calibration"],
                         ref_id)
        rows = [x for x in frames(os.path.join(capdir, "samples.csv"))
                if not int(x["flags"]) & 2]
        self.assertEqual(len(rows), 52)
        med, n = self.median_error(rows, dark_rows, SAMPLE)
        self.assertGreaterEqual(n, 100)
        self.assertLessEqual(med, 0.005)

    def median_error(self, rows, dark_rows, material):
        """median |measured/true - 1| over the values of rows with SNR >= 100,
        and how many: the truth at each point by brdf/material.h alone; the
        SNR from the counts, the signal over the dark of its integration
        against its shot noise (the scene's ADC gain) and the dark frames'
        spread."""
        pairs = "".join("%s %s\n" % (x["theta_i"], x["theta_r"]) for x in rows)
        truth = subprocess.run([MATERIAL_VALUES, material], input=pairs, capture_output=True,
                               text=True, check=True).stdout.split("\n")
        errors = []
        for k, x in enumerate(rows):
            t = float(x["integration_s"])
            dark_g = [float(d["g"]) for d in dark_rows
                      if abs(float(d["integration_s"]) - t) < 1e-6 * t]
            self.assertGreater(len(dark_g), 1, "no dark at %g s" % t)
            want = [float(v) for v in truth[k].split()]
            for ch, name in enumerate("rgb"):
                signal = float(x["raw_" + name]) - statistics.mean(dark_g)
                noise = (GAIN_ADU_PER_E * signal + statistics.pstdev(dark_g) ** 2) ** 0.5
                if signal / noise >= 100:
                    errors.append(abs(float(x[name]) / want[ch] - 1))
        med = statistics.median(errors)
        sys.stderr.write("%s through goniod: median |measured/true - 1| %.3f %% over %d "
                         "values with SNR >= 100\n" % (material, 100 * med, len(errors)))
        return med, len(errors)

    def test_glossy_and_metal_ranged_through_goniod(self):
        """A dark over the ladder lets the calibrated captures range over
        Modbus: a glossy plastic's and a metal's peaks are read short, not
        clipped, and reduce as the diffuse sample does."""
        self.start_daemon()
        d = self.calibrate("dark", "--ladder")
        self.assertEqual(d.returncode, 0, d.stderr)
        dark_rows = frames(os.path.join(self.cal_root, d.stdout.strip(), "frames.csv"))
        self.assertEqual(len({x["integration_s"] for x in dark_rows}), 7)  # the ladder's rungs
        r = self.calibrate("reference", "--plan", "ds3", "--repeats", "8",
                           operator=self.mount_standard)
        self.assertEqual(r.returncode, 0, r.stderr)
        for name, material in (("glossy", "builtin:red-plastic"),
                               ("metal", "builtin:gold-metallic-paint")):
            self.start_sim(material)
            c = self.d.gonio("capture", "--plan", "ds3", "--name", name, "--calibration",
                             "newest", "--wait", "--quiet")
            self.assertEqual(c.returncode, 0, c.stderr + c.stdout)
            rows = [x for x in frames(os.path.join(self.d.root, name, "samples.csv"))
                    if not int(x["flags"]) & 2]
            self.assertEqual(len(rows), 52)
            clipped = [(x["point"], x["integration_s"]) for x in rows if int(x["flags"]) & 1]
            self.assertEqual(clipped, [], name)
            if name == "metal":  # its peak clips at the rig's 0.25 s: read shorter
                self.assertLess(min(float(x["integration_s"]) for x in rows), 0.25)
            med, n = self.median_error(rows, dark_rows, material)
            self.assertGreaterEqual(n, 50, name)
            # DS3's few values make a noisy median: the metal's 0.57 % is
            # the lab's stray light on its dim values and noise (DS1 below
            # and docs/radiometry.md hold it to 0.5 %)
            self.assertLessEqual(med, 0.005 if name == "glossy" else 0.0075, name)


class CalibrateDS1Tests(CalibrateRig):
    """The three materials on DS1 through goniod over Modbus TCP, the
    whole chain with its stray-light step, each median against the
    material alone held to 0.5 %."""

    def test_three_materials_ds1(self):
        """A dark over the ladder, the stray light (the sample removed: a
        light trap in its place) and a reference naming it on the shipped
        5-degree grid (8 repeats; DS1's points between its geometries
        interpolated), then a diffuse, a glossy and a metal sample on DS1
        (912 points), ranged: each recovers the material's BRDF alone to a
        median |measured/true - 1| of at most 0.5 %
        (gonio_cal.DS1_STRAY_LIMIT; the glossy one, at its counting floor,
        0.55 %: gonio_cal.DS1_LIMIT) over its values with SNR >= 100. The
        same capture reduced again with the stray light not subtracted is
        further off the material alone, and measures the material plus
        the lab's stray light (within
        gonio_cal.DS1_LIMIT of gonio_cal.chain_errors' chain truth), and
        the metal's dim values, which that light lifts, take it beyond
        0.5 % against the material alone; reduced again without the stray
        light and without the dark, or with the standard as Lambertian,
        each is measurably worse than that;
        with its own calibration, it is the capture byte for byte."""
        if VALGRIND:
            self.skipTest("DS1's 912 points x 3 and 8000 stray and reference readings take "
                          "about a minute natively and too long under memcheck; the DS3 "
                          "groups (goniod_Calibrate, goniod_CalibrateStray) run the same "
                          "code there")
        self.start_daemon()
        d = self.calibrate("dark", "--ladder")
        self.assertEqual(d.returncode, 0, d.stderr)
        dark_rows = frames(os.path.join(self.cal_root, d.stdout.strip(), "frames.csv"))
        grid = ("--plan", "reference-grid", "--repeats", "8")
        self.start_sim("trap")  # the operator removes the sample
        s = self.calibrate("stray", *grid, operator=self.remove_sample)
        self.assertEqual(s.returncode, 0, s.stderr)
        self.start_sim(STANDARD)
        r = self.calibrate("reference", *grid, "--stray", "newest", operator=self.mount_standard)
        self.assertEqual(r.returncode, 0, r.stderr)
        ref_id = r.stdout.strip()
        with open(os.path.join(self.cal_root, ref_id, "calibration.json")) as f:
            self.assertEqual(json.load(f)["stray"], s.stdout.strip())
        plain = gonio_cal.without_stray(self.cal_root, ref_id,
                                        os.path.join(self.folder, "nostray"))
        # Less a step, of the chain without the stray light: a stray
        # reading holds the dark too, so with it a missing dark is half made up.
        less = gonio_cal.without_a_step(plain, ref_id, os.path.join(self.folder, "less"))
        got = {}
        for name, material in (("diffuse", SAMPLE), ("glossy", "builtin:red-plastic"),
                               ("metal", "builtin:gold-metallic-paint")):
            self.start_sim(material)
            c = self.d.gonio("capture", "--plan", "ds1", "--name", name, "--calibration",
                             "newest", "--wait", "--quiet")
            self.assertEqual(c.returncode, 0, c.stderr + c.stdout)
            capdir = os.path.join(self.d.root, name)
            rows = frames(os.path.join(capdir, "samples.csv"))
            kept = [x for x in rows if not int(x["flags"]) & 2]
            self.assertEqual(len(kept), 912, name)
            self.assertEqual([x["point"] for x in kept if int(x["flags"]) & 1], [], name)
            e = gonio_cal.chain_errors(kept, dark_rows, material)
            ns = gonio_cal.recalibrated_chain_errors(capdir, ref_id, plain, dark_rows, material,
                                                     os.path.join(self.folder, name + "-ns"))
            sys.stderr.write("%s DS1 through goniod, stray light subtracted: median "
                             "|measured/true - 1| %.3f %% against the material alone over %d "
                             "values with SNR >= 100; not subtracted %.3f %% (the chain's "
                             "truth %.3f %%)\n" % (material, 100 * e["material"], e["n"],
                                                   100 * ns["material"], 100 * ns["chain"]))
            self.assertGreaterEqual(e["n"], 1000, name)
            # the glossy plastic at its counting floor, 0.50 %: 0.55 % (gonio_cal.DS1_LIMIT)
            self.assertLessEqual(e["material"], max(gonio_cal.DS1_STRAY_LIMIT,
                                                    gonio_cal.DS1_LIMIT[name]), name)
            self.assertLess(e["material"], ns["material"], name)
            self.assertLessEqual(ns["chain"], gonio_cal.DS1_LIMIT[name], name)
            got[name] = (e["material"], ns["material"])
            # Reduced again with its own calibration: the capture's samples
            # and model, byte for byte (its ranging's dark frames included).
            again = os.path.join(self.folder, name)
            rc = subprocess.run([GONIO, "recalibrate", capdir, "--calibration", ref_id,
                                 "--calibrations", self.cal_root, "-o", again],
                                capture_output=True, text=True, timeout=300)
            self.assertEqual(rc.returncode, 0, rc.stderr)
            for f in ("samples.csv", "abc.model"):
                with open(os.path.join(capdir, f), "rb") as a, \
                        open(os.path.join(again, f), "rb") as b:
                    self.assertEqual(a.read(), b.read(), (name, f))
            # Each step is needed: the same capture reduced again without
            # the dark, or with the standard as Lambertian, is worse.
            worse = gonio_cal.recalibrated_errors(capdir, ref_id, less, dark_rows, material,
                                                  self.folder)
            sys.stderr.write("  without dark %.3f %%, standard as Lambertian %.3f %%\n"
                             % (100 * worse["nodark"], 100 * worse["lambertian"]))
            for kind, med in worse.items():
                self.assertGreaterEqual(med, 2 * ns["chain"], (name, kind))
                self.assertGreater(med, 0.01, (name, kind))
        with_stray, without = got["metal"]
        self.assertGreater(without, gonio_cal.DS1_STRAY_LIMIT, got)
        self.assertGreater(without, with_stray + 0.0003, got)

    def test_operator_covers_a_detector_without_shutter(self):
        self.d = None
        self.start_daemon(rig_profile(self.folder, "lab", 0.25, shutter=False))
        # Aborted while it waits on the operator: nothing read, the
        # directory kept; gonio resume ID asks again.
        c = self.d.connect()
        c.request("watch")
        r = c.request("calibrate", kind="dark", frames=4, name="dark-cut")
        self.assertEqual(r["class"], "OK", r)
        st = self.wait_state("paused", "asking to cover the detector")
        self.assertEqual(st["capture_id"], "dark-cut")
        r = self.d.gonio("abort")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("gonio resume dark-cut", r.stdout)
        stop = c.until_stop("dark-cut")[-1]
        self.assertEqual((stop["exit_status"], stop["reason"]), ("abort", "aborted"), stop)
        self.assertEqual(stop["calibration"]["frames"], 0)
        self.assertEqual(c.request("resume", capture_id="dark-cut")["class"], "OK")
        self.wait_state("paused", "asking again")
        self.assertEqual(c.request("resume")["class"], "OK")
        stop = c.until_stop("dark-cut")[-1]
        self.assertEqual(stop["exit_status"], "success", stop)
        self.assertEqual(len(frames(os.path.join(self.cal_root, "dark-cut", "frames.csv"))), 4)

        def cover(st):
            self.assertEqual(st["capture"]["kind"], "dark")
            self.assertIn("rig 'lab' has no shutter: cover the detector",
                          st["capture"]["message"])
            self.assertEqual(st["points_done"], 0, "nothing read before the operator acted")
            out = self.d.gonio("status").stdout
            self.assertIn("goniod paused: calibration %s, 0/4 frames" % st["capture_id"], out)
            self.assertIn("dark calibration %s: paused" % st["capture_id"], out)
            self.assertIn("cover the detector (or turn the lamp off), then: gonio resume", out)
        d = self.calibrate("dark", "--frames", "4", operator=cover)
        self.assertEqual(d.returncode, 0, d.stderr)
        rows = frames(os.path.join(self.cal_root, d.stdout.strip(), "frames.csv"))
        self.assertEqual(len(rows), 4)
        # gonio-sim's shutter was never closed: the lit standard, read as the
        # "dark" (the operator's cover is the operator's).
        self.assertGreater(min(float(x["g"]) for x in rows), 3000)
        st = self.status()
        self.assertEqual((st["state"], st["capture"]["state"]), ("idle", "complete"))

    def test_on_goniods_simulated_rig(self):
        """The sim driver mounts the standard itself for a reference (the
        material standard:NAME), after the same pause."""
        self.d = Daemon(self.folder, scene="lab").start()
        self.cal_root = os.path.join(self.folder, "calibrations")
        _, ref_id = self.dark_and_reference()
        # The standard as the offline calibration on the same scene reads it.
        offline = os.path.join(self.folder, "offline")
        for kind in (["dark"], ["reference", "--plan", "ds3", "--repeats", "2"]):
            r = subprocess.run([GONIO, "calibrate", *kind, "--offline", "--scene", "lab",
                                "--out", offline], capture_output=True, text=True, timeout=60)
            self.assertEqual(r.returncode, 0, r.stderr)
        want = frames(os.path.join(offline, r.stdout.strip(), "frames.csv"))
        got = frames(os.path.join(self.cal_root, ref_id, "frames.csv"))
        self.assertEqual([(x["theta_i"], x["theta_r"]) for x in got],
                         [(x["theta_i"], x["theta_r"]) for x in want])
        for a, b in zip(got, want):
            self.assertLess(abs(float(a["g"]) / float(b["g"]) - 1), 0.05, (a, b))
        r = self.d.gonio("capture", "--plan", "ds3", "--name", "sim", "--calibration", ref_id,
                         "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr + r.stdout)
        capdir = os.path.join(self.d.root, "sim")
        self.assertEqual(json.load(open(os.path.join(capdir, "setup.json")))["calibration"],
                         ref_id)
        rows = [x for x in frames(os.path.join(capdir, "samples.csv"))
                if not int(x["flags"]) & 2]
        self.assertTrue(rows and all(float(x["u_g"]) > 0 for x in rows))

    def test_bad_requests_refused_naming_the_field(self):
        self.start_daemon()
        cases = [
            (["reference", "--plan", "ds3", "--standard", "no-such-plaque"],
             "standard 'no-such-plaque'"),
            (["reference", "--plan", "ds3"], "(run gonio calibrate dark, then reference)"),
            (["reference", "--plan", "no-such-plan"], "no-such-plan"),
            (["dark", "--rig", "no-such-rig"], "no-such-rig"),
            (["dark", "--name", "../x"], "field 'name' '../x'"),
        ]
        for args, needle in cases:
            r = self.calibrate(*args)
            self.assertEqual(r.returncode, 2, (args, r.stderr))
            self.assertIn(needle, r.stderr, args)
        self.assertFalse(os.path.exists(self.cal_root) and os.listdir(self.cal_root),
                         "a refused request created nothing")
        # A dark of one rig does not serve another's reference.
        d = self.calibrate("dark", "--frames", "2")
        self.assertEqual(d.returncode, 0, d.stderr)
        shutil.copy(self.rig, os.path.join(self.d.root, "bench.yaml"))
        text = open(os.path.join(self.d.root, "bench.yaml")).read()
        with open(os.path.join(self.d.root, "bench.yaml"), "w") as f:
            f.write(text.replace("name: lab", "name: bench"))
        r = self.calibrate("reference", "--plan", "ds3", "--rig", "bench.yaml", "--dark",
                           d.stdout.strip())
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("is of rig 'lab', the capture's rig is 'bench'", r.stderr)
        self.assertEqual(os.listdir(self.cal_root), [d.stdout.strip()])


class CalibrateCrashTests(CalibrateRig):
    """goniod killed mid-calibration, then gonio resume ID."""

    def test_kill9_mid_reference_then_resume(self):
        # On wall time (the reference's 104 readings of 0.25 s over about 3 s
        # at the scale), so that the kill lands mid-way on a loaded machine:
        # on the simulated clock a starved test could see the run end first.
        self.start_sim(STANDARD, time_scale=10)
        self.start_daemon(time_scale=10)
        dark_id, whole_id = self.dark_and_reference()
        whole = frames(os.path.join(self.cal_root, whole_id, "frames.csv"))
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        p = subprocess.Popen([GONIO, "calibrate", "reference", "--plan", "ds3", "--repeats",
                              "2", "--name", "ref-killed"], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=env,
                             preexec_fn=child_procs.die_with_parent)
        self.mount_standard(self.wait_state("paused", "asking for the standard"))
        journal = os.path.join(self.cal_root, "ref-killed", "journal.csv")
        self.assertEqual(self.d.gonio("resume").returncode, 0)
        deadline = time.time() + 4 * START_S
        while time.time() < deadline and journal_lines(journal) < 31:
            time.sleep(0.005)
        self.d.kill9()
        p.communicate(timeout=START_S)
        self.assertNotEqual(p.returncode, 0)
        with open(journal) as f:  # the whole lines: a kill mid-write tears the last
            text = f.read()
        before = text[:text.rfind("\n") + 1].splitlines()
        self.assertGreater(len(before), 30)
        self.assertLess(len(before), 105, "killed before the end")
        self.assertFalse(os.path.exists(os.path.join(self.cal_root, "ref-killed",
                                                     "calibration.json")))
        self.d.start()
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        c = self.d.connect()
        c.request("watch")
        self.assertEqual(c.request("resume", capture_id="ref-killed")["class"], "OK")
        st = self.wait_state("paused", "asking for the standard again")
        self.mount_standard(st)
        self.assertEqual(st["points_done"], len(before) - 1, "the journal's frames kept")
        self.assertEqual(self.d.gonio("resume").returncode, 0)
        stop = c.until_stop("ref-killed")[-1]
        self.assertEqual(stop["exit_status"], "success", stop)
        self.assertEqual(stop["calibration"]["frames"], 104)
        resumed = os.path.join(self.cal_root, "ref-killed")
        text = open(os.path.join(resumed, "frames.csv")).read().splitlines()
        # Nothing measured before the kill is lost or changed ...
        self.assertEqual(text[:len(before)], before)
        # ... and the calibration is the uninterrupted one's: the same frames
        # (kind, geometry, integration), the standard's readings alike.
        got = frames(os.path.join(resumed, "frames.csv"))
        key = ("kind", "theta_i", "theta_r", "integration_s", "gain_state")
        self.assertEqual([[x[k] for k in key] for x in got],
                         [[x[k] for k in key] for x in whole])
        for a, b in zip(got, whole):
            self.assertLess(abs(float(a["g"]) / float(b["g"]) - 1), 0.05, (a, b))
        meta = json.load(open(os.path.join(resumed, "calibration.json")))
        self.assertEqual((meta["id"], meta["dark"], meta["frames"]), ("ref-killed", dark_id, 104))
        r = self.d.gonio("resume", "ref-killed")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("is complete", r.stderr)


class CalibrateListTests(CalibrateRig):
    """The calibrations an operator finds (goniod's simulated rig, lab):
    gonio list names each one's kind, state, rig, detector and time, and
    the command that resumes one cut short; gonio status names the newest
    and its resume command."""

    def listed(self):
        r = self.d.gonio("list", "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout)
        return {e["id"]: e for e in doc["calibrations"]}, [e["id"] for e in doc["calibrations"]]

    def reference_waiting(self, name):
        """A reference started and paused on the operator (mount the
        standard); the watching connection."""
        c = self.d.connect()
        c.request("watch")
        r = c.request("calibrate", kind="reference", plan="ds3", repeats=2, name=name,
                      dark="dark-ok")
        self.assertEqual(r["class"], "OK", r)
        self.mount_standard(self.wait_state("paused", "asking for the standard"))
        return c

    def test_list_and_status_name_calibrations(self):
        self.d = Daemon(self.folder, scene="lab").start()
        self.cal_root = os.path.join(self.folder, "calibrations")
        for name, valid in (("dark-old", ["--valid", "0.01"]), ("dark-ok", [])):
            r = self.calibrate("dark", "--frames", "2", "--name", name, *valid)
            self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(self.cal_root, "dark-ok", "calibration.json")) as f:
            made = json.load(f)

        # Aborted while it waits on the operator; listed as paused before.
        c = self.reference_waiting("ref-ab")
        self.assertEqual(self.listed()[0]["ref-ab"]["state"], "paused")
        self.assertEqual(self.d.gonio("abort").returncode, 0)
        c.until_stop("ref-ab")
        # Interrupted: goniod killed while it waits, then started again.
        self.reference_waiting("ref-cut")
        self.d.kill9()
        self.d.conns = []
        self.d.start()
        while time.time() <= made["created_unix"] + 1:  # dark-old's 0.6 s have passed
            time.sleep(0.05)

        cals, order = self.listed()
        self.assertEqual(order, ["ref-cut", "ref-ab", "dark-ok", "dark-old"])
        for cid, kind, state, n in (("ref-cut", "reference", "interrupted", 0),
                                    ("ref-ab", "reference", "aborted", 0),
                                    ("dark-ok", "dark", "complete", 2),
                                    ("dark-old", "dark", "expired", 2)):
            e = cals[cid]
            self.assertEqual((e["kind"], e["state"], e["frames_done"]), (kind, state, n), e)
            # what it is of, before calibration.json says it too
            self.assertEqual((e["rig"], e["detector"]), (made["rig"], made["detector"]), e)
            self.assertRegex(e["created"], r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ$")
        self.assertEqual(cals["dark-ok"]["expires"], made["expires"])
        self.assertEqual(cals["ref-ab"]["reason"], "aborted")

        # The table, after the captures' (none here), with the resume commands.
        table = self.d.gonio("list").stdout.splitlines()
        head = table.index(next(x for x in table if x.startswith("CALIBRATION")))
        self.assertEqual([x.split()[:3] for x in table[head + 1:]],
                         [["ref-cut", "reference", "interrupted"],
                          ["resume", "it", "with:"],
                          ["ref-ab", "reference", "aborted"],
                          ["resume", "it", "with:"],
                          ["dark-ok", "dark", "complete"], ["dark-old", "dark", "expired"]])
        self.assertEqual(table[head + 2].strip(), "resume it with: gonio resume ref-cut")
        out = self.d.gonio("status").stdout
        self.assertIn("newest calibration ref-cut (reference): interrupted, 0 frames", out)
        self.assertIn("resume it with: gonio resume ref-cut", out)

        # Resumed, it completes, and says so everywhere.
        c = self.d.connect()
        c.request("watch")
        r = c.request("resume", capture_id="ref-cut")
        self.assertEqual(r["class"], "OK", r)
        self.mount_standard(self.wait_state("paused", "asking for the standard again"))
        self.assertEqual(self.d.gonio("resume").returncode, 0)
        self.assertEqual(c.until_stop("ref-cut")[-1]["exit_status"], "success")
        e = self.listed()[0]["ref-cut"]
        self.assertEqual((e["state"], e["frames_done"], e["frames_total"]), ("complete", 104, 104))
        out = self.d.gonio("status").stdout
        self.assertIn("newest calibration ref-cut (reference): complete, 104/104 frames", out)
        self.assertNotIn("gonio resume ref-cut", out)


if __name__ == "__main__":
    unittest.main()
