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
                 --drift-m-per-sqrt-m D --drift-deg-per-sqrt-m R]
      per file (and per scenario): mean NEES 3/6 dof, 3-sigma coverage,
      integrity counts at 0.03, 0.05 and 0.10 m.
  fit FILE... [--scale S --floor-position-m F --floor-attitude-deg A --short-m 2]
      on the calibration files: the mean position NEES before the map has
      drifted (map travel < --short-m) for a few variance factors (to choose
      --scale), then, at --scale, the smallest drift_m_per_sqrt_m for which
      no file's mean position NEES exceeds 3 (the chi2(3) mean) and the
      smallest drift_deg_per_sqrt_m for which no file's mean attitude NEES
      exceeds 3.

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


def score(run, p):
    P = published(run, p)
    e6 = np.concatenate([run["ep"], run["er"]], axis=1)
    n3 = nees(run["ep"], P[:, :3, :3])
    n6 = nees(e6, P)
    nr = nees(run["er"], P[:, 3:, 3:])
    bound = 3.0 * np.sqrt(np.maximum(np.linalg.eigvalsh(P[:, :3, :3])[:, -1], 0.0))
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


def print_scores(runs, p):
    print("settings: " + ", ".join("%s %g" % kv for kv in p.items()))
    print("| run | scored | travelled / largest map travel (m) | max error (cm) | mean 3σ (cm) | NEES pos [band] | NEES pose [band] "
          "| 3σ covers (%) | alerts/over/FA/MD at 0.03 | at 0.05 | at 0.10 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    groups = collections.OrderedDict()
    for run in runs:
        s = score(run, p)
        groups.setdefault(run["scenario"], []).append(s)
        b3, b6 = band(s["n"], 3), band(s["n"], 6)
        print("| %s | %d | %.1f / %.1f | %.1f | %.1f | %.2f [%.2f, %.2f] | %.2f [%.2f, %.2f] | %.1f | %s | %s | %s |" % (
            run["name"], s["n"], run["travelled"][-1], run["map_travel"].max(), 100 * s["err"].max(), 100 * s["bound"].mean(),
            s["nees3"].mean(), b3[0], b3[1], s["nees6"].mean(), b6[0], b6[1], 100 * s["covered"].mean(),
            "/".join(map(str, s[0.03])), "/".join(map(str, s[0.05])), "/".join(map(str, s[0.10]))))
    print()
    print("| scenario | runs | mean NEES pos | mean NEES pose | 3σ covers (%) | FA % / MD % at 0.03 | at 0.05 "
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
        print("| %s | %d | %.2f | %.2f | %.1f | %s |" % (name, len(ss), cat("nees3").mean(), cat("nees6").mean(),
                                                     100 * cat("covered").mean(), " | ".join(rates)))


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


def fit(runs, base, short_m):
    """Calibrates on `runs`: the variance factor is checked on the short horizon, the drift rates fitted."""
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
    # 2. The position drift rate: the smallest for which no calibration file
    #    is overconfident on average (mean position NEES <= 3, the chi2(3)
    #    mean). 3. The attitude rate likewise on the attitude NEES.
    p = dict(base, drift_deg_per_sqrt_m=0.0)
    worst = lambda q, key: max(score(r, q)[key].mean() for r in runs)
    k = smallest(lambda d: worst(dict(p, drift_m_per_sqrt_m=d), "nees3") <= 3.0, 0.0, 0.1)
    p["drift_m_per_sqrt_m"] = k
    a = smallest(lambda d: worst(dict(p, drift_deg_per_sqrt_m=d), "nees_att") <= 3.0, 0.0, 1.0)
    print("scale %g: drift_m_per_sqrt_m %.5f, drift_deg_per_sqrt_m %.5f" % (p["scale"], k, a))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=("score", "fit"))
    ap.add_argument("files", nargs="+")
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--floor-position-m", type=float, default=0.005)
    ap.add_argument("--floor-attitude-deg", type=float, default=0.02)
    ap.add_argument("--drift-m-per-sqrt-m", type=float, default=0.0)
    ap.add_argument("--drift-deg-per-sqrt-m", type=float, default=0.0)
    ap.add_argument("--short-m", type=float, default=2.0, help="fit: the short horizon, m of map travel")
    args = ap.parse_args()
    runs = [load(f) for f in args.files]
    p = collections.OrderedDict(scale=args.scale, floor_position_m=args.floor_position_m,
                                floor_attitude_deg=args.floor_attitude_deg, drift_m_per_sqrt_m=args.drift_m_per_sqrt_m,
                                drift_deg_per_sqrt_m=args.drift_deg_per_sqrt_m)
    if args.command == "score":
        print_scores(runs, p)
    else:
        fit(runs, p, args.short_m)
    return 0


if __name__ == "__main__":
    sys.exit(main())
