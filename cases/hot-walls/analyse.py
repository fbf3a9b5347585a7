#!/usr/bin/env python3
"""The bulk and the wall layers of cases/hot-walls, beside the homogeneous theory.

  build/grainbath run cases/hot-walls
  /usr/bin/python3 cases/hot-walls/analyse.py [--out DIR [DIR ...]] [--grainbath PATH] [--bulk-from D]

Reads OUT/results.h5 (default cases/hot-walls/output; several directories: runs of the case
with other seeds, whose spread then gives the errors) and prints
  - the bulk (cells farther than D = 1 from both walls, ten eps): density and temperature,
    averaged with the per-cell batch errors (inflated by sqrt(chi2/dof) when the cells
    scatter more than their errors say);
  - the homogeneous collision equilibrium at the bulk's density from `grainbath theory`
    (Sonine, Grad and local-Maxwellian roots of Bisi-Spiga eq. 27, first-order expansion),
    and at the box's mean density for contrast;
  - the wall layer: the e-folding length of T(x) - T_bulk near the walls (both walls
    folded onto one), in units of eps;
  - the heat the walls put in per unit wall area and time in the window.
Writes hot-walls.png (n(x) and T(x) with the bulk and theory lines) and profile.csv (x, n,
n_err, T, T_err; averaged over the runs) into the first OUT."""
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


def load(out):
    path = os.path.join(out, "results.h5")
    if not os.path.exists(path):
        sys.exit(f"analyse.py: {path} not found: run `grainbath run {os.path.relpath(here)}` first")
    with h5py.File(path, "r") as f:
        r = {"x": f["fields/x"][:], "n": f["fields/density"][0, 0], "n_err": f["fields/density_stderr"][0, 0],
             "T": f["fields/temperature"][0, 0], "T_err": f["fields/temperature_stderr"][0, 0],
             "t": f["timeseries/t"][:], "wall": f["timeseries/wall_energy_input_per_grain"][:]}
        for key in ("background.knudsen", "domain.wall_temperature", "grains.density", "sampling.steady_from",
                    "run.seed"):
            r[key] = float(f["parameters"].attrs[key]) if key in f["parameters"].attrs else float("nan")
    return r


def layer_length(x, T, T_err, T_bulk, bulk_from):
    """e-folding length of T - T_bulk: both walls folded onto the distance s from the nearest
    wall, ln(T - T_bulk) fitted against s where the excess is well above its error."""
    L = float(x[-1] + x[0])
    s = np.minimum(x, L - x)
    excess = T - T_bulk
    use = (s < bulk_from) & (excess > 5 * T_err)
    if use.sum() < 3:
        return float("nan"), None
    wts = (excess[use] / T_err[use]) ** 2  # 1/var of ln(excess)
    A = np.vstack([np.ones(use.sum()), s[use]]).T
    coef = np.linalg.lstsq(A * np.sqrt(wts)[:, None], np.log(excess[use]) * np.sqrt(wts), rcond=None)[0]
    return -1.0 / coef[1], (float(s[use].min()), float(s[use].max()))


def mean_and_error(values):
    a = np.asarray(values, dtype=float)
    return float(a.mean()), float(a.std(ddof=1) / np.sqrt(len(a)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", nargs="+", default=[os.path.join(here, "output")],
                    help="one run's output directory, or several (seeds): then the errors are the seeds' spread")
    ap.add_argument("--grainbath", default=os.path.join(here, "..", "..", "build", "grainbath"))
    ap.add_argument("--bulk-from", type=float, default=1.0, help="distance from the walls where the bulk starts")
    a = ap.parse_args()
    runs = [load(out) for out in a.out]
    first = runs[0]
    x = first["x"]
    if any(len(r["x"]) != len(x) or not np.allclose(r["x"], x) for r in runs):
        sys.exit("analyse.py: the runs have different cells; pass runs of one case (seeds)")
    L = float(x[-1] + x[0])
    eps, Tw, n_mean = first["background.knudsen"], first["domain.wall_temperature"], first["grains.density"]
    t0 = first["sampling.steady_from"]
    bulk = (x > a.bulk_from) & (x < L - a.bulk_from)
    if bulk.sum() < 2:
        sys.exit(f"analyse.py: no bulk: --bulk-from {a.bulk_from} leaves fewer than 2 cells of a box of length {L}")

    per_run = []
    for r in runs:
        nb, nb_err, n_chi2 = weighted_mean(r["n"][bulk], r["n_err"][bulk])
        Tb, Tb_err, T_chi2 = weighted_mean(r["T"][bulk], r["T_err"][bulk])
        ell, span = layer_length(x, r["T"], r["T_err"], Tb, a.bulk_from)
        w = r["t"] >= t0
        # the walls' energy per grain and time -> per unit wall area (1D: per unit
        # cross-section, n_mean L grains) and per wall
        q = np.polyfit(r["t"][w], r["wall"][w], 1)[0] * n_mean * L / 2 if w.sum() >= 2 else float("nan")
        per_run.append(dict(nb=nb, nb_err=nb_err, n_chi2=n_chi2, Tb=Tb, Tb_err=Tb_err, T_chi2=T_chi2, ell=ell,
                            span=span, q=q, T_wall=(float(r["T"][0]), float(r["T"][-1]))))
    print(f"box length L = {L:g} = {L / eps:g} eps, walls at Tw = {Tw:g}; bulk: {bulk.sum()} cells "
          f"with {a.bulk_from:g} < x < {L - a.bulk_from:g}; {len(runs)} run(s)")
    if len(runs) == 1:
        p = per_run[0]
        nb, nb_err, Tb, Tb_err, ell, q = p["nb"], p["nb_err"], p["Tb"], p["Tb_err"], p["ell"], p["q"]
        print(f"bulk density      n_bulk = {nb:.5f} +- {nb_err:.5f}   (box mean {n_mean:g}; chi2/dof {p['n_chi2']:.2f})")
        print(f"bulk temperature  T_bulk = {Tb:.5f} +- {Tb_err:.5f}   (chi2/dof {p['T_chi2']:.2f})")
        print("  (one run: its batch errors understate the bulk density's error, about fivefold here: the bulk\n"
              "   trades grains with the layers through a slow density mode; pass several seeds' outputs)")
        ell_err = q_err = float("nan")
    else:
        nb, nb_err = mean_and_error([p["nb"] for p in per_run])
        Tb, Tb_err = mean_and_error([p["Tb"] for p in per_run])
        ell, ell_err = mean_and_error([p["ell"] for p in per_run])
        q, q_err = mean_and_error([p["q"] for p in per_run])
        print(f"bulk density      n_bulk = {nb:.5f} +- {nb_err:.5f}   (box mean {n_mean:g}; error: the runs' spread)")
        print(f"bulk temperature  T_bulk = {Tb:.6f} +- {Tb_err:.6f}")
    print()
    at_bulk, at_mean = theory(a.grainbath, nb), theory(a.grainbath, n_mean)
    print("homogeneous equilibrium T#      at n_bulk   T_bulk - T# (sigma)    at the mean n")
    for k in at_bulk:
        d = Tb - at_bulk[k]
        print(f"  {k:26s}  {at_bulk[k]:.5f}   {d:+.5f} ({d / Tb_err:+.1f})        {at_mean[k]:.5f}")
    print()
    if np.isfinite(ell):
        span = per_run[0]["span"]
        T_wall = np.mean([p["T_wall"] for p in per_run])
        err = f" +- {ell_err:.4f}" if np.isfinite(ell_err) else ""
        print(f"wall layer: T - T_bulk ~ exp(-s/l) (first run's fit range s in [{span[0]:.3f}, {span[1]:.3f}]): "
              f"l = {ell:.4f}{err} = {ell / eps:.2f} eps; T in the wall cells {T_wall:.4f} (Tw = {Tw:g})")
    else:
        print("wall layer: T - T_bulk is nowhere 5 sigma above its error near the walls (no layer to fit)")
    err = f" +- {q_err:.4f}" if np.isfinite(q_err) else ""
    print(f"heat from each wall per unit area and time: {q:.4f}{err} (the walls' energy input, t >= {t0:g})")

    # the profile (averaged over the runs; errors: one run's batch errors, or the runs' spread)
    n = np.mean([r["n"] for r in runs], axis=0)
    T = np.mean([r["T"] for r in runs], axis=0)
    if len(runs) == 1:
        n_err, T_err = first["n_err"], first["T_err"]
    else:
        n_err = np.std([r["n"] for r in runs], axis=0, ddof=1) / np.sqrt(len(runs))
        T_err = np.std([r["T"] for r in runs], axis=0, ddof=1) / np.sqrt(len(runs))
    outdir = a.out[0]
    with open(os.path.join(outdir, "profile.csv"), "w") as out:
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
    fig.savefig(os.path.join(outdir, "hot-walls.png"), dpi=110)
    print(f"figure: {os.path.join(outdir, 'hot-walls.png')}; profile: {os.path.join(outdir, 'profile.csv')}")


if __name__ == "__main__":
    main()
