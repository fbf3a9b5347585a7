#!/usr/bin/env python3
"""Bizon et al. (1999) Sec. V A, Figs. 11-13: profiles, heat flux and kappa/kappa_Enskog.

Reads every nu*/output/{results.h5,summary.json} of this case; writes conductivity.png and
conductivity.csv (one row per run) into --out DIR (default output/ beside this script, which git
ignores) and compares the table with the shipped conductivity.csv. Run after run.sh (or by it)."""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(here, "..", "bizon-conductivity"))
from transport_runs import load_runs, output_dir, save  # noqa: E402

out = output_dir(here, __doc__)
runs = load_runs(here)

fig, ax = plt.subplots(1, 3, figsize=(16, 4.8))
markers = "osD^v<>p"
for m, (name, s, f) in zip(markers, runs):
    L = f["z_slab"][-1] + f["z_slab"][0]
    ax[0].semilogy(f["z_slab"] / L, f["T"] / s["transport"]["T_max"], m + "-", ms=3, label=name)
# flux check for the first nu = 0.75 run (or the first run)
pick = next((r for r in runs if r[0].startswith("nu0.75-a1")), runs[0])
name, s, f = pick
L = f["z_slab"][-1] + f["z_slab"][0]
z = f["z_plane"] / L
ax[1].errorbar(z, f["energy_flux"], f["energy_flux_stderr"], fmt="ko", ms=4, label="measured: kinetic + collisional")
ax[1].plot(z, f["energy_flux_kin"], "b.", label="kinetic part")
ax[1].plot(z, f["energy_flux_col"], "r.", label="collisional part")
ax[1].plot(z, f["energy_flux_balance"], "g-", label="input - loss - storage, from plane 0")
ax[1].plot(z, f["energy_flux_bizon"], "m--", label="Bizon: input - loss, zero flux at z = 0")
ax[1].axhline(0, color="gray", lw=0.5)
ax[1].set_xlabel("z / L")
ax[1].set_ylabel("energy flux q_z  [energy / (sigma time)]")
ax[1].set_title(f"{name}: heat flux through the slab planes")
ax[1].legend(fontsize=7)
rows = []
for m, (name, s, f) in zip(markers, runs):
    t = s["transport"]
    L = f["z_slab"][-1] + f["z_slab"][0]
    d = np.abs(f["z_plane"] - 0.5 * L) / (0.5 * L)
    sel = (d >= 0.2) & (d <= 0.8)
    fl = sel & (f["packing_plane"] < 0.70)  # fluid planes: filled; denser (crystallising): open
    dn = sel & ~fl
    eb = ax[2].errorbar(f["T_plane"][fl], f["kappa_ratio"][fl], f["kappa_ratio_stderr"][fl], fmt=m, ms=5,
                        label=f"{name} (nu_local < 0.70)")
    ax[2].errorbar(f["T_plane"][dn], f["kappa_ratio"][dn], f["kappa_ratio_stderr"][dn], fmt=m, ms=5, mfc="none",
                   color=eb[0].get_color(), label=f"{name} (nu_local >= 0.70)")
    rows.append(dict(run=name, packing_mean=t["packing_mean"], a0=name.split("-a")[1], T_fit=t["T_fit"],
                     T_min=t["T_min"], T_max=t["T_max"], kappa_over_enskog=t["kappa_over_enskog"],
                     kappa_over_enskog_stderr=t["kappa_over_enskog_stderr"],
                     kappa_over_enskog_fluid=t.get("kappa_over_enskog_fluid", float("nan")),
                     kappa_over_enskog_fluid_stderr=t.get("kappa_over_enskog_fluid_stderr", float("nan")),
                     T_fit_fluid=t.get("T_fit_fluid", float("nan")),
                     kappa_fit_planes=float(np.mean(f["kappa"][sel])),
                     kappa_enskog_fit_planes=float(np.mean(f["kappa_enskog"][sel])),
                     flux_over_bizon_integrated=t["flux_over_bizon_integrated"],
                     energy_balance_residual=t["energy_balance_residual"], mean_e=s["restitution"]["mean_e"],
                     wall_seconds=s["performance"]["wall_seconds"]))
ax[0].set_xlabel("z / L")
ax[0].set_ylabel("T / T_max")
ax[0].set_title("temperature profiles (forcing peaked at z = L/2)")
ax[0].legend(fontsize=7)
ax[2].set_xscale("log")
ax[2].axhline(1.0, color="k", lw=0.8)
ax[2].axhline(0.5, color="gray", ls=":", lw=0.8)
ax[2].set_ylim(0, 3)
ax[2].set_xlabel("local T  [v0^2]")
ax[2].set_ylabel("kappa / kappa_Enskog (eq. 17, local nu and T)")
ax[2].set_title("Bizon Fig. 13: planes at 0.2-0.8 of L/2 from the peak")
ax[2].legend(fontsize=6)
fig.tight_layout()
save(here, out, "conductivity", fig, rows)
