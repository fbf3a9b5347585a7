#!/usr/bin/env python3
"""a2 and a3 of the homogeneous cooling state from a seed sweep of cases/free-cooling
(docs/dsmc.md D4), beside the theory in each run's summary.json (theory.haff.a2_van_noije_ernst,
theory.hcs.*; docs/closures.md Sec. H).

  grainbath sweep cases/free-cooling --set run.seed=1,...,R --set restitution.e=E \
      --set checkpoint.every=10 --set checkpoint.keep=true -j1 --out D
  /usr/bin/python3 scripts/hcs_a2_a3.py D [t_from]

a2: each run's window mean (summary a2.mean, t >= sampling.steady_from) and, from
/timeseries/a2, the window mean from t_from on (default 8, two past the case's steady_from of 6; it was 4 when that was 2) as a check that the
initial transient does not bias it; errors are the replicas' scatter / sqrt(R).
a3 = 1 + 3 a2 - <c^6>/(105 (T/m)^3) (docs/closures.md eq. H2): since 2026-12-06 in the time
series (/timeseries/a3, summary a3.mean; src/dsmc/moments.cpp), averaged like a2 (window mean
in the summary and from t_from); as a check, and for runs written before, also from the grain
velocities of the checkpoints the runs kept, if any (variant-*.checkpoints/*.h5,
particles/v{x,y,z}; with every = 10 and t_end = 20 those of t = 10 and 20, ~ 10 collisions per
grain apart, taken as independent), with a2 from the same snapshots beside it.
"""
import argparse
import glob
import json
import os
import sys

import h5py
import numpy as np


def mean_se(x):
    x = np.asarray(x, float)
    return x.mean(), x.std(ddof=1) / np.sqrt(len(x))


def snapshot(path):
    with h5py.File(path, "r") as f:
        v = np.stack([f["particles/vx"][:], f["particles/vy"][:], f["particles/vz"][:]], axis=1)
    c = v - v.mean(axis=0)
    c2 = (c * c).sum(axis=1)
    th = c2.mean() / 3.0  # T/m
    a2 = (c2 * c2).mean() / (15 * th * th) - 1
    a3 = 1 + 3 * a2 - (c2 ** 3).mean() / (105 * th ** 3)
    return a2, a3


def main(sweep, t_from=None):
    runs = sorted(d for d in glob.glob(os.path.join(sweep, "variant-*")) if os.path.isdir(d)
                  and not d.endswith(".checkpoints"))
    win, late, snaps_a2, snaps_a3, theory = [], [], [], [], None
    win3, late3 = [], []
    Ts, slopes, haff = [], [], {}
    tf = t_from if t_from is not None else 8.0
    for d in runs:
        try:
            s = json.load(open(os.path.join(d, "summary.json")))
        except OSError:
            continue
        theory = s.get("theory", {})
        win.append(s["a2"]["mean"])
        with h5py.File(os.path.join(d, "results.h5"), "r") as f:
            t, a2 = f["/timeseries/t"][:], f["/timeseries/a2"][:]
        late.append(a2[t >= tf].mean())
        if "a3" in s:
            win3.append(s["a3"]["mean"])
        with h5py.File(os.path.join(d, "results.h5"), "r") as f:
            T = f["/timeseries/temperature"][:]
            Ts.append(T)
            # late cooling rate: 1/sqrt(T) = 1/sqrt(T0) + zeta t / 2 in the cooling state
            slopes.append(2 * np.polyfit(t[t >= tf], 1 / np.sqrt(T[t >= tf]), 1)[0])
            for k in ("temperature", "temperature_sonine2"):
                if "/theory/haff/" + k in f:
                    haff[k] = f["/theory/haff/" + k][:]
            if "/timeseries/a3" in f:
                a3 = f["/timeseries/a3"][:]
                late3.append(np.nanmean(a3[t >= tf]))
        for cp in sorted(glob.glob(d + ".checkpoints/*.h5")):
            x2, x3 = snapshot(cp)
            snaps_a2.append(x2)
            snaps_a3.append(x3)
    R = len(win)
    print(f"{sweep}: {R} runs, {len(snaps_a3)} snapshots")
    m, e = mean_se(win)
    print(f"  a2 window mean (summary)        {m:+.5f} +- {e:.5f}   (one run's scatter {e * np.sqrt(R):.5f})")
    m, e = mean_se(late)
    print(f"  a2 window mean from t = {tf:<5g}   {m:+.5f} +- {e:.5f}")
    if len(win3) > 1:
        m, e = mean_se(win3)
        print(f"  a3 window mean (summary)        {m:+.5f} +- {e:.5f}   (one run's scatter {e * np.sqrt(len(win3)):.5f})")
    if len(late3) > 1:
        m, e = mean_se(late3)
        print(f"  a3 window mean from t = {tf:<5g}   {m:+.5f} +- {e:.5f}   (one run's scatter {e * np.sqrt(len(late3)):.5f})")
    if snaps_a3:
        m, e = mean_se(snaps_a2)
        print(f"  a2 snapshots                    {m:+.5f} +- {e:.5f}")
        m, e = mean_se(snaps_a3)
        print(f"  a3 snapshots                    {m:+.5f} +- {e:.5f}")
    if theory and len(slopes) > 1:
        z0 = theory.get("haff", {}).get("zeta0")
        if z0:
            m, e = mean_se(np.array(slopes) / z0)
            vne = 1 + 3 * theory["haff"].get("a2_van_noije_ernst", float("nan")) / 16
            s2 = theory.get("hcs", {}).get("cooling_rate_ratio_sonine2", float("nan"))
            print(f"  late cooling rate zeta/zeta0 (slope of 1/sqrt(T), t >= {tf:g})  {m:.5f} +- {e:.5f}: "
                  f"vNE {vne:.5f} ({(vne - m) / e:+.1f} sigma), second Sonine {s2:.5f} ({(s2 - m) / e:+.1f} sigma)")
        T = np.array(Ts)
        mT, se = T.mean(0), T.std(0, ddof=1) / np.sqrt(len(T))
        for k, label in (("temperature", "vNE"), ("temperature_sonine2", "second Sonine")):
            if k in haff:
                at = [tt for tt in (2, 4, 6, 10, 15, 20) if tt <= t[-1] + 1e-9]
                idx = [int(np.argmin(abs(t - tt))) for tt in at]
                print(f"  Haff ({label}) - DSMC T(t), in standard errors: " +
                      ", ".join(f"t = {t[i]:g}: {(haff[k][i] - mT[i]) / se[i]:+.1f}" for i in idx))
    if theory:
        h, c = theory.get("haff", {}), theory.get("hcs", {})
        print(f"  theory: a2 vNE {h.get('a2_van_noije_ernst', float('nan')):+.5f}, second Sonine "
              f"{c.get('a2_sonine2', float('nan')):+.5f} (a3 {c.get('a3_sonine2', float('nan')):+.5f}), "
              f"nonlinear {c.get('a2_sonine2_nonlinear', float('nan')):+.5f} "
              f"(a3 {c.get('a3_sonine2_nonlinear', float('nan')):+.5f})")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(prog="hcs_a2_a3.py", description="a2 and a3 of the homogeneous cooling state "
                                 "from a seed sweep of cases/free-cooling (see the top of this file).")
    ap.add_argument("sweep_dir", metavar="D", help="the seed sweep's directory (grainbath sweep --out D)")
    ap.add_argument("t_from", nargs="?", type=float, default=None,
                    help="start of the window of the check from /timeseries (default 8)")
    a = ap.parse_args()
    main(a.sweep_dir, a.t_from)
