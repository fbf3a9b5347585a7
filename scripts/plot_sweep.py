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
    axis = keys[1]  # first swept key: the x axis
    swept = [k for k in keys[1:] if not k.startswith(("temperature", "a2", "mode", "profile", "pressure",
                                                       "theory", "counters", "energy", "performance",
                                                       "run", "solver", "velocity", "histogram"))]
    group_key = swept[1] if len(swept) > 1 else None  # second swept key: one series per value
    groups = {}
    for r in rows:
        groups.setdefault(r[group_key] if group_key else "", []).append(r)

    def xval(r):
        try:
            return float(r[axis])
        except ValueError:
            return rows.index(r)

    panels = [m for m in PAIRS if m in keys and any(r[m] for r in rows)]
    if not panels:
        sys.exit("no headline quantity to plot")
    fig, axes = plt.subplots(len(panels), 1, figsize=(6.8, 4.0 * len(panels)), squeeze=False)
    markers = "osD^v<>"
    for ax, m in zip(axes[:, 0], panels):
        err_key, theory, label = PAIRS[m]
        for gi, (gval, grows) in enumerate(sorted(groups.items())):
            grows = sorted(grows, key=xval)
            xs = [xval(r) for r in grows]
            tag = f" ({group_key} = {gval})" if group_key else ""
            y = [float(r[m]) if r[m] else math.nan for r in grows]
            e = [float(r[err_key]) if r.get(err_key) else 0.0 for r in grows]
            ax.errorbar(xs, y, yerr=e, fmt=markers[gi % len(markers)], color="k", capsize=3, ms=5,
                        mfc="white" if gi % 2 else "k", label="DSMC (± 1 s.e.)" + tag)
            for ti, t in enumerate(theory):
                if t in keys and any(r[t] for r in grows):
                    ax.plot(xs, [float(r[t]) if r[t] else math.nan for r in grows], ["-", "--", "-.", ":"][ti % 4],
                            color=f"C{ti}", alpha=1.0 if gi == 0 else 0.6,
                            label=t.replace("theory.", "") + tag)
        ax.set_xlabel(axis)
        ax.set_ylabel(label)
        xs_all = [xval(r) for r in rows]
        if min(xs_all) > 0 and max(xs_all) / min(xs_all) > 8:
            ax.set_xscale("log")
        ax.legend(fontsize=7, ncol=1 if not group_key else 2, loc="best")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(Path(sweep_dir) / "sweep.png", dpi=110)


if __name__ == "__main__":
    main(sys.argv[1])
