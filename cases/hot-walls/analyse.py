#!/usr/bin/env python3
"""The bulk and the wall layers of cases/hot-walls, beside the homogeneous theory.

  build/grainbath run cases/hot-walls
  /usr/bin/python3 cases/hot-walls/analyse.py [--out DIR] [--grainbath PATH] [--bulk-from D]

Reads OUT/results.h5 (default cases/hot-walls/output) and prints
  - the bulk (cells farther than D = 1 from both walls, ten eps): density and temperature,
    averaged with the per-cell batch errors (inflated by sqrt(chi2/dof) when the cells
    scatter more than their errors say);
  - the homogeneous collision equilibrium at the bulk's density from `grainbath theory`
    (Sonine, Grad and local-Maxwellian roots of Bisi-Spiga eq. 27, first-order expansion),
    and at the box's mean density for contrast;
  - the wall layer: the e-folding length of T(x) - T_bulk near the walls (both walls
    folded onto one), in units of eps;
  - the heat the walls put in per unit wall area and time in the window.
Writes OUT/hot-walls.png (n(x) and T(x) with the bulk and theory lines) and
OUT/profile.csv (x, n, n_err, T, T_err)."""
import argparse
import json
import os
import subprocess
import sys

import h5py
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))


def weighted_mean(values, errors):
    w = 1.0 / errors**2
    mean = float((values * w).sum() / w.sum())
    err = float(1.0 / np.sqrt(w.sum()))
    dof = len(values) - 1
    chi2 = float((((values - mean) / errors) ** 2).sum() / dof) if dof > 0 else 1.0
    return mean, err * np.sqrt(max(1.0, chi2)), chi2


def theory(grainbath, density):
    r = subprocess.run([grainbath, "theory", here, "--set", f"grains.density={density!r}"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"analyse.py: `{grainbath} theory` failed:\n{r.stderr}")
    eq = json.loads(r.stdout)
    return {"Sonine": eq["equilibrium"]["sonine"]["T"], "Grad": eq["equilibrium"]["grad"]["T"],
            "local Maxwellian": eq["equilibrium"]["maxwellian"]["T"],
            "first order T0 + eps T1": eq["expansion"]["first_order"]["T"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(here, "output"))
    ap.add_argument("--grainbath", default=os.path.join(here, "..", "..", "build", "grainbath"))
    ap.add_argument("--bulk-from", type=float, default=1.0, help="distance from the walls where the bulk starts")
    a = ap.parse_args()
    path = os.path.join(a.out, "results.h5")
    if not os.path.exists(path):
        sys.exit(f"analyse.py: {path} not found: run `grainbath run {os.path.relpath(here)}` first")
    f = h5py.File(path, "r")
    x = f["fields/x"][:]
    n, n_err = f["fields/density"][0, 0], f["fields/density_stderr"][0, 0]
    T, T_err = f["fields/temperature"][0, 0], f["fields/temperature_stderr"][0, 0]
    L = float(f["fields/x"][-1] + f["fields/x"][0])
    eps = float(f["parameters"].attrs["background.knudsen"])
    Tw = float(f["parameters"].attrs["domain.wall_temperature"])
    n_mean = float(f["parameters"].attrs["grains.density"])
    t = f["timeseries/t"][:]
    t0 = float(f["parameters"].attrs["sampling.steady_from"])

    bulk = (x > a.bulk_from) & (x < L - a.bulk_from)
    if bulk.sum() < 2:
        sys.exit(f"analyse.py: no bulk: --bulk-from {a.bulk_from} leaves fewer than 2 cells of a box of length {L}")
    nb, nb_err, n_chi2 = weighted_mean(n[bulk], n_err[bulk])
    Tb, Tb_err, T_chi2 = weighted_mean(T[bulk], T_err[bulk])
    print(f"box length L = {L:g} = {L / eps:g} eps, walls at Tw = {Tw:g}; bulk: {bulk.sum()} cells "
          f"with {a.bulk_from:g} < x < {L - a.bulk_from:g}")
    print(f"bulk density      n_bulk = {nb:.5f} +- {nb_err:.5f}   (box mean {n_mean:g}; chi2/dof {n_chi2:.2f})")
    print(f"bulk temperature  T_bulk = {Tb:.5f} +- {Tb_err:.5f}   (chi2/dof {T_chi2:.2f})")
    print()
    at_bulk, at_mean = theory(a.grainbath, nb), theory(a.grainbath, n_mean)
    print("homogeneous equilibrium T#      at n_bulk   T_bulk - T# (sigma)    at the mean n")
    for k in at_bulk:
        d = Tb - at_bulk[k]
        print(f"  {k:26s}  {at_bulk[k]:.5f}   {d:+.5f} ({d / Tb_err:+.1f})        {at_mean[k]:.5f}")

    # the layer: fold both walls onto distance s from the nearest wall, and fit
    # ln(T - T_bulk) against s where the excess is well above its error
    s = np.minimum(x, L - x)
    excess = T - Tb
    use = (s < a.bulk_from) & (excess > 5 * np.hypot(T_err, Tb_err))
    ell = float("nan")
    if use.sum() >= 3:
        wts = (excess[use] / T_err[use]) ** 2  # 1/var of ln(excess)
        A = np.vstack([np.ones(use.sum()), s[use]]).T
        coef = np.linalg.lstsq(A * np.sqrt(wts)[:, None], np.log(excess[use]) * np.sqrt(wts), rcond=None)[0]
        ell = -1.0 / coef[1]
        print()
        print(f"wall layer: T - T_bulk ~ exp(-s/l) over s in [{s[use].min():.3f}, {s[use].max():.3f}]: "
              f"l = {ell:.4f} = {ell / eps:.2f} eps; T in the first cell {T[0]:.4f}, {T[-1]:.4f} (Tw = {Tw:g})")
    w = t >= t0
    wall = f["timeseries/wall_energy_input_per_grain"][:]
    if w.sum() >= 2:
        slope = np.polyfit(t[w], wall[w], 1)[0]
        q = slope * n_mean * L / 2  # per grain and time -> per unit wall area (1D: per unit cross-section), per wall
        print(f"heat from each wall per unit area and time: {q:.4f} (the walls' energy input, t >= {t0:g})")

    with open(os.path.join(a.out, "profile.csv"), "w") as out:
        out.write("x,density,density_stderr,temperature,temperature_stderr\n")
        for row in zip(x, n, n_err, T, T_err):
            out.write(",".join(f"{v:.8g}" for v in row) + "\n")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not found: no figure (Debian: python3-matplotlib)")
        return
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].errorbar(x, n, n_err, fmt=".", ms=3, label="DSMC")
    ax[0].axhline(nb, color="k", lw=0.8, label=f"bulk {nb:.4f}")
    ax[0].axhline(n_mean, color="gray", ls=":", lw=0.8, label=f"box mean {n_mean:g}")
    ax[0].set_xlabel("x [grain mean free paths]")
    ax[0].set_ylabel("grain density n")
    ax[0].legend()
    ax[1].errorbar(x, T, T_err, fmt=".", ms=3, label="DSMC")
    ax[1].axhline(at_bulk["Sonine"], color="r", lw=0.8, label=f"Sonine T# at n_bulk {at_bulk['Sonine']:.4f}")
    ax[1].axhline(Tb, color="k", lw=0.8, ls="--", label=f"bulk {Tb:.4f}")
    ax[1].set_ylim(min(T.min(), at_bulk["Sonine"]) - 0.01, min(T.max(), Tw) + 0.02)
    ax[1].set_xlabel("x [grain mean free paths]")
    ax[1].set_ylabel("grain temperature T")
    ax[1].legend()
    fig.suptitle(f"grains in a bath between diffuse walls at Tw = {Tw:g} (eps = {eps:g})")
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "hot-walls.png"), dpi=110)
    print(f"figure: {os.path.join(a.out, 'hot-walls.png')}; profile: {os.path.join(a.out, 'profile.csv')}")


if __name__ == "__main__":
    main()
