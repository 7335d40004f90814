#!/usr/bin/python3
"""The detector part of the auto-ranged ETA (capture/eta.c, rate_map.c),
replayed on the journals that bench/ranging_eta.c wrote, to try rate
models and walks without running the captures again.

At every step-th sample from the end of the pre-scan on, the points measured
so far predict the rates of the points left, the ladder (capture/autorange.c's
rule, the default rig's: fixed 0.05 s, x4, 0.001..2 s, floor 2 %, aim 25 %
of 65535 counts) is walked over them from the rung the capture stood on,
and the detector time so predicted (tries and dark frames) is set against
the detector time the capture spent on those points, as a fraction of the
capture's rig time: the ETA's error less its moves and overhead, which the
ETA learns within a fraction of a per cent. Reported, never asserted.

Rate models (the log rate at a point, from its three measured neighbours
nearest in (theta_h, theta_d / 2), inverse-square-distance weights):
  plain  the log rate itself (rate_map.c);
  cos    the log of rate / cos theta_i, times cos theta_i at the point
         (a diffuse material's rate is its foreshortening).
Walks:
  shared five walks, every rate scaled together by exp(sigma z), sigma the
         pre-scan's leave-one-out error (eta.c);
  chain  the rung as a distribution carried point to point, each point's
         rate drawn on its own (three Gauss-Hermite nodes) with the sd of
         its neighbours' values times the pre-scan's leave-one-out scale,
         and 0.02 on top for the reading's own noise; a rung's dark frame
         counted where a point ends on it, with the chance it is the first.
  mix    plain and cos chains weighted by their log scores: the pre-scan's
         leave-one-out and every later point predicted before it was read,
         each with the chain's sd;
  mix/shared  plain and cos shared walks weighted the same way, each model's
         sd its pre-scan's leave-one-out rms.

Usage: bench/ranging_eta_replay.py DIR [STEP [FLOOR]]
  (DIR: ranging_eta's OUTDIR, run on its default materials: 0 gray-plastic,
  1 red-plastic, 2 gold-metallic-paint; STEP: samples between checks, 20;
  FLOOR: the ladder's floor the captures were taken with, 0.02)
Prints per variant and material the error right after the pre-scan, the
largest from there on and the largest from a quarter of the points on. About
a minute of CPU per variant.
"""
import csv
import math
import sys

FS, FLOOR, AIM, STEP, FIX, TMIN, TMAX, TRIES = 65535.0, 0.02, 0.25, 4.0, 0.05, 0.001, 2.0, 12
RUNGS = [0.001, 0.003125, 0.0125, 0.05, 0.2, 0.8, 2.0]
PRESCAN, NOISE = 12, 0.02
GH5 = [(-2.856970013872806, 0.011257411327721), (-1.355626179974266, 0.222075922005613),
       (0.0, 0.533333333333333), (1.355626179974266, 0.222075922005613),
       (2.856970013872806, 0.011257411327721)]
GH3 = [(-math.sqrt(3), 1 / 6), (0.0, 2 / 3), (math.sqrt(3), 1 / 6)]
MATERIALS = ["gray-plastic", "red-plastic", "gold-metallic-paint"]


def rung_of(k):
    return min(max(FIX * STEP**k, TMIN), TMAX)


def index_of(t):
    return math.log(t / FIX) / math.log(STEP)


def decide(t, peak, saturated, went_down):
    """autorange.c's decide(): the integration after a reading at t."""
    if saturated:
        return rung_of(round(index_of(t)) - 1)
    if went_down or peak >= FLOOR * FS:
        return t
    want = index_of(t * AIM * FS / max(peak, 1.0))
    return rung_of(max(round(index_of(t)) + 1, math.floor(want)))


def offset(darks, t):
    """The dark offset at t: its frame's, else the nearest shorter one's."""
    below = [d for d in darks if d <= t * (1 + 1e-9)]
    return darks[max(below)] if below else 0.0


def point_cost(t, rate, darks):
    """autorange_model_point without the dark frames: (tries' time, end rung, rungs tried)."""
    cost, went_down, tried = 0.0, False, []
    for tries in range(1, TRIES + 1):
        signal = rate * t
        cost += t
        tried.append(t)
        nxt = decide(t, min(signal, FS), signal + offset(darks, t) >= FS, went_down)
        if nxt == t:
            break
        went_down |= nxt < t
        t = nxt
    return cost, t, tried


def load(path):
    """The samples in journal order, and the ladder's state after each."""
    samples, darks, states, spent = [], {}, [], []
    for r in csv.DictReader(open(path)):
        t = float(r["integration_s"])
        raw = [float(r[c]) for c in ("raw_r", "raw_g", "raw_b")]
        if int(r["flags"]) & 2:
            darks[t] = raw
            spent.append(t)
            continue
        dk = darks.get(t, [0, 0, 0])
        peak = max(raw[c] - dk[c] for c in range(3))
        ti, tr = float(r["theta_i"]), float(r["theta_r"])
        samples.append({"ti": ti, "h": abs(tr - ti) / 2, "d": abs(ti + tr) / 4,
                        "rate": max(peak / t, 1 / t), "t": t, "rig": float(r["rig_time_s"])})
        spent.append(float(r["integration_total_s"]))
        states.append((t, {d: max(v) for d, v in darks.items()}, len(spent)))
    left = [sum(spent[s[2]:]) for s in states]
    return samples, states, left


def near(meas, p):
    ds = sorted(((p["h"] - q["h"]) ** 2 + (p["d"] - q["d"]) ** 2, i) for i, q in enumerate(meas))
    return [(d2, meas[i]) for d2, i in ds[:3]]


def off(model, p):
    return math.log(max(math.cos(math.radians(p["ti"])), 1e-3)) if model == "cos" else 0.0


def interp(model, nb, p):
    """The model's log rate at p and its neighbours' variance."""
    sw = sv = svv = 0.0
    for d2, q in nb:
        v = math.log(q["rate"]) - off(model, q)
        if d2 <= 0:
            return v + off(model, p), 0.0
        sw, sv, svv = sw + 1 / d2, sv + v / d2, svv + v * v / d2
    return sv / sw + off(model, p), max(svv / sw - (sv / sw) ** 2, 0.0)


def loo(model, first):
    """The pre-scan's leave-one-out: rms error, scale of the neighbours' sd, log score."""
    errs = []
    for a in first:
        m, v = interp(model, near([b for b in first if b is not a], a), a)
        errs.append((m - math.log(a["rate"]), v))
    ss, sv = sum(e * e for e, _ in errs), sum(v for _, v in errs)
    scale = math.sqrt(ss / sv) if sv > 0 else 0.0
    score = sum(logpdf(e, scale * scale * v + NOISE * NOISE) for e, v in errs)
    return math.sqrt(ss / len(first)), scale, score


def logpdf(e, s2):
    return -0.5 * math.log(s2) - 0.5 * e * e / s2


def dark_cost(t, known, taken, u):
    """A dark frame at end rung t, the first time: its expected time (u: probability)."""
    if t in known:
        return 0.0
    d = taken.get(t, 0.0)
    taken[t] = d + u * (1 - d)
    return u * (1 - d) * t


def walk_shared(model, meas, left, t, darks, sigma):
    preds = [interp(model, near(meas, p), p)[0] for p in left]
    total = 0.0
    for z, w in GH5:
        r, known = t, set(darks)
        for lp in preds:
            cost, r, tried = point_cost(r, math.exp(lp + sigma * z), darks)
            total += w * (cost + sum(x for x in set(tried) if x not in known))
            known.update(tried)
    return total


def walk_chain(model, meas, left, t, darks, scale):
    dist, taken, total = {t: 1.0}, {}, 0.0
    for p in left:
        m, v = interp(model, near(meas, p), p)
        s = math.sqrt(scale * scale * v + NOISE * NOISE)
        nxt = {}
        for r, pr in dist.items():
            for z, w in GH3:
                cost, e, _ = point_cost(r, math.exp(m + s * z), darks)
                total += pr * w * cost + dark_cost(e, darks, taken, pr * w)
                nxt[e] = nxt.get(e, 0.0) + pr * w
        dist = {r: pr for r, pr in nxt.items() if pr > 1e-6}
    return total


def sequential_scores(model, samples, scale, first_score, rms=None):
    """Each point after the pre-scan predicted from those before it: the log
    score so far (its variance the neighbours', scaled, or rms squared)."""
    out, sc = [first_score], first_score
    for j in range(PRESCAN, len(samples)):
        m, v = interp(model, near(samples[:j], samples[j]), samples[j])
        s2 = rms * rms if rms else scale * scale * v + NOISE * NOISE
        sc += logpdf(m - math.log(samples[j]["rate"]), s2)
        out.append(sc)
    return out


def replay(path, variant, step):
    samples, states, spent_left = load(path)
    rig = samples[-1]["rig"]
    fits = {m: loo(m, samples[:PRESCAN]) for m in ("plain", "cos")}
    scores = {}
    if variant == "mix":
        scores = {m: sequential_scores(m, samples, fits[m][1], fits[m][2]) for m in fits}
    if variant == "mix/shared":
        # one sd per model, its pre-scan's rms: the leave-one-out's score is
        # then n (-log rms - 1/2)
        scores = {m: sequential_scores(m, samples, 0, PRESCAN * (-math.log(fits[m][0]) - 0.5),
                                       fits[m][0]) for m in fits}
    errs = []
    for k in range(PRESCAN, len(samples), step):
        meas, left = samples[:k], samples[k:]
        t, darks, _ = states[k - 1]
        if variant.startswith("mix"):
            sc = {m: scores[m][k - PRESCAN] for m in scores}
            best = max(sc.values())
            w = {m: math.exp(s - best) for m, s in sc.items()}
            w = {m: x / sum(w.values()) for m, x in w.items() if x > 1e-3 * sum(w.values())}
            pred = sum(w[m] * (walk_chain(m, meas, left, t, darks, fits[m][1]) if variant == "mix"
                               else walk_shared(m, meas, left, t, darks, fits[m][0]))
                       for m in w) / sum(w.values())
        else:
            walk, model = variant.split("/")
            pred = (walk_shared(model, meas, left, t, darks, fits[model][0]) if walk == "shared"
                    else walk_chain(model, meas, left, t, darks, fits[model][1]))
        errs.append((k, (pred - spent_left[k - 1]) / rig))
    return errs, len(samples)


def main():
    global FLOOR
    if len(sys.argv) < 2:
        sys.stderr.write("usage: ranging_eta_replay.py DIR [STEP [FLOOR]]\n")
        return 2
    step = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    FLOOR = float(sys.argv[3]) if len(sys.argv) > 3 else FLOOR
    variants = sys.argv[4].split(",") if len(sys.argv) > 4 else [
        "shared/plain", "shared/cos", "chain/plain", "chain/cos", "mix", "mix/shared"]
    for variant in variants:
        cells = []
        for i, name in enumerate(MATERIALS):
            errs, n = replay("%s/%d/samples.csv" % (sys.argv[1], i), variant, step)
            quarter = [abs(e) for k, e in errs if k >= n // 4] or [0.0]
            cells.append("%s %+.1f %% / %.1f %% / %.1f %%" % (
                name, 100 * errs[0][1], 100 * max(abs(e) for _, e in errs), 100 * max(quarter)))
        print("%-13s %s" % (variant, " | ".join(cells)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
