#!/usr/bin/python3
"""Thesis Fig. 10.9 setting: Ttr(t), Trot(t) of the driven rough gas (mu = inf and 0.5) from the
EDMD beside mean-field models A-E, and the steady R = Trot/Ttr vs mu (EDMD, event-free MC, models).
    /usr/bin/python3 cases/rough-driven/plot.py [--out DIR]     -> DIR/rough_driven.png
DIR (default output/ beside this script, which git ignores) holds edmd_curves.csv and
edmd_r_vs_mu.csv (collect.py --out DIR, from the EDMD runs of run.sh); r_vs_mu.csv (models and
the event-free MC) is the shipped one beside this script, written by
    GRAINBATH_ROUGH_CURVES_DIR=$PWD/cases/rough-driven build/tests/rough/rough_driven_mc --gtest_filter='RoughDrivenCase.*'
`--out cases/rough-driven` plots the shipped tables and replaces the shipped figure."""
import argparse
import csv
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

here = os.path.dirname(os.path.abspath(__file__))
ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--out", default=os.path.join(here, "output"), help="collect.py's tables; the figure goes there")
out_dir = ap.parse_args().out


def rows(folder, name):
    path = os.path.join(folder, name)
    if not os.path.exists(path):
        raise SystemExit(f"plot.py: {path}: no such file (collect.py --out {folder} writes it)")
    with open(path) as f:
        return list(csv.DictReader(f))


curves, edmd_r = rows(out_dir, "edmd_curves.csv"), rows(out_dir, "edmd_r_vs_mu.csv")
rmu = rows(here, "r_vs_mu.csv")
colors = {"A": "tab:gray", "B": "tab:orange", "C": "tab:green", "D": "tab:purple", "E": "k"}
fig, axes = plt.subplots(2, 2, figsize=(12, 9.5))
for ax, mu, tag in [(axes[0, 0], "inf", "(a) μ = ∞"), (axes[0, 1], "0.5", "(b) μ = 0.5")]:
    sim = [r for r in curves if r["mu"] == mu and float(r["t_nu0"]) > 0]
    t = [float(r["t_nu0"]) for r in sim]
    ax.plot(t, [float(r["Ttr"]) for r in sim], "o", ms=3, color="tab:blue", label="EDMD Ttr")
    ax.plot(t, [float(r["Trot"]) for r in sim], "s", ms=3, color="tab:red", label="EDMD Trot")
    for m in "ABCDE":
        lw = 2.0 if m == "E" else 1.0
        ax.plot(t, [float(r["Ttr_" + m]) for r in sim], "-", lw=lw, color=colors[m], label=f"model {m} Ttr")
        ax.plot(t, [float(r["Trot_" + m]) for r in sim], "--", lw=lw, color=colors[m], label=f"model {m} Trot")
    ax.set_xscale("log"), ax.set_yscale("log")
    ax.set_ylim(0.02, 1.5)
    ax.set_xlabel("t  [1/ν(0), ν(0) = G √Ttr(0), Enskog]"), ax.set_ylabel("T / Ttr(0)")
    ax.set_title(f"{tag}: α = 0.95, β0 = 1, q = 2/5, N = 11025, φ = 0.0866", fontsize=10)
axes[0, 0].legend(fontsize=6, ncol=2, loc="lower left")

ax = axes[1, 0]
mus = [float(r["mu"]) for r in rmu]
for m in "ABCDE":
    ax.plot(mus, [float(r["R_" + m]) for r in rmu], "-", lw=2.0 if m == "E" else 1.0, color=colors[m], label=f"model {m}")
ax.errorbar(mus, [float(r["R_MC"]) for r in rmu], yerr=[float(r["R_MC_stderr"]) for r in rmu],
            fmt="o", ms=4, mfc="none", color="tab:blue", label="event-free MC (N = 2000, φ → 0)")
fin = [r for r in edmd_r if float(r["mu"]) < 1e6]
for r in fin:  # over the seeds when run.sh ran several (the blocked error of one run is too small)
    if int(r.get("seeds") or 1) > 1:
        r["R"], r["R_stderr"] = r["R_seeds"], r["R_seeds_sem"]
ax.errorbar([float(r["mu"]) for r in fin], [float(r["R"]) for r in fin], yerr=[float(r["R_stderr"]) for r in fin],
            fmt="D", ms=4, color="tab:red", label="EDMD (N = 11025, φ = 0.0866)")
small = [m for m in mus if m <= 0.2]
ax.plot(small, [(1 + 0.95) * m for m in small], ":", color="tab:red", label="(1 + e) μ")
ax.set_xscale("log"), ax.set_yscale("log")
ax.set_xlabel("μ"), ax.set_ylabel("R = Trot / Ttr (steady)")
ax.set_title("(c) steady R vs μ; slope 1 = linear (μ = ∞: R = 1 for all models)", fontsize=10)
ax.legend(fontsize=7)

ax = axes[1, 1]
ax.axhline(0, color="k", lw=2, label="model E")
for m in "BCD":
    ax.plot([float(r["mu"]) for r in fin], [100 * (float(r["R_" + m]) / float(r["R_E"]) - 1) for r in fin], "-",
            color=colors[m], label=f"model {m}")
ax.errorbar(mus, [100 * (float(r["R_MC"]) / float(r["R_E"]) - 1) for r in rmu],
            yerr=[100 * float(r["R_MC_stderr"]) / float(r["R_E"]) for r in rmu], fmt="o", mfc="none",
            color="tab:blue", label="event-free MC")
ax.errorbar([float(r["mu"]) for r in fin], [100 * (float(r["R"]) / float(r["R_E"]) - 1) for r in fin],
            yerr=[100 * float(r["R_stderr"]) / float(r["R_E"]) for r in fin], fmt="D", color="tab:red", label="EDMD")
ax.set_xscale("log"), ax.set_ylim(-15, 15)
ax.set_xlabel("μ"), ax.set_ylabel("R / R_E − 1  [%]")
ax.set_title("(d) deviation from model E (B, C, D leave the frame at small μ)", fontsize=10)
ax.legend(fontsize=7)
fig.tight_layout()
out = os.path.join(out_dir, "rough_driven.png")
fig.savefig(out, dpi=100)
print("wrote", out)
