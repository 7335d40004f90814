#!/usr/bin/python3
"""goniod --check --probe against what a new rig gets wrong and only a
device can tell: an RTU line at another speed than the devices' (gonio-sim
--baud answers only a master at its own speed, as a device on a wire hears
framing errors otherwise), a detector without the shutter register that
the rig profile's dark frames close (gonio-sim --no-shutter), and a sample
changer the config declares (driver.slaves.sample_changer) that does not
answer (gonio-sim on a rig profile without one). Each exits 2 naming the
device; the matching setup answers (goniod_harness.py; gonio-sim
through test_goniod_modbus.ModbusRig).

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \
      python3 tests/daemon/test_goniod_probe.py -v
"""
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import GONIOD, SLOW, SOURCE, run_wrapped  # noqa: E402
import test_goniod_modbus  # noqa: E402  (ModbusRig)

with open(os.path.join(SOURCE, "configs", "rigs", "default.yaml")) as _f:
    DEFAULT_RIG = _f.read()
# The default rig whose detector has no shutter: dark frames wait for the
# operator instead, and nothing reads the shutter register.
NO_SHUTTER_RIG = (DEFAULT_RIG.replace("name: default", "name: noshutter")
                  .replace("out_of_plane: true", "out_of_plane: true\nshutter: false"))
assert "shutter: false" in NO_SHUTTER_RIG
SLAVES = "sample: 1, arm: 2, detector: 3, azimuth: 4"
DEVICES = ("axis sample (slave 1)", "axis arm (slave 2)", "axis azimuth (slave 4)",
           "detector (slave 3)")


# The default rig with a sample changer (slave 6).
CHANGER_RIG = DEFAULT_RIG.replace("name: default", "name: changer") + "sample_changer: true\n"
CHANGER = "sample changer (slave 6)"


class ProbeRig(test_goniod_modbus.ModbusRig):
    def probe(self, rtu, baud=115200, rig="default", slaves=SLAVES):
        where = ("  kind: modbus-rtu\n  device: %s\n  baud: %d\n" % (self.pty, baud) if rtu else
                 "  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %d\n" % self.port)
        path = os.path.join(self.folder, "probe.yaml")
        with open(path, "w") as f:
            f.write("rig: %s\ndriver:\n%s  time_scale: %g\n  timeout_s: %g\n  retries: 1\n"
                    "  slaves: {%s}\ncapture_root: cap\nsocket:\n  path: p.sock\n"
                    % (rig, where, self.SIM_SCALE, 0.1 * SLOW, slaves))
        return run_wrapped([GONIOD, "--config", path, "--check", "--probe"], self.folder,
                           timeout=60)

    def lines(self, r, devices=DEVICES):
        """The probe's line of each device, by device."""
        out = {}
        for line in r.stdout.splitlines():
            for who in devices:
                if line.startswith("# probe: " + who):
                    out[who] = line
        self.assertEqual(sorted(out), sorted(devices), r.stdout)
        return out


class ProbeBaudTests(ProbeRig):
    """gonio-sim's devices on a 19200-baud wire: goniod at 19200 finds them
    all; at 9600 none answers, and the refusal says which settings to check."""
    SIM_ARGS = ("--baud", "19200")

    def test_matching_baud_answers(self):
        r = self.probe(True, 19200)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        lines = self.lines(r)
        for who in DEVICES[:3]:
            self.assertIn("answered: at 0.00 deg, READY, alarm none", lines[who])
        # The default profile has a shutter: its register is read.
        self.assertIn("answered: 3 channels, idle, shutter open", lines["detector (slave 3)"])

    def test_wrong_baud_does_not_answer(self):
        r = self.probe(True, 9600)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        for who, line in self.lines(r).items():
            self.assertIn("did not answer", line, who)
        self.assertIn("goniod: probe: axis sample (slave 1) on %s: no answer" % self.pty,
                      r.stderr)
        self.assertIn("check driver.device (%s), driver.baud (9600, parity N) and the slave id"
                      % self.pty, r.stderr)


class ProbeShutterTests(ProbeRig):
    """A detector without the shutter register (gonio-sim --no-shutter):
    refused where the rig profile has a shutter, over TCP and RTU; a
    profile without one does not ask for it."""
    SIM_ARGS = ("--no-shutter",)

    def test_detector_without_shutter_refused(self):
        for rtu in (False, True):
            r = self.probe(rtu)
            self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
            self.assertIn("goniod: probe: detector (slave 3) has no shutter (register 0x010a: "
                          "exception 02)", r.stderr)
            lines = self.lines(r)
            self.assertRegex(lines["detector (slave 3)"],
                             r"answered, but detector \(slave 3\) has no shutter")
            for who in DEVICES[:3]:
                self.assertIn("answered: at 0.00 deg", lines[who])

    def test_profile_without_shutter_passes(self):
        rig = os.path.join(self.folder, "noshutter.yaml")
        with open(rig, "w") as f:
            f.write(NO_SHUTTER_RIG)
        r = self.probe(False, rig=rig)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        line = self.lines(r)["detector (slave 3)"]
        self.assertIn("answered: 3 channels, idle", line)
        self.assertNotIn("shutter", line)


class ProbeChangerTests(ProbeRig):
    """A config declaring a sample changer at slave 6: the probe reads the
    slot in place and its status (gonio-sim on the changer's rig profile,
    over TCP and RTU); the probe of a changer the config names but the bus
    lacks exits 2 naming it."""

    @property
    def SIM_ARGS(self):  # noqa: N802 (ModbusRig's gonio-sim options)
        if not self.id().endswith("_missing"):
            return ("--rig", self.changer_rig())
        return ()

    def changer_rig(self):
        path = os.path.join(self.folder, "changer.yaml")
        with open(path, "w") as f:
            f.write(CHANGER_RIG)
        return path

    def test_changer_read(self):
        for rtu in (False, True):
            r = self.probe(rtu, rig=self.changer_rig(), slaves=SLAVES + ", sample_changer: 6")
            self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
            line = self.lines(r, DEVICES + (CHANGER,))[CHANGER]
            self.assertIn("answered: slot 0 (the sample) in place, IN-POS", line)

    def test_changer_missing(self):
        r = self.probe(False, rig=self.changer_rig(), slaves=SLAVES + ", sample_changer: 6")
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        lines = self.lines(r, DEVICES + (CHANGER,))
        self.assertIn("did not answer", lines[CHANGER])
        for who in DEVICES[:3]:
            self.assertIn("answered: at 0.00 deg", lines[who])
        self.assertIn("goniod: probe: sample changer (slave 6)", r.stderr)


if __name__ == "__main__":
    unittest.main()
