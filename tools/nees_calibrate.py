#!/usr/bin/python3
"""Re-score and calibrate the published covariance from `sitepose bench nees --csv` files.

Each CSV row is one scored OK frame with its error against ground truth, the
path length travelled, the map travel (the map-drift term's distance,
PoseEstimate::map_travel_m) and the tracker's own [dp; dtheta] covariance. The published covariance is rebuilt exactly as
output::published_pose forms it (no anchor, lever arm 0):

    P = scale * C_tracker + diag(s_p^2 I, s_a^2 I)
    s_p = hypot(floor_position_m, drift_m_per_sqrt_m * sqrt(map_travel_m))
    s_a = hypot(floor_attitude_deg, drift_deg_per_sqrt_m * sqrt(map_travel_m))  (in rad)

so other settings are scored without re-running the tracker.

  score FILE... [--scale S --floor-position-m F --floor-attitude-deg A
                 --drift-m-per-sqrt-m D --drift-deg-per-sqrt-m R --protection-level-sigmas K]
      per file (and per scenario): mean NEES 3/6 dof against the 95 % band
      of one chi2 value, the protection level's (K sigma) coverage,
      integrity counts at 0.03, 0.05 and 0.10 m. Defaults: the shipped.
  fit FILE... [--scale S --short-m 2]
      on the calibration files: the mean position NEES before the map has
      drifted (map travel < --short-m) for a few variance factors (to choose
      --scale); then, at --scale, on grids of round values, the position
      floor and drift rate that put the worst file's mean position NEES
      deepest inside the chi2(3) band (in log ratio to the nearer edge), the
      attitude floor and rate likewise for the pose NEES (chi2(6)); and the
      largest |dp| / sigma_max of any frame, which the protection level's K
      must exceed.

File names: <scenario>_<seed>.csv (the scenario is the part before the
last '_'). Needs python3-numpy.
"""

import argparse
import collections
import math
import os
import sys

import numpy as np

LIMITS_M = (0.03, 0.05, 0.10)


def load(path):
    rows = np.genfromtxt(path, delimiter=",", names=True)
    rows = np.atleast_1d(rows)
    run = {
        "name": os.path.splitext(os.path.basename(path))[0],
        "ep": np.stack([rows["ex_m"], rows["ey_m"], rows["ez_m"]], axis=1),
        "er": np.stack([rows["erx_rad"], rows["ery_rad"], rows["erz_rad"]], axis=1),
        "travelled": rows["travelled_m"],
        # CSVs written before the map travel existed: the path length was the drift's distance.
        "map_travel": rows["map_travel_m"] if "map_travel_m" in rows.dtype.names else rows["travelled_m"],
    }
    n = len(rows)
    c = np.zeros((n, 6, 6))
    for i in range(6):
        for j in range(i, 6):
            c[:, i, j] = rows["tracker_c%d%d" % (i, j)]
            c[:, j, i] = c[:, i, j]
    run["tracker"] = c
    run["scenario"] = run["name"].rsplit("_", 1)[0]
    return run


def published(run, p):
    """Published [dp; dtheta] covariance of every frame of `run` under settings `p`."""
    deg = math.pi / 180.0
    sp2 = p["floor_position_m"] ** 2 + p["drift_m_per_sqrt_m"] ** 2 * run["map_travel"]
    sa2 = (p["floor_attitude_deg"] * deg) ** 2 + (p["drift_deg_per_sqrt_m"] * deg) ** 2 * run["map_travel"]
    P = p["scale"] * run["tracker"].copy()
    for k in range(3):
        P[:, k, k] += sp2
        P[:, 3 + k, 3 + k] += sa2
    return P


def nees(e, P):
    return np.einsum("ni,ni->n", e, np.linalg.solve(P, e[..., None])[..., 0])


def score(run, p, sigmas=4.5):
    P = published(run, p)
    e6 = np.concatenate([run["ep"], run["er"]], axis=1)
    n3 = nees(run["ep"], P[:, :3, :3])
    n6 = nees(e6, P)
    nr = nees(run["er"], P[:, 3:, 3:])
    bound = sigmas * np.sqrt(np.maximum(np.linalg.eigvalsh(P[:, :3, :3])[:, -1], 0.0))
    err = np.linalg.norm(run["ep"], axis=1)
    out = {
        "n": len(err),
        "nees3": n3,
        "nees6": n6,
        "nees_att": nr,
        "bound": bound,
        "err": err,
        "covered": err <= bound,
    }
    for lim in LIMITS_M:
        alert = bound > lim
        out[lim] = (int(alert.sum()), int((err > lim).sum()), int((alert & (err < lim)).sum()),
                    int((~alert & (err > lim)).sum()))
    return out


def band(n, dof):
    # Wilson-Hilferty, as experiments::chi_square_mean_band_95.
    v = n * dof
    a = 2.0 / (9.0 * v)
    q = lambda z: v * (1.0 - a + z * math.sqrt(a)) ** 3 / n
    return q(-1.959963984540054), q(1.959963984540054)


def verdict(mean, dof):
    lo, hi = CHI2_BAND_95[dof]
    return "%.2f" % mean + ("" if lo <= mean <= hi else (" (below)" if mean < lo else " (**above**)"))


def print_scores(runs, p, sigmas):
    print("settings: " + ", ".join("%s %g" % kv for kv in p.items()) + ", protection level %g sigma" % sigmas)
    print("| run | scored | travelled / largest map travel (m) | max error (cm) | mean PL (cm) | NEES pos | NEES pose "
          "| PL covers (%) | alerts/over/FA/MD at 0.03 | at 0.05 | at 0.10 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    groups = collections.OrderedDict()
    for run in runs:
        s = score(run, p, sigmas)
        groups.setdefault(run["scenario"], []).append(s)
        print("| %s | %d | %.1f / %.1f | %.1f | %.1f | %s | %s | %.1f | %s | %s | %s |" % (
            run["name"], s["n"], run["travelled"][-1], run["map_travel"].max(), 100 * s["err"].max(), 100 * s["bound"].mean(),
            verdict(s["nees3"].mean(), 3), verdict(s["nees6"].mean(), 6), 100 * s["covered"].mean(),
            "/".join(map(str, s[0.03])), "/".join(map(str, s[0.05])), "/".join(map(str, s[0.10]))))
    print()
    print("bands of one chi2 value (95 %%): 3 dof [%.3f, %.3f], 6 dof [%.3f, %.3f]" % (*CHI2_BAND_95[3], *CHI2_BAND_95[6]))
    print()
    print("| scenario | runs | mean NEES pos | mean NEES pose | PL covers (%) | FA % / MD % at 0.03 | at 0.05 "
          "| at 0.10 |")
    print("|---|---|---|---|---|---|---|---|")
    for name, ss in groups.items():
        n = sum(s["n"] for s in ss)
        cat = lambda k: np.concatenate([s[k] for s in ss])
        rates = []
        for lim in LIMITS_M:
            fa = sum(s[lim][2] for s in ss)
            md = sum(s[lim][3] for s in ss)
            rates.append("%.1f / %.1f" % (100.0 * fa / n, 100.0 * md / n))
        print("| %s | %d | %s | %s | %.1f | %s |" % (name, len(ss), verdict(cat("nees3").mean(), 3),
                                                 verdict(cat("nees6").mean(), 6), 100 * cat("covered").mean(),
                                                 " | ".join(rates)))


def smallest(pred, lo, hi, steps=40):
    """Smallest x in [lo, hi] with pred(x) (pred monotone: false ... true); None if pred(hi) is false."""
    if pred(lo):
        return lo
    if not pred(hi):
        return None
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if pred(mid) else (mid, hi)
    return hi


# The 95 % band of one chi2(k) value (k = 3, 6): a consistent covariance
# puts each run's mean NEES inside it (the band of the mean of N frames
# is far narrower, but takes successive errors as independent; a run's drift
# is one slowly varying error, so the run's mean scatters like few samples).
CHI2_BAND_95 = {3: (0.2158, 9.3484), 6: (1.2373, 14.4494)}


def log_margin(mean, dof):
    """How far inside the chi2(dof) 95 % band `mean` lies, as the smaller log ratio to its edges (< 0: outside)."""
    lo, hi = CHI2_BAND_95[dof]
    return min(math.log(mean / lo), math.log(hi / mean))


def centre_in_band(runs, base, key, dof, floor_name, floors, rate_name, rates):
    """The (floor, rate) of the grid whose worst calibration run lies deepest inside the chi2(dof) band."""
    best = None
    for f in floors:
        for d in rates:
            p = dict(base, **{floor_name: f, rate_name: d})
            means = [score(r, p)[key].mean() for r in runs]
            worst = min(log_margin(m, dof) for m in means)
            pooled = np.mean(means)
            if best is None or worst > best[0] + 1e-12:
                best = (worst, f, d, min(means), max(means), pooled)
    return best


def fit(runs, base, short_m):
    """Calibrates on `runs`: the variance factor is checked on the short horizon; the floors and drift rates are
    centred so that every run's mean NEES lies inside the chi2 band; the protection level's K covers every frame."""
    # 1. Before the map has drifted (map travel < short_m) the error is the
    #    tracker's own: the mean NEES there, per file and pooled, for a few
    #    variance factors (the factor is chosen by hand from it: --scale).
    print("short horizon (map travel < %g m), drift 0: mean position NEES" % short_m)
    for scale in (0.5, 1.0, 2.0, 3.0):
        p = dict(base, scale=scale, drift_m_per_sqrt_m=0.0, drift_deg_per_sqrt_m=0.0)
        per, pooled = [], []
        for r in runs:
            m = r["map_travel"] < short_m
            n3 = score(r, p)["nees3"][m]
            pooled.append(n3)
            per.append("%s %.2f (%d)" % (r["name"], n3.mean() if m.any() else float("nan"), m.sum()))
        print("  scale %g: pooled %.2f; %s" % (scale, np.concatenate(pooled).mean(), ", ".join(per)))
    # 2. Position floor and drift rate on a grid of round values: the pair
    #    whose worst calibration run lies deepest inside the chi2(3) band
    #    (both edges: overconfident above, needlessly cautious below).
    #    3. The attitude floor and rate likewise on the whole pose's NEES
    #       (6 dof, the position's settings fixed).
    p = dict(base)
    grid = lambda lo, hi, step: [lo + i * step for i in range(int(round((hi - lo) / step)) + 1)]
    pos = centre_in_band(runs, p, "nees3", 3, "floor_position_m", grid(0.001, 0.006, 0.0005),
                         "drift_m_per_sqrt_m", grid(0.001, 0.008, 0.00025))
    p.update(floor_position_m=pos[1], drift_m_per_sqrt_m=pos[2])
    att = centre_in_band(runs, p, "nees6", 6, "floor_attitude_deg", grid(0.0025, 0.03, 0.0025),
                         "drift_deg_per_sqrt_m", grid(0.001, 0.02, 0.0005))
    p.update(floor_attitude_deg=att[1], drift_deg_per_sqrt_m=att[2])
    for name, dof, r in (("position (3 dof)", 3, pos), ("pose (6 dof), attitude settings", 6, att)):
        print("%s: floor %g, rate %g; run means %.2f .. %.2f (band %.3f .. %.3f), mean of runs %.2f, worst log margin %.2f"
              % (name, r[1], r[2], r[3], r[4], CHI2_BAND_95[dof][0], CHI2_BAND_95[dof][1], r[5], r[0]))
    attitude = [score(r, p)["nees_att"].mean() for r in runs]
    print("attitude (3 dof) run means %.2f .. %.2f (band %.3f .. %.3f)" % (min(attitude), max(attitude), *CHI2_BAND_95[3]))
    # 4. The protection level's K: the largest |dp| / sigma_max of any
    #    calibration frame (sigma_max: the largest position standard deviation).
    ratio = 0.0
    for r in runs:
        P = published(r, p)
        sigma = np.sqrt(np.maximum(np.linalg.eigvalsh(P[:, :3, :3])[:, -1], 0.0))
        ratio = max(ratio, float((np.linalg.norm(r["ep"], axis=1) / sigma).max()))
    print("largest |dp| / sigma_max over the calibration frames: %.2f (protection level K must exceed it)" % ratio)
    print("settings: " + ", ".join("%s %g" % kv for kv in p.items()))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=("score", "fit"))
    ap.add_argument("files", nargs="+")
    # Defaults: the shipped settings (config/siteposed.yaml).
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--floor-position-m", type=float, default=0.001)
    ap.add_argument("--floor-attitude-deg", type=float, default=0.005)
    ap.add_argument("--drift-m-per-sqrt-m", type=float, default=0.003)
    ap.add_argument("--drift-deg-per-sqrt-m", type=float, default=0.008)
    ap.add_argument("--protection-level-sigmas", type=float, default=4.5, help="score: the protection level's K")
    ap.add_argument("--short-m", type=float, default=2.0, help="fit: the short horizon, m of map travel")
    args = ap.parse_args()
    runs = [load(f) for f in args.files]
    p = collections.OrderedDict(scale=args.scale, floor_position_m=args.floor_position_m,
                                floor_attitude_deg=args.floor_attitude_deg, drift_m_per_sqrt_m=args.drift_m_per_sqrt_m,
                                drift_deg_per_sqrt_m=args.drift_deg_per_sqrt_m)
    if args.command == "score":
        print_scores(runs, p, args.protection_level_sigmas)
    else:
        fit(runs, p, args.short_m)
    return 0


if __name__ == "__main__":
    sys.exit(main())
