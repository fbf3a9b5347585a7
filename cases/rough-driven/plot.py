#!/usr/bin/python3
"""Thesis Fig. 10.9 setting: Ttr(t), Trot(t) of the driven rough gas (mu = inf and 0.5) from the
event-free Monte Carlo beside mean-field models A-E, and the steady R = Trot/Ttr vs mu.
    /usr/bin/python3 cases/rough-driven/plot.py [DIR]   -> DIR/rough_driven.png
DIR (default: this folder) holds theory_curves.csv, mc_curves.csv, r_vs_mu.csv, written by
    GRAINBATH_ROUGH_CURVES_DIR=DIR build-rough/tests/rough/rough_driven_mc --gtest_filter='RoughDrivenCase.*'
and, once the EDMD engine supports law = "walton", optionally mu-inf/output and
mu-0.5/output (summary.json: rotation.R, rotation.R_stderr, theory.model_E.R)."""
import csv
import json
import math
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

here = os.path.dirname(os.path.abspath(__file__))
d = sys.argv[1] if len(sys.argv) > 1 else here


def rows(name):
    with open(os.path.join(d, name)) as f:
        return list(csv.DictReader(f))


theory, mc, rmu = rows("theory_curves.csv"), rows("mc_curves.csv"), rows("r_vs_mu.csv")
colors = {"A": "tab:gray", "B": "tab:orange", "C": "tab:green", "D": "tab:purple", "E": "k"}
fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
for ax, mu, tag in [(axes[0], "inf", "(a) μ = ∞"), (axes[1], "0.5", "(b) μ = 0.5")]:
    sim = [r for r in mc if r["mu"] == mu and float(r["t"]) > 0]
    t = [float(r["t"]) for r in sim]
    ax.plot(t, [float(r["Ttr"]) for r in sim], "o", ms=3, color="tab:blue", label="MC Ttr")
    ax.plot(t, [float(r["Trot"]) for r in sim], "s", ms=3, color="tab:red", label="MC Trot")
    for m in "ABCDE":
        th = [r for r in theory if r["mu"] == mu and r["model"] == m and float(r["t"]) > 0]
        tt = [float(r["t"]) for r in th]
        lw = 2.0 if m == "E" else 1.0
        ax.plot(tt, [float(r["Ttr"]) for r in th], "-", lw=lw, color=colors[m], label=f"model {m} Ttr")
        ax.plot(tt, [float(r["Trot"]) for r in th], "--", lw=lw, color=colors[m], label=f"model {m} Trot")
    ax.set_xscale("log"), ax.set_yscale("log")
    ax.set_ylim(0.01, 1.5)
    ax.set_xlabel("t  [ν(0)⁻¹ = 1/(G √Ttr(0))]"), ax.set_ylabel("T / Ttr(0)")
    ax.set_title(f"{tag}: α = 0.95, β0 = 1, q = 2/5, N = 11025")
axes[0].legend(fontsize=6, ncol=2, loc="lower left")

ax = axes[2]
mus = [float(r["mu"]) for r in rmu]
for m in "ABCDE":
    ax.plot(mus, [float(r["R_" + m]) for r in rmu], "-", lw=2.0 if m == "E" else 1.0,
            color=colors[m], label=f"model {m}")
ax.errorbar(mus, [float(r["R_MC"]) for r in rmu], yerr=[float(r["R_MC_stderr"]) for r in rmu],
            fmt="o", ms=4, color="tab:blue", label="MC (N = 2000)")
small = [m for m in mus if m <= 0.2]
ax.plot(small, [(1 + 0.95) * m for m in small], ":", color="tab:red", label="(1 + e) μ")
for sub in ("mu-inf", "mu-0.5"):  # EDMD points, once the engine can run the case
    p = os.path.join(here, sub, "output", "summary.json")
    if os.path.exists(p):
        s = json.load(open(p))
        mu = math.inf if sub == "mu-inf" else 0.5
        ax.errorbar([min(mu, max(mus))], [s["rotation"]["R"]], yerr=[s["rotation"]["R_stderr"]],
                    fmt="D", color="tab:green", label=f"EDMD {sub}")
ax.set_xscale("log"), ax.set_yscale("log")
ax.set_xlabel("μ"), ax.set_ylabel("R = Trot / Ttr (steady)")
ax.set_title("steady R vs μ (α = 0.95, β0 = 1); slope 1 = linear")
ax.legend(fontsize=7)
fig.tight_layout()
out = os.path.join(d, "rough_driven.png")
fig.savefig(out, dpi=110)
print("wrote", out)
