#!/usr/bin/env python3
"""Plots the heat-bath runs beside the trends Bizon et al. (1999) report at nu = 0.5, T ~ 1:
G_s vs the Carnahan-Starling G (Fig. 5: white noise and air table below, Boltzmann slightly
above), g(r) with g(sigma) against G_s/nu (Fig. 4), velocity correlations (Fig. 7), the
distribution of normal collision speeds (Fig. 10) and gamma/gamma_e (Fig. 8b).

    /usr/bin/python3 cases/bizon-heat-baths/plot.py [--out DIR]

Writes heat_baths.png and heat_baths.csv into DIR (default: output/ beside this script, which
git ignores), then compares the table with the shipped heat_baths.csv beside this script (the
reference; scripts/compare_tables.py). `--out cases/bizon-heat-baths` replaces the reference."""
import argparse
import csv
import json
import os
import subprocess
import sys

import h5py
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--out", default=os.path.join(here, "output"), help="where the table and figure go")
out = ap.parse_args().out
os.makedirs(out, exist_ok=True)
runs = {"white noise": "white-noise/output", "air table": "air-table/output", "Boltzmann": "boltzmann/output",
        "elastic": "elastic/output"}
nu = 0.5
G_cs = nu * (16 - 7 * nu) / (16 * (1 - nu) ** 2)  # Bizon eq. 5

if not any(os.path.exists(os.path.join(here, d, "summary.json")) for d in runs.values()):
    raise SystemExit(f"plot.py: no finished runs in {here}/<bath>/output (run.sh makes them)")
fig, ax = plt.subplots(2, 3, figsize=(15, 8))
rows = []
for name, d in runs.items():
    path = os.path.join(here, d)
    if not os.path.exists(os.path.join(path, "summary.json")):
        continue
    s = json.load(open(os.path.join(path, "summary.json")))
    h = h5py.File(os.path.join(path, "results.h5"), "r")
    obs = h["observables"]
    r, g = obs["gr/r"][:], obs["gr/g"][:]
    ax[0, 0].plot(r, g, label=name)
    rc, par, perp = obs["velocity_correlation/r"][:], obs["velocity_correlation/parallel"][:], \
        obs["velocity_correlation/perpendicular"][:]
    ok = rc > 1
    ax[0, 1].plot(rc[ok], par[ok], label=name)
    ax[0, 2].plot(rc[ok], perp[ok], label=name)
    vn, dens = obs["normal_speed/vn_over_sqrtT"][:], obs["normal_speed/density"][:]
    ax[1, 0].plot(vn, dens, label=name)
    vx = obs["velocity_distribution/v_over_sqrtT"][:]
    ax[1, 1].semilogy(vx, obs["velocity_distribution/x"][:], label=name + " (x)")
    row = {"bath": name, "T": s["temperature"]["mean"], "T_err": s["temperature"]["stderr"],
           "Z": s["pressure"]["Z"], "Z_err": s["pressure"]["Z_stderr"], "G_s": s["pressure"]["G_s"],
           "G_s_over_G_cs": s["pressure"]["G_s"] / G_cs, "g_sigma_fit": s["g_r"]["contact_fit"],
           "g_sigma_collisions": s["g_r"].get("contact_from_collisions", float("nan")),
           "G_s_over_nu": s["pressure"]["G_s"] / nu, "mean_e": s["restitution"]["mean_e"],
           "gamma_over_gamma0": s["loss"].get("gamma_over_gamma0", float("nan")),
           "gamma_over_gamma_e": s["loss"].get("gamma_over_gamma_e", float("nan")),
           "velocity_ratio_eq33": s["loss"]["velocity_ratio"], "a2": s["velocity"]["a2"],
           "corr_par_at_2sigma": float(np.interp(2.0, rc, par)), "corr_perp_at_2sigma": float(np.interp(2.0, rc, perp))}
    rows.append(row)
x = np.linspace(0, 4, 200)
ax[1, 0].plot(x, 0.5 * x * np.exp(-x ** 2 / 4), "k--", label="molecular chaos")
ax[1, 1].semilogy(x, np.exp(-x ** 2 / 2) / np.sqrt(2 * np.pi), "k--", label="Maxwell")
ax[0, 0].axhline(G_cs / nu, color="k", ls=":", label="CS g(σ) (eq. 5)")
ax[0, 0].set_xlim(0.9, 4), ax[0, 0].set_xlabel("r/σ"), ax[0, 0].set_ylabel("g(r)"), ax[0, 0].legend()
ax[0, 1].set_xlabel("r/σ"), ax[0, 1].set_ylabel("<v1∥ v2∥>/T (eq. 25)"), ax[0, 1].axhline(0, color="k", lw=0.5)
ax[0, 2].set_xlabel("r/σ"), ax[0, 2].set_ylabel("<v1⊥ v2⊥>/T (eq. 26)"), ax[0, 2].axhline(0, color="k", lw=0.5)
ax[0, 1].legend()
ax[1, 0].set_xlabel("v_n/√T"), ax[1, 0].set_ylabel("P(v_n) at collision"), ax[1, 0].set_xlim(0, 5), ax[1, 0].legend()
ax[1, 1].set_xlabel("v_x/√T"), ax[1, 1].set_ylabel("P"), ax[1, 1].set_ylim(1e-5, 1), ax[1, 1].legend(fontsize=7)
names = [r["bath"] for r in rows]
ax[1, 2].bar(np.arange(len(rows)) - 0.2, [r["G_s_over_G_cs"] for r in rows], 0.4, label="G_s / G_CS (Fig. 5b)")
ax[1, 2].bar(np.arange(len(rows)) + 0.2, [r["gamma_over_gamma_e"] for r in rows], 0.4, label="γ/γ_e (Fig. 8b)")
ax[1, 2].set_xticks(range(len(rows)), names), ax[1, 2].axhline(1, color="k", lw=0.5), ax[1, 2].set_ylim(0.6, 1.3)
ax[1, 2].legend()
fig.suptitle("Bizon et al. heat baths, ν = 0.5, T ≈ 1 (paper: white noise and air table G_s < G_CS, Boltzmann ≥; "
             "γ/γ_e < 1 tracks the collision-velocity reduction)", fontsize=9)
fig.tight_layout()
fig.savefig(os.path.join(out, "heat_baths.png"), dpi=110)
with open(os.path.join(out, "heat_baths.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)
for r in rows:
    print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items()))
print(f"wrote {os.path.join(out, 'heat_baths.csv')} and heat_baths.png beside it")
if os.path.realpath(out) != os.path.realpath(here):
    subprocess.run([sys.executable, os.path.join(here, "..", "..", "scripts", "compare_tables.py"),
                    os.path.join(here, "heat_baths.csv"), os.path.join(out, "heat_baths.csv")], check=True)
