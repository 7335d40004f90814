#!/usr/bin/python3
"""The ABC fit of bench/abc_scipy.c in SciPy: same samples, same model
(brdf/abc.c), same parametrisation and clamps (fit/abc_problem.h), same log
loss, analytic Jacobian, least_squares (MINPACK Levenberg-Marquardt) from
the C grid's starting points; the lowest final cost wins, as in C.

Usage: /usr/bin/python3 bench/abc_scipy.py DIR  (DIR written by abc_scipy)
Prints per material the C and SciPy times, their ratio and both costs."""
import glob
import os
import sys
import time

import numpy as np
from scipy.optimize import least_squares

PI = np.pi


def read(path):
    with open(path) as f:
        head = f.readline().split()
        lim = f.readline().split()
        meta = {head[i]: head[i + 1] for i in range(3, len(head) - 1, 2)}
        meta["name"] = head[2].rstrip(":")
        v = lim[2:]
        limits = {v[i]: tuple(float(x) for x in v[i + 1:i + 3]) for i in range(0, 15, 3)}
        limits["eta_max"] = float(v[16])
        starts, rows = [], []
        for line in f:
            if line.startswith("start"):
                starts.append([float(x) for x in line.split()[1:]])
            else:
                rows.append([float(x) for x in line.split()])
    return meta, limits, np.array(starts), np.array(rows)


class Problem:
    def __init__(self, rows, limits):
        self.x, self.vh, self.gt, self.ci = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
        self.f = rows[:, 4:7]
        self.y = np.log1p(self.f * self.ci[:, None])
        self.lim = limits
        self.n = len(rows)

    @staticmethod
    def cexp(t, lo, hi):
        inside = (t >= lo) & (t <= hi)
        v = np.exp(np.clip(t, lo, hi))
        return v, np.where(inside, v, 0.0)

    def parts(self, th):
        L = self.lim
        kd, dkd = self.cexp(th[0:3], *L["logkd"])
        A, dA = self.cexp(th[3:6], *L["logA"])
        B, dB = self.cexp(th[6] - th[7], *L["logB"])
        C, dC = self.cexp(th[7], *L["logC"])
        e = th[8]
        inside = L["e"][0] <= e <= L["e"][1]
        sg = 1.0 / (1.0 + np.exp(-np.clip(e, *L["e"])))
        eta = 1.0 + (L["eta_max"] - 1.0) * sg
        deta = (L["eta_max"] - 1.0) * sg * (1.0 - sg) if inside else 0.0
        c = np.clip(self.vh, 1e-12, 1.0)
        g2 = np.maximum((eta - 1.0) * (eta + 1.0) + c * c, 0.0)
        g = np.sqrt(g2)
        gp, gm = g + c, g - c
        p = (gm / gp) ** 2
        den = c * gm + 1.0
        r = (c * gp - 1.0) / den
        qq = 1.0 + r * r
        F = 0.5 * p * qq
        dp = 4.0 * c * gm / gp ** 3
        dr = 2.0 * c * (1.0 - c * c) / den ** 2
        dF = np.where(g > 0, 0.5 * (dp * qq + p * 2.0 * r * dr) * eta / np.where(g > 0, g, 1), 0)
        bx = B * self.x
        lg = np.log1p(bx)
        D = np.exp(-C * lg)
        dDB = -C * self.x / (1.0 + bx) * D
        dDC = -lg * D
        S = F * self.gt * D
        fhat = kd[None, :] / PI + A[None, :] * S[:, None]
        return kd, dkd, A, dA, dB, C, dC, deta, F, dF, D, dDB, dDC, S, fhat

    def res(self, th):
        fhat = self.parts(th)[-1]
        return (np.log1p(fhat * self.ci[:, None]) - self.y).ravel()

    def jac(self, th):
        kd, dkd, A, dA, dB, C, dC, deta, F, dF, D, dDB, dDC, S, fhat = self.parts(th)
        w = self.ci[:, None] / (1.0 + fhat * self.ci[:, None])  # n x 3
        J = np.zeros((self.n, 3, 9))
        for ch in range(3):
            J[:, ch, ch] = w[:, ch] * dkd[ch] / PI
            J[:, ch, 3 + ch] = w[:, ch] * dA[ch] * S
            ag = w[:, ch] * A[ch] * self.gt
            J[:, ch, 6] = ag * F * dDB * dB
            J[:, ch, 7] = ag * F * (dDC * dC - dDB * dB)
            J[:, ch, 8] = ag * D * dF * deta
        return J.reshape(3 * self.n, 9)


def fit(pb, starts):
    best = None
    for s in starts:
        r = least_squares(pb.res, s, jac=pb.jac, method="lm", xtol=1e-8, gtol=1e-8,
                          ftol=1e-8, max_nfev=2000)
        if best is None or r.cost < best.cost:
            best = r
    return best


def main():
    d = sys.argv[1]
    files = sorted(glob.glob(os.path.join(d, "*.txt")))
    print("C_ms: whole fit_abc (grid search + 5 solves); C_solve_ms: C's solves from the grid's")
    print("starts, the part SciPy is given to do; costs: 0.5 sum r^2 of the winning solve")
    print("%-24s %8s %10s %9s %8s %8s %12s %12s" % (
        "material", "C_ms", "C_solve_ms", "SciPy_ms", "ratio", "r_solve", "C_cost", "SciPy_cost"))
    ratios, sratios, worse = [], [], 0
    for path in files:
        meta, limits, starts, rows = read(path)
        pb = Problem(rows, limits)
        best_t = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            r = fit(pb, starts)
            best_t = min(best_t, time.perf_counter() - t0)
        ct, cc = float(meta["c_time_s"]), float(meta["c_cost"])
        st = float(meta["c_solve_time_s"])
        ratios.append(best_t / ct)
        sratios.append(best_t / st)
        worse += cc > r.cost * (1 + 1e-6)
        print("%-24s %8.1f %10.1f %9.1f %8.2f %8.2f %12.6g %12.6g" % (
            meta["name"], 1e3 * ct, 1e3 * st, 1e3 * best_t, best_t / ct, best_t / st, cc, r.cost))
    if ratios:
        g = lambda v: np.exp(np.mean(np.log(v)))
        print("SciPy time / C time, geometric mean: whole fit %.2f, solves only %.2f; C cost "
              "above SciPy's (by > 1e-6 relative) on %d of %d" % (g(ratios), g(sratios), worse,
                                                                  len(ratios)))


if __name__ == "__main__":
    main()
