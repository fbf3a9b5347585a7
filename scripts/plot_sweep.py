#!/usr/bin/python3
"""Plot a `grainbath sweep` table: every measured headline quantity (with its standard error)
against one swept key, theory columns of the same kind as lines, and under each the distance
(simulation − theory)/σ with ±2σ guides. Writes SWEEP_DIR/sweep.png.

The x axis follows the rule `grainbath report` uses (python/grainbath_report/axes.py, stated in
docs/OUTPUT.md "Sweep directories"): the numeric swept key with the most values, or --x KEY.

    /usr/bin/python3 scripts/plot_sweep.py SWEEP_DIR [--x KEY]
"""
import argparse
import csv
import json
import math
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# the rule of the x axis and of σ distances, shared with `grainbath report`
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python"))
from grainbath_report.axes import choose_x, error_verdict, identity_axes  # noqa: E402

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
    "pressure.Z": ("pressure.Z_stderr", ["theory.Z"], "compressibility Z"),
}
# summary prefixes: columns of sweep.tsv that are no swept key (for a sweep without sweep.identity)
SUMMARY_PREFIXES = ("temperature", "a2", "a3", "mode", "profile", "pressure", "theory", "counters", "energy",
                    "performance", "run", "solver", "velocity", "histogram", "rotation", "resolution", "collision",
                    "loss", "haff", "g_r", "transport", "checkpoint")


def _float(s):
    try:
        return float(s)
    except (TypeError, ValueError):
        return math.nan


def _plateau(s):
    """A `_plateau` cell of sweep.tsv (1, 0 or empty) as True, False or None."""
    return None if s in (None, "") else _float(s) != 0.0


def read_sweep(sweep_dir):
    """The rows of sweep.tsv, its swept keys and each variant's solver."""
    path = Path(sweep_dir) / "sweep.tsv"
    with open(path, encoding="utf-8") as f:
        rows = list(csv.DictReader(f, delimiter="\t"))
    if not rows:
        raise ValueError(f"{path}: no rows")
    keys = list(rows[0].keys())
    axes = identity_axes(sweep_dir)
    if axes is None or not all(k in keys for k in axes):
        axes = [k for k in keys[1:] if not k.startswith(SUMMARY_PREFIXES)]
    for r in rows:  # the solver is a string, which sweep.tsv leaves out: from the variant's summary
        try:
            with open(Path(sweep_dir) / r["variant"] / "summary.json", encoding="utf-8") as f:
                s = json.load(f)
            r["@solver"] = s.get("run", {}).get("solver") or s.get("solver")
        except (OSError, ValueError, AttributeError):
            r["@solver"] = None
    return rows, keys, axes


def sigma(r, m, err_key, t):
    """(simulation − theory)/σ of one row, or nan where the rule gives no σ distance."""
    v, th, e = _float(r.get(m)), _float(r.get(t)), _float(r.get(err_key))
    if not (math.isfinite(v) and math.isfinite(th) and math.isfinite(e) and e > 0):
        return math.nan
    if error_verdict(r["@solver"], err_key, e, _plateau(r.get(err_key + "_plateau"))):
        return math.nan
    return (v - th) / e


def make_figure(sweep_dir, x=None):
    """The figure of sweep.png (raises ValueError for an unusable table or --x)."""
    rows, keys, axes = read_sweep(sweep_dir)
    axis, group_keys = choose_x({k: [r[k] for r in rows] for k in axes}, x)
    if axis is None:
        raise ValueError("no numeric swept key to plot against")
    groups = {}
    for r in rows:  # one series per combination of the other swept keys
        groups.setdefault(", ".join(f"{k} = {r[k]}" for k in group_keys), []).append(r)

    panels = [m for m in PAIRS if m in keys and any(r[m] for r in rows)]
    if not panels:
        raise ValueError("no headline quantity to plot")
    fig, axs = plt.subplots(2 * len(panels), 1, figsize=(9.5, 5.6 * len(panels)), squeeze=False,
                            gridspec_kw={"height_ratios": [3, 1.6] * len(panels)})
    markers = "osD^v<>"
    styles = ["-", "--", "-.", ":"]
    for pi, m in enumerate(panels):
        ax, axr = axs[2 * pi, 0], axs[2 * pi + 1, 0]
        axr.sharex(ax)
        axr.axhline(0.0, color="0.4", lw=0.8)  # the guides first: axr.lines[3:] are the distances
        for g in (-2.0, 2.0):
            axr.axhline(g, color="0.55", lw=0.9, ls="--")
        err_key, theory, label = PAIRS[m]
        have = [t for t in theory if t in keys and any(r[t] for r in rows)]
        for gi, (gval, grows) in enumerate(sorted(groups.items())):
            grows = sorted(grows, key=lambda r: _float(r[axis]))
            xs = [_float(r[axis]) for r in grows]
            tag = f" ({gval})" if gval else ""
            y = [_float(r[m]) for r in grows]
            e = [_float(r.get(err_key)) if r.get(err_key) else 0.0 for r in grows]
            ax.errorbar(xs, y, yerr=e, fmt=markers[gi % len(markers)], color="k", capsize=3, ms=5, zorder=5,
                        mfc="white" if gi % 2 else "k", label="simulation (± 1 s.e.)" + tag)
            for ti, t in enumerate(have):
                ax.plot(xs, [_float(r[t]) for r in grows], styles[ti % 4], color=f"C{ti}",
                        alpha=1.0 if gi == 0 else 0.6, label=t.replace("theory.", "") + tag)
                d = [sigma(r, m, err_key, t) for r in grows]
                if any(math.isfinite(v) for v in d):
                    axr.plot(xs, d, styles[ti % 4], marker=markers[gi % len(markers)], ms=4, lw=1.0,
                             color=f"C{ti}", alpha=1.0 if gi == 0 else 0.6, mfc="white" if gi % 2 else f"C{ti}")
        ax.set_ylabel(label)
        axr.set_xlabel(axis)
        axr.set_ylabel("(sim − theory)/σ")
        vals = [abs(v) for ln in axr.lines[3:] for v in ln.get_ydata() if math.isfinite(v)]
        lim = max([2.5] + [1.15 * v for v in vals])
        axr.set_ylim(-lim, lim)
        if not vals:
            axr.text(0.5, 0.5, "no σ distances (no theory, or errors flagged: no plateau / unchecked)",
                     transform=axr.transAxes, ha="center", va="center", fontsize=7, color="0.3")
        xs_all = [_float(r[axis]) for r in rows]
        if min(xs_all) > 0 and max(xs_all) / min(xs_all) > 8:
            ax.set_xscale("log")
        # outside the axes, right of them: never over a point; sweep.png is saved "tight"
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
        ax.grid(alpha=0.3)
        axr.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def save_figure(fig, path):
    """sweep.png: "tight", so that the legends right of the axes are in the image."""
    fig.savefig(path, dpi=110, bbox_inches="tight")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="plot_sweep.py",
                                 description="Plot a grainbath sweep's sweep.tsv into SWEEP_DIR/sweep.png.")
    ap.add_argument("sweep_dir", metavar="SWEEP_DIR", help="a `grainbath sweep` directory (holding sweep.tsv)")
    ap.add_argument("--x", metavar="KEY", help="the swept key to plot against (default: the numeric swept key "
                                               "with the most values; docs/OUTPUT.md, \"Sweep directories\")")
    a = ap.parse_args(argv)
    try:
        fig = make_figure(a.sweep_dir, a.x)
    except (OSError, ValueError, KeyError) as e:
        print(f"plot_sweep.py: error: {e}", file=sys.stderr)
        return 2
    save_figure(fig, os.path.join(a.sweep_dir, "sweep.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
