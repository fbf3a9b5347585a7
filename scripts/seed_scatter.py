#!/usr/bin/env python3
"""The runs' own errors against the replicas' scatter, for a seed sweep of a DSMC or EDMD case
(`grainbath sweep CASE --set run.seed=1,...,R --out DIR`, or a directory of `grainbath run`
outputs, one subdirectory per seed): for each window mean or fit with an
error in summary.json, the scatter of the values (sample SD, with its own standard error
SD/sqrt(2(R-1))), the rms of the runs' errors, their ratio and how many runs flagged their
error as a lower bound (`*_plateau` false). For a density mode, also the fit of ln A used
before 2026-12-05 on the same runs (docs/OUTPUT.md, /mode/decay_rate), to show the
difference of the two estimators run by run.

usage: /usr/bin/python3 scripts/seed_scatter.py SWEEP_DIR
"""
import argparse
import glob
import json
import math
import os
import sys

import numpy as np


def old_log_fit(t, A, N, t0, t1):
    """straight line through ln A, weights (A/noise)^2 from the measured A, A > 5 noise"""
    noise = math.sqrt(2.0 / N)
    m = (t >= t0) & (t <= t1) & (A > 5 * noise)
    x, y, w = t[m], np.log(A[m]), A[m] ** 2
    S, Sx, Sy, Sxx, Sxy = w.sum(), (w * x).sum(), (w * y).sum(), (w * x * x).sum(), (w * x * y).sum()
    return -(S * Sxy - Sx * Sy) / (S * Sxx - Sx * Sx)


def main(sweep):
    runs = sorted(d for d in glob.glob(os.path.join(sweep, "variant-*")) if os.path.isdir(d))
    if not runs:  # plain run directories (e.g. --out DIR/s1, DIR/s2, ...)
        runs = sorted(os.path.dirname(p) for p in glob.glob(os.path.join(sweep, "*", "summary.json")))
    summaries = []
    for d in runs:
        try:
            summaries.append((d, json.load(open(os.path.join(d, "summary.json")))))
        except OSError:
            pass
    R = len(summaries)
    if R < 2:
        sys.exit(f"{sweep}: fewer than 2 runs with a summary.json")

    def get(s, key):
        for part in key.split("."):
            if not isinstance(s, dict) or part not in s:
                return None
            s = s[part]
        return s

    print(f"{sweep}: {R} runs")
    print(f"{'quantity':22s} {'mean':>12s} {'scatter SD':>18s} {'rms own error':>14s} {'SD/rms':>7s} {'lower bounds':>13s}")
    for key, err, flag in [("temperature.mean", "temperature.stderr", "temperature.stderr_plateau"),
                           ("a2.mean", "a2.stderr", "a2.stderr_plateau"),
                           ("a3.mean", "a3.stderr", "a3.stderr_plateau"),
                           ("rotation.R", "rotation.R_stderr", "rotation.R_stderr_plateau"),
                           ("rotation.Ttr_mean", "rotation.Ttr_stderr", "rotation.Ttr_stderr_plateau"),  # EDMD rough grains
                           ("rotation.Trot_mean", "rotation.Trot_stderr", "rotation.Trot_stderr_plateau"),
                           ("pressure.Z", "pressure.Z_stderr", "pressure.Z_stderr_plateau"),  # EDMD
                           ("pressure.P", "pressure.P_stderr", "pressure.P_stderr_plateau"),  # EDMD, steady
                           ("mode.decay_rate", "mode.decay_rate_stderr", None)]:
        v = [get(s, key) for _, s in summaries]
        e = [get(s, err) for _, s in summaries]
        ok = [i for i in range(R) if isinstance(v[i], (int, float)) and isinstance(e[i], (int, float))]
        if len(ok) < 2:
            continue
        x, ex = np.array([v[i] for i in ok]), np.array([e[i] for i in ok])
        sd, rms = x.std(ddof=1), math.sqrt(np.mean(ex ** 2))
        flags = [get(summaries[i][1], flag) for i in ok] if flag else []
        low = sum(1 for f in flags if f is False)
        print(f"{key:22s} {x.mean():12.6g} {sd:10.3g} ± {sd / math.sqrt(2 * (len(ok) - 1)):5.2g} {rms:14.3g} "
              f"{sd / rms:7.2f} {f'{low}/{len(ok)}' if flags else '':>13s}")
    try:
        import h5py
    except ImportError:
        return
    diffs = []
    for d, s in summaries:
        new = get(s, "mode.decay_rate")
        path = os.path.join(d, "results.h5")
        if not isinstance(new, (int, float)) or not os.path.exists(path):
            continue
        with h5py.File(path, "r") as f:
            if "/mode/amplitude" not in f:
                continue
            t, A = f["/mode/t"][:], f["/mode/amplitude"][:]
            lo, hi = f["/mode/fit_window"][:]
        N = float(get(s, "counters.particles_final") or 0) or None
        if N is None:
            continue
        diffs.append(new - old_log_fit(t, A, N, lo, hi))
    if len(diffs) >= 2:
        d = np.array(diffs)
        print(f"mode.decay_rate minus the fit of ln A (before 2026-12-05), run by run: "
              f"{d.mean():+.5f} ± {d.std(ddof=1) / math.sqrt(len(d)):.5f} ({len(d)} runs)")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(prog="seed_scatter.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sweep_dir", metavar="SWEEP_DIR", help="a seed sweep's directory (or one of runs, one per seed)")
    main(ap.parse_args().sweep_dir)
