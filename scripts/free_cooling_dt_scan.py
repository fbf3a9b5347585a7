#!/usr/bin/env python3
"""Time-step scan of DSMC free cooling (docs/dsmc.md D4, "The time step in free cooling").

  /usr/bin/python3 scripts/free_cooling_dt_scan.py run BIN OUT DTS SEEDS [key=value ...]
  /usr/bin/python3 scripts/free_cooling_dt_scan.py table OUT [t1,t2,...]

`run` runs cases/free-cooling once per (dt, seed), one job at a time, one thread
(`--set run.threads=1`), sampling every 0.08 (a whole number of steps at every dt of the scan),
into OUT/dt<DT>/s<SEED>, and keeps only /timeseries/{t,temperature,a2,grain_collisions}
(OUT/dt<DT>/s<SEED>.npz); DTS and SEEDS are comma lists (seeds also as A-B). Extra key=value
are passed as --set (default: dsmc.particles=1000000, dsmc.t_end=6, sampling.steady_from=2).
Runs already done are skipped, so a scan can be extended by more seeds.

`table` prints, per dt, the replica mean of T(t) at the given times with its standard error,
the difference from the smallest dt and the fit T(t; dt) = T0(t) + c1(t) dt (+ c2 dt^2), and
the shift in time that the difference amounts to (delta t = -dT / (dT/dt)).
"""
import argparse
import glob
import os
import shutil
import subprocess
import sys

import numpy as np

CASE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "cases", "free-cooling")
DEFAULTS = {"dsmc.particles": "1000000", "dsmc.t_end": "6", "sampling.steady_from": "2", "sampling.every": "0.08"}


def seeds_of(spec):
    out = []
    for part in spec.split(","):
        if "-" in part:
            a, b = part.split("-")
            out += list(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def run(binary, out, dts, seeds, extra):
    import h5py

    keys = dict(DEFAULTS)
    for kv in extra:
        k, v = kv.split("=", 1)
        keys[k] = v
    for seed in seeds_of(seeds):
        for dt in dts.split(","):
            d = os.path.join(out, f"dt{dt}")
            os.makedirs(d, exist_ok=True)
            npz = os.path.join(d, f"s{seed}.npz")
            if os.path.exists(npz):
                continue
            rd = os.path.join(d, f"s{seed}")
            cmd = [binary, "run", CASE, "--out", rd, "-q", "--set", "run.threads=1", "--set", f"run.seed={seed}",
                   "--set", f"dsmc.dt={dt}"] + sum((["--set", f"{k}={v}"] for k, v in keys.items()), [])
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            with h5py.File(os.path.join(rd, "results.h5"), "r") as f:
                ts = {k: f["/timeseries/" + k][:] for k in ("t", "temperature", "a2", "grain_collisions")}
            np.savez(npz, **ts)
            shutil.rmtree(rd)
            print(f"dt {dt} seed {seed}: T(end) {ts['temperature'][-1]:.6f}", flush=True)


def load(out):
    data = {}
    for d in sorted(glob.glob(os.path.join(out, "dt*"))):
        dt = float(os.path.basename(d)[2:])
        runs = [np.load(p) for p in sorted(glob.glob(os.path.join(d, "s*.npz")))]
        if runs:
            data[dt] = runs
    return data


def at(run, key, t):
    i = int(np.argmin(abs(run["t"] - t)))
    return run[key][i] if abs(run["t"][i] - t) < 1e-9 else np.nan  # runs sampled more coarsely


def table(out, times):
    data = load(out)
    dts = sorted(data)
    print(f"{out}: runs per dt " + ", ".join(f"{dt:g}: {len(data[dt])}" for dt in dts))
    for t in times:
        print(f"\nt = {t:g}")
        ms, es, ns, used = [], [], [], []
        for dt in dts:
            x = np.array([at(r, "temperature", t) for r in data[dt]])
            x = x[np.isfinite(x)]
            if len(x) < 2:  # this dt's runs are not sampled at t
                continue
            used.append(dt)
            ns.append(len(x))
            ms.append(x.mean())
            es.append(x.std(ddof=1) / np.sqrt(len(x)))
        ms, es, dts_t = np.array(ms), np.array(es), used
        # local cooling rate from the smallest dt's mean series (central difference over 0.08)
        r0 = [r for r in data[dts_t[0]] if np.isfinite(at(r, "temperature", t))]
        tt = r0[0]["t"]
        Tm = np.mean([r["temperature"] for r in r0], axis=0)
        i = int(np.argmin(abs(tt - t)))
        slope = (Tm[min(i + 1, len(tt) - 1)] - Tm[max(i - 1, 0)]) / (tt[min(i + 1, len(tt) - 1)] - tt[max(i - 1, 0)])
        for dt, m, e, n in zip(dts_t, ms, es, ns):
            d, de = m - ms[0], np.hypot(e, es[0])
            print(f"  dt {dt:<6g} ({n:3d} runs) T {m:.7f} +- {e:.7f}   - T(dt {dts_t[0]:g}) = {d:+.7f} +- {de:.7f} "
                  f"({d / ms[0] * 100:+.4f} %, {d / de if de > 0 else 0:+.1f} sigma)  delta t {-d / slope:+.5f}")
        w = 1 / es ** 2
        for deg in (1, 2):
            if len(dts_t) <= deg + 1:
                continue
            A = np.vander(np.array(dts_t), deg + 1, increasing=True)
            cov = np.linalg.inv(A.T @ (A * w[:, None]))
            c = cov @ (A.T @ (w * ms))
            chi2 = float(((A @ c - ms) ** 2 * w).sum())
            terms = ", ".join(f"c{k} = {c[k]:+.6f} +- {np.sqrt(cov[k, k]):.6f}" for k in range(deg + 1))
            print(f"  fit degree {deg}: {terms}; chi2 {chi2:.1f} / {len(dts_t) - deg - 1}; "
                  f"c1/T0 = {c[1] / c[0]:+.5f} +- {np.sqrt(cov[1, 1]) / c[0]:.5f} per unit dt, "
                  f"c1/(dT/dt) = {-c[1] / slope:+.4f} +- {np.sqrt(cov[1, 1]) / abs(slope):.4f} (time shift per unit dt)")


def _times(s):
    try:
        return [float(x) for x in s.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected times t1,t2,..., found {s!r}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(prog="free_cooling_dt_scan.py", description="Time-step scan of DSMC free cooling "
                                 "(docs/dsmc.md D4; see the top of this file).")
    sub = ap.add_subparsers(dest="command", required=True, metavar="{run,table}")
    r = sub.add_parser("run", help="run cases/free-cooling once per (dt, seed)")
    r.add_argument("binary", metavar="BIN", help="the grainbath binary")
    r.add_argument("out", metavar="OUT", help="the scan's directory")
    r.add_argument("dts", metavar="DTS", help="time steps, a comma list")
    r.add_argument("seeds", metavar="SEEDS", help="seeds, a comma list (also A-B)")
    r.add_argument("extra", metavar="key=value", nargs="*", help="passed as --set")
    t = sub.add_parser("table", help="print the replica means per dt and the fits in dt")
    t.add_argument("out", metavar="OUT", help="the scan's directory")
    t.add_argument("times", metavar="t1,t2,...", nargs="?", type=_times, default=[0.4, 1.04, 2.0, 4.0, 6.0],
                   help="times at which T(t) is compared (default 0.4,1.04,2,4,6)")
    a = ap.parse_args()
    if a.command == "run":
        run(a.binary, a.out, a.dts, a.seeds, a.extra)
    else:
        table(a.out, a.times)
