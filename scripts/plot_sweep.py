#!/usr/bin/python3
"""Plot a `grainbath sweep` table: every measured headline quantity (with its standard error)
against the first swept key, theory columns of the same kind as lines. Writes sweep.png."""
import csv
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# measured quantity -> (its stderr column, theory columns drawn beside it, axis label)
PAIRS = {
    "temperature.mean": ("temperature.stderr",
                         ["theory.equilibrium.maxwellian.T", "theory.equilibrium.grad.T",
                          "theory.equilibrium.sonine.T", "theory.expansion.first_order.T"],
                         "steady temperature T# [energy]"),
    "mode.decay_rate": ("mode.decay_rate_stderr",
                        ["theory.hydro.decay_rate", "theory.hydro.decay_rate_kinetic",
                         "theory.hydro.decay_rate_maxwellian_closure"],
                        "density-mode decay rate [1/time]"),
    "profile.exponent": ("profile.exponent_stderr",
                         ["theory.hydro.thermal_diffusion_exponent",
                          "theory.hydro.thermal_diffusion_exponent_kinetic"],
                         "exponent p of n ~ TB^-p"),
    "pressure.Z": ("pressure.Z_stderr", [], "compressibility Z"),
}


def main(sweep_dir):
    rows = list(csv.DictReader(open(Path(sweep_dir) / "sweep.tsv"), delimiter="\t"))
    if not rows:
        sys.exit("empty sweep table")
    keys = list(rows[0].keys())
    axis = keys[1]  # first swept key
    try:
        x = [float(r[axis]) for r in rows]
    except ValueError:
        x = list(range(len(rows)))
    panels = [m for m in PAIRS if m in keys and any(r[m] for r in rows)]
    if not panels:
        sys.exit("no headline quantity to plot")
    fig, axes = plt.subplots(len(panels), 1, figsize=(6.4, 3.6 * len(panels)), squeeze=False)
    order = sorted(range(len(x)), key=lambda i: x[i])
    for ax, m in zip(axes[:, 0], panels):
        err_key, theory, label = PAIRS[m]
        y = [float(rows[i][m]) if rows[i][m] else math.nan for i in order]
        e = [float(rows[i][err_key]) if rows[i].get(err_key) else 0.0 for i in order]
        xs = [x[i] for i in order]
        ax.errorbar(xs, y, yerr=e, fmt="o", color="k", capsize=3, label="DSMC (± 1 s.e.)")
        for t in theory:
            if t in keys and any(r[t] for r in rows):
                ax.plot(xs, [float(rows[i][t]) if rows[i][t] else math.nan for i in order], "-",
                        label=t.replace("theory.", ""))
        ax.set_xlabel(axis)
        ax.set_ylabel(label)
        if min(xs) > 0 and max(xs) / min(xs) > 8:
            ax.set_xscale("log")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(Path(sweep_dir) / "sweep.png", dpi=110)


if __name__ == "__main__":
    main(sys.argv[1])
