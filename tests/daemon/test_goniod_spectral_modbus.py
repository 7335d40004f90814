#!/usr/bin/python3
"""A spectral detector over Modbus (docs/protocol-modbus.md, "Band block"):
gonio-sim serves the raw spectral-lab scene over Modbus TCP, goniod takes a
dark and a reference through it (their frames keep every band) and a
capture with them, whose spectra.csv holds each band reduced through the
per-band chain: the band values come back as the standard's spectral BRDF,
flat across the bands (gonio-sim mounts the standard as the sample too).
"""
import csv
import os
import statistics
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_goniod_calibrate import STANDARD, CalibrateRig, frames, rig_profile  # noqa: E402


class SpectralModbusTests(CalibrateRig):
    scene = "spectral-lab"

    def start_sim(self, material, time_scale=None):
        """gonio-sim on spectral-lab (CalibrateRig's, another scene)."""
        self.launch_sim(["--scene", self.scene, "--material", material, "--clock", "simulated"])

    def test_bands_reduced_per_band_over_modbus(self):
        self.start_daemon(rig_profile(self.folder, "lab", 0.25))
        dark_id, ref_id = self.dark_and_reference()
        for cal_id in (dark_id, ref_id):  # every frame has its 31 bands
            with open(os.path.join(self.cal_root, cal_id, "frames.csv")) as f:
                rows = [line.rstrip("\n").split(",") for line in f][1:]
            self.assertTrue(rows)
            self.assertEqual({len(r[12].split()) if len(r) > 12 else 0 for r in rows}, {31},
                             cal_id)
        # The operator mounts the standard's twin as the sample: a known
        # spectral BRDF (the standard reads 0.99/pi times its shape).
        self.start_sim(STANDARD)
        r = self.d.gonio("capture", "--plan", "ds3", "--name", "cap", "--calibration", ref_id,
                         "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr + r.stdout)
        capdir = os.path.join(self.d.root, "cap")
        spectra = list(csv.DictReader(open(os.path.join(capdir, "spectra.csv"))))
        samples = [x for x in frames(os.path.join(capdir, "samples.csv"))
                   if not int(x["flags"]) & 2]
        self.assertEqual(len(spectra), 31 * len(samples))
        self.assertEqual(sorted({float(x["wavelength_nm"]) for x in spectra})[:2], [400, 410])
        # The standard measured against itself: every band 0.99/pi times the
        # shape at its geometry, which the reference divides out; so each
        # band's value over its point's mean across bands is 1.
        by_point = {}
        for x in spectra:
            by_point.setdefault((x["theta_i"], x["theta_r"]), []).append(float(x["value"]))
        spread = []
        for values in by_point.values():
            m = statistics.mean(values)
            spread += [abs(v / m - 1) for v in values]
        med = statistics.median(spread)
        # and BRDF, not counts: 0.99/pi = 0.315 times a shape within 0.85..1.02
        values = [float(x["value"]) for x in spectra]
        self.assertGreater(statistics.median(values), 0.25)
        self.assertLess(statistics.median(values), 0.33)
        sys.stderr.write("spectral over Modbus: %d band values, median %.4f 1/sr, median "
                         "|band/mean - 1| %.3f %%\n" % (len(spectra), statistics.median(values),
                                                       100 * med))
        self.assertLess(med, 0.01)


if __name__ == "__main__":
    unittest.main()
