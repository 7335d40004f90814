#!/usr/bin/python3
"""Write chain.ioctl and chain-standard.yaml: a USB2000+ taking the dark
frames, a reference standard and a sample's capture through the radiometry
chain (test_usb_chain.c reduces them and compares with the sample's BRDF);
and chain_stray.ioctl: the same device on a rig with stray light, taking
the dark frames, the stray light (a light trap in the sample's place), the
standard and the sample's capture twice.

The device, pixel by pixel, as make_recordings.py's: the lamp curve times
the detector's response (far from flat, as a real one is), an electric
baseline of about 1500 counts under every pixel, which the masked pixels
6-20 show; on top of it a dark signal of its own per pixel (a pattern and
hot pixels, growing with the integration) that only a dark frame removes,
shot noise (var = G_ADU * signal) and read noise, the factory nonlinearity
(the device reads z where z / P(z) is the light, P as its slots 6-8 say)
and the 16-bit clip. Everything is seeded: the output is committed.
"""
import math
import random
import struct

import make_recordings as mr

T_S = mr.INTEGRATION_US * 1e-6
N_DARK = 8
REPEATS = 3
# (theta_i, theta_r) on the standard's nodes below, theta_r signed (+ on
# the mirror side), in the order the reference and the capture visit them.
GEOMETRIES = [(0, 30), (0, 60), (30, -60), (30, 0), (30, 30), (60, 60)]
RHO = 0.99                       # the standard: flat, as chain-standard.yaml says
INCIDENCE = [0, 30, 60]
VIEW = [-60, -30, 0, 30, 60]
SHAPE = [[0.910, 0.985, 1.010, 0.985, 0.910],   # spectralon-99's at these nodes
         [0.904, 0.983, 1.010, 0.989, 0.925],
         [0.887, 0.979, 1.010, 1.001, 0.968]]
# The sample: a diffuse albedo per bin (B below 495 nm, G to 595, R above)
# and a grey lobe around the mirror direction (test_usb_chain.c's truth).
KD = (0.30, 0.35, 0.40)          # B, G, R
KS, LOBE_DEG = 0.30, 12.0
RATE = 1.5e5 / 0.315             # linear counts per second at the response's peak, per 1/sr
G_ADU, READ_SD = 0.05, 4.0
STRAY = 0.006                    # chain_stray.ioctl's stray light, 1/sr equivalent
DARK_RATE = 3000.0               # counts per second, before the pattern


def p_of(z):
    c = [float(x) for x in mr.NL]
    return c[0] + c[1] * z + c[2] * z * z


def nl_forward(x):
    """The count z the device reads for light x: z / P(z) = x (Newton)."""
    z = x
    for _ in range(30):
        p = p_of(z)
        dp = float(mr.NL[1]) + 2 * float(mr.NL[2]) * z
        z -= (z / p - x) / ((p - z * dp) / (p * p))
    return z


def f_ref(ti, tr):
    return RHO / math.pi * SHAPE[INCIDENCE.index(ti)][VIEW.index(tr)]


def f_sample(lam, ti, tr):
    kd = KD[0] if lam < 495 else KD[1] if lam < 595 else KD[2]
    return kd / math.pi + KS * math.exp(-((tr - ti) / LOBE_DEG) ** 2)


def f_stray(lam, ti, tr):
    """The rig's stray light, as the BRDF that would give its counts: there
    with the light path open whatever sits in the sample's place, growing
    towards the source's side and the blue, so that only a per-band stray
    calibration at each geometry removes it."""
    return STRAY * (1 + 0.5 * (tr - ti) / 90) * (1.6 - (lam - 340) / 700)


def spectrum(rng, f, ti=0, stray=None):
    """Counts of one reading: f(lambda) the BRDF lit (None: dark); stray:
    the stray light's (None: none)."""
    c = [float(x) for x in mr.COEF]
    peak = max(mr.shape(c, p) for p in range(mr.PIXELS))
    out = []
    for p in range(mr.PIXELS):
        lam = c[0] + p * (c[1] + p * (c[2] + p * c[3]))
        base = 1500 + 7 * math.sin(0.37 * p)
        if p < mr.DARK[1]:        # masked: the electric baseline alone
            out.append(base + rng.gauss(0, READ_SD))
            continue
        dark = T_S * DARK_RATE * (1 + 0.5 * math.sin(0.05 * p)) * (4 if p % 97 == 0 else 1)
        sig = 0.0 if f is None else T_S * RATE * mr.shape(c, p) / peak * \
            math.cos(math.radians(ti)) * f(lam)
        if stray is not None:
            sig += T_S * RATE * mr.shape(c, p) / peak * stray(lam)
        x = sig + dark
        x += rng.gauss(0, math.sqrt(G_ADU * x + READ_SD ** 2))
        out.append(base + nl_forward(x))
    return [max(0, min(65535, int(round(v)))) for v in out]


def reading(lines, counts, first):
    raw = b"".join(struct.pack("<H", v) for v in counts)
    mr.spectrum(lines, raw, integration=first)


def write_standard():
    with open("chain-standard.yaml", "w") as f:
        f.write("# Written by make_chain.py: the standard chain.ioctl's reference was\n"
                "# read on (flat, with spectralon-99's shape at these nodes).\n"
                "name: chain-test\ncertificate: \"test: make_chain.py\"\n"
                "reflectance:\n  rgb: [%g, %g, %g]\n  u: [0.005, 0.005, 0.005]\n"
                "angular:\n  incidence_deg: %s\n  view_deg: %s\n  factor:\n%s  u: 0.005\n"
                % (RHO, RHO, RHO, INCIDENCE, VIEW,
                   "".join("    - %s\n" % row for row in SHAPE)))


def main():
    rng = random.Random(24)
    lines = []
    mr.opening(lines)
    for k in range(N_DARK):
        reading(lines, spectrum(rng, None), k == 0)
    for ti, tr in GEOMETRIES:
        for _ in range(REPEATS):
            reading(lines, spectrum(rng, lambda lam, ti=ti, tr=tr: f_ref(ti, tr), ti), False)
    for ti, tr in GEOMETRIES:
        reading(lines, spectrum(rng, lambda lam, ti=ti, tr=tr: f_sample(lam, ti, tr), ti),
                False)
    mr.write("chain.ioctl", lines)
    write_standard()
    write_stray()


def write_stray():
    """chain_stray.ioctl: dark, stray light, standard (each as chain.ioctl's),
    then the sample at each geometry, twice (a capture for each way of
    reducing it), every lit reading with the stray light on top."""
    rng = random.Random(2424)
    lines = []
    mr.opening(lines)
    for k in range(N_DARK):
        reading(lines, spectrum(rng, None), k == 0)
    for ti, tr in GEOMETRIES:
        for _ in range(REPEATS):
            reading(lines, spectrum(rng, None, stray=lambda lam, ti=ti, tr=tr:
                                    f_stray(lam, ti, tr)), False)
    for ti, tr in GEOMETRIES:
        for _ in range(REPEATS):
            reading(lines, spectrum(rng, lambda lam, ti=ti, tr=tr: f_ref(ti, tr), ti,
                                    stray=lambda lam, ti=ti, tr=tr: f_stray(lam, ti, tr)),
                    False)
    for _ in range(2):
        for ti, tr in GEOMETRIES:
            reading(lines, spectrum(rng, lambda lam, ti=ti, tr=tr: f_sample(lam, ti, tr), ti,
                                    stray=lambda lam, ti=ti, tr=tr: f_stray(lam, ti, tr)),
                    False)
    mr.write("chain_stray.ioctl", lines)


if __name__ == "__main__":
    main()
