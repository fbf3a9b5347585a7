#!/usr/bin/env python3
"""Bizon et al. (1999) Sec. V B, Figs. 14-17: velocity profile, normal stress difference, P_xy vs du_x/dy,
mu/mu_Enskog.

Reads every nu*/output/{results.h5,summary.json} of this case; writes viscosity.png and
viscosity.csv (one row per run) into --out DIR (default output/ beside this script, which git
ignores) and compares the table with the shipped viscosity.csv. Bizon's (y, z) are grainbath's (x, y) in 2D."""
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

fig, ax = plt.subplots(1, 4, figsize=(21, 4.8))
markers = "osD^v<>p"
pick = next((r for r in runs if r[0].endswith("-a1")), runs[0])
name, s, f = pick
t = s["transport"]
L = f["z_slab"][-1] + f["z_slab"][0]
ax[0].errorbar(f["z_slab"] / L, f["u_c"], f["u_c_stderr"], fmt="ko", ms=4, label="u_x (slab time average)")
zz = np.linspace(0, 1, 200)
ax[0].plot(zz, t["velocity_amplitude"] * np.sin(2 * np.pi * zz), "k--", lw=0.8, label="forced mode")
ax0b = ax[0].twinx()
ax0b.plot(f["z_slab"] / L, f["forcing_density"], "r.", label="body force density")
ax0b.set_ylabel("body force density (red)", color="r")
ax[0].set_xlabel("y / L")
ax[0].set_ylabel("u_x  [v0]")
ax[0].set_title(f"{name}: velocity profile (Bizon Fig. 14)")
ax[0].legend(fontsize=7, loc="lower left")
ax[1].errorbar(f["dudz"], f["P_cz"], xerr=f["dudz_stderr"], yerr=f["P_cz_stderr"], fmt="ko", ms=4, label="planes")
g = np.linspace(f["dudz"].min(), f["dudz"].max(), 10)
ax[1].plot(g, t["fit_intercept"] - t["mu"] * g, "b-", label=f"best line, mu = {t['mu']:.3g}")
ax[1].plot(g, -t["mu_enskog"] * g, "g--", label=f"Enskog eq. 16, mu0 = {t['mu_enskog']:.3g}")
ax[1].set_xlabel("du_x/dy")
ax[1].set_ylabel("P_xy (kinetic + collisional, through planes)")
ax[1].set_title(f"{name}: Newton's law (Bizon Fig. 16)")
ax[1].legend(fontsize=7)
rows = []
for m, (name, s, f) in zip(markers, runs):
    t = s["transport"]
    ax[2].errorbar(t["T_mean"], t["mu_mode_over_enskog"], t["mu_mode_over_enskog_stderr"], fmt=m, color="k", ms=6,
                   label=f"{name} (forced mode)")
    ax[2].errorbar(t["T_mean"] * 1.08, t["mu_over_enskog"], t["mu_over_enskog_stderr"], fmt=m, mfc="none", color="b",
                   ms=6, label=f"{name} (slope fit)")
    ax[3].errorbar(1.0 - s["restitution"]["mean_e"], t["normal_stress_difference"],
                   t["normal_stress_difference_stderr"], fmt=m, color="k", ms=6, label=name)
    rows.append(dict(run=name, packing=t["packing_mean"], T_mean=t["T_mean"], mean_e=s["restitution"]["mean_e"],
                     mu_mode=t["mu_mode"], mu_mode_stderr=t["mu_mode_stderr"], mu_fit=t["mu"], mu_fit_stderr=t["mu_stderr"],
                     mu_enskog=t["mu_enskog"], mu_mode_over_enskog=t["mu_mode_over_enskog"],
                     mu_mode_over_enskog_stderr=t["mu_mode_over_enskog_stderr"], mu_over_enskog=t["mu_over_enskog"],
                     mu_over_enskog_stderr=t["mu_over_enskog_stderr"], mu_from_forcing=t["mu_from_forcing"],
                     mu_from_forcing_stderr=t["mu_from_forcing_stderr"], mach_max=t["mach_max"],
                     anisotropy=t["anisotropy"], normal_stress_difference=t["normal_stress_difference"],
                     normal_stress_difference_stderr=t["normal_stress_difference_stderr"],
                     P_xx=t["P_cc_mean"], P_yy=t["P_zz_mean"], P_yy_planes=t["P_zz_planes_mean"],
                     momentum_balance_residual=t["momentum_balance_residual"],
                     wall_seconds=s["performance"]["wall_seconds"]))
ax[2].set_xscale("log")
ax[2].set_xlim(1e-3, 1e2)
ax[2].axhline(1.0, color="k", lw=0.8)
ax[2].axhspan(0.85, 1.15, color="gray", alpha=0.15, label="Bizon: within 15 %")
ax[2].set_ylim(0, 2)
ax[2].set_xlabel("T  [v0^2]")
ax[2].set_ylabel("mu / mu_Enskog")
ax[2].set_title("Bizon Fig. 17 (nu = 0.6)")
ax[2].legend(fontsize=6)
ax[3].axhline(0.0, color="k", lw=0.8)
ax[3].set_xlim(0, 0.35)
ax[3].set_xlabel("1 - <e>  (mean over collisions)")
ax[3].set_ylabel("(P_xx - P_yy) / P  (slab virial, box average)")
ax[3].set_title("normal stress difference (Bizon Fig. 15)")
ax[3].legend(fontsize=7)
fig.tight_layout()
save(here, out, "viscosity", fig, rows)
