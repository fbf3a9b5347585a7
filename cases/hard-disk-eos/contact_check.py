#!/usr/bin/env python3
"""g(sigma+) from the pair histogram against the virial, over many runs (docs/VALIDATION.md).

Usage: /usr/bin/python3 cases/hard-disk-eos/contact_check.py RUN_DIR [RUN_DIR ...]
(--out directories of elastic 2D runs, e.g. of this case with --set sampling.gr_bin=0.005).

For microcanonical hard disks Z = 1 + 2 nu g_N(sigma+) holds exactly in the N-particle box
when g_N is normalised by N(N-1) and T = sum c^2/(D N), so g_r.contact_fit / pressure.g_contact
should be 1 up to the fit's own bias and noise. Prints, as mean +- standard error over the
runs (one number per run: runs are independent seeds):
  - the summary's ratio (g_r.contact_fit: quadratic over [1, 1.1] of the run's own bins);
  - the same least-squares fit of the bins' shell averages (exact moments of the r weight) for
    polynomial orders 1-4, windows [1, 1 + h], h = 0.05, 0.1, 0.2, and the histogram re-binned
    to wider bins (shell-weighted), some of them straddling sigma; and each one's paired
    difference to the summary's estimator (same histograms: the fit's and binning's own bias);
  - the sum rule of the N(N-1) normalisation: the mean of g over 10 sigma ... L/2 against
    1 + (1 - S(0))/N, S(0) = 1/(d(nu Z)/d nu) from Henderson's Z = (1 + nu^2/8)/(1 - nu)^2.
"""
import json
import os
import sys

import h5py
import numpy as np


def shell_moments(lo, hi, r0, r1, h, order):
    # int_lo^hi ((r - 1)/h)^k r dr / int_r0^r1 r dr (2D shell weight), exact polynomial integrals
    def prim(x, k):  # int x^k (1 + x) dx, x = r - 1
        return x ** (k + 1) / (k + 1) + x ** (k + 2) / (k + 2)
    V = prim(r1 - 1, 0) - prim(r0 - 1, 0)
    return [(prim(hi - 1, k) - prim(lo - 1, k)) / (V * h ** k) for k in range(order + 1)]


def contact(edges, gbar, h, order):
    rows, ys = [], []
    for r0, r1, g in zip(edges[:-1], edges[1:], gbar):
        if r1 <= 1.0 or 0.5 * (r0 + r1) > 1.0 + h + 1e-12:
            continue
        rows.append(shell_moments(max(r0, 1.0), r1, r0, r1, h, order))
        ys.append(g)
    if len(rows) < order + 1:
        return np.nan
    return np.linalg.lstsq(np.array(rows), np.array(ys), rcond=None)[0][0]


def rebin(edges, g, f, off):
    sh = edges[1:] ** 2 - edges[:-1] ** 2
    g, sh, e = g[off:], sh[off:], edges[off:]
    n = len(g) // f * f
    G = (g[:n] * sh[:n]).reshape(-1, f).sum(1) / sh[:n].reshape(-1, f).sum(1)
    return e[: n + 1 : f], G


def main(runs):
    res, tails = {}, []
    for run in runs:
        s = json.load(open(os.path.join(run, "summary.json")))
        gv = s["pressure"]["g_contact"]
        with h5py.File(os.path.join(run, "results.h5"), "r") as f:
            r = f["observables/gr/r"][()]
            g = f["observables/gr/g"][()]
            par = f["parameters"].attrs
            nu, n_part = float(par["edmd.packing_fraction"]), int(par["edmd.particles"])
            aspect = json.loads(par["edmd.aspect"]) if "edmd.aspect" in par else [1.0]
        dr = r[1] - r[0]
        edges = np.append(r - dr / 2, r[-1] + dr / 2)
        res.setdefault("summary g_r.contact_fit", []).append(s["g_r"]["contact_fit"] / gv)
        fine = round(0.005 / dr)
        for width in (1, 4) if fine == 1 else (1,):
            e, G = rebin(edges, g, width, 0)
            for h in (0.05, 0.1, 0.2):
                for order in (1, 2, 3, 4):
                    res.setdefault(f"bins {width * dr:.3f}, [1, {1 + h:.2f}], order {order}", []).append(
                        contact(e, G, h, order) / gv)
        if fine == 1:  # straddling bins from the 0.005 histogram
            for f_, off in ((6, 0), (6, 4), (5, 2)):
                e, G = rebin(edges, g, f_, off)
                lo = e[e < 1.0].max()
                res.setdefault(f"bins {f_ * dr:.3f} from {lo:.3f} (straddling), [1, 1.1], order 2", []).append(
                    contact(e, G, 0.1, 2) / gv)
        if all(a == 1.0 for a in aspect):  # square box: L/2 is the pair range
            L = np.sqrt(n_part * np.pi / (4 * nu))
            m = (edges[:-1] >= 10) & (edges[1:] <= L / 2 - 0.1)
            if m.any():
                sh = edges[1:] ** 2 - edges[:-1] ** 2
                fz = lambda v: v * (1 + v * v / 8) / (1 - v) ** 2
                S0 = 1 / ((fz(nu + 1e-6) - fz(nu - 1e-6)) / 2e-6)
                tails.append(((g[m] * sh[m]).sum() / sh[m].sum(), 1 + (1 - S0) / n_part))
    base = np.array(res["summary g_r.contact_fit"])
    print(f"{len(base)} runs; g(sigma+) from g(r) / virial, mean +- se; paired difference to the summary's")
    for k, v in res.items():
        v = np.array(v)
        d = v - base
        se = lambda x: x.std(ddof=1) / np.sqrt(len(x)) if len(x) > 1 else np.nan
        print(f"  {k:55s} {v.mean():.5f} +- {se(v):.5f}   {d.mean():+.5f} +- {se(d):.5f}")
    if tails:
        t = np.array(tails)
        print(f"  tail mean of g over 10 sigma ... L/2: {t[:, 0].mean():.6f} +- {t[:, 0].std(ddof=1) / np.sqrt(len(t)) if len(t) > 1 else np.nan:.6f}"
              f"  (1 + (1 - S(0))/N = {t[:, 1].mean():.6f})")


if __name__ == "__main__":
    main(sys.argv[1:])
