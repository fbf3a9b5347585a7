"""Shared plot style: simulation in black (solid line or points with error bars), each theory in
its own colour *and* line style (readable in greyscale and for colour-blind readers)."""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SIM = dict(color="black", lw=1.3, label="simulation")
SIM_POINTS = dict(color="black", marker="o", ms=3.5, ls="none", label="simulation")

# Okabe-Ito palette
THEORY = {
    "maxwellian": dict(color="#0072B2", ls="--", lw=1.8, label="local-Maxwellian closure"),
    "grad": dict(color="#E69F00", ls="-.", lw=1.8, label="Grad closure"),
    "sonine": dict(color="#009E73", ls=":", lw=2.2, label="Sonine closure"),
    "haff": dict(color="#D55E00", ls="--", lw=1.8, label="Haff's law"),
    "hcs": dict(color="#56B4E9", ls="-.", lw=1.8, label="second Sonine (cooling state)"),
    "hydro": dict(color="#CC79A7", ls="--", lw=1.8, label="hydrodynamic limit"),
    "maxwell_dist": dict(color="#0072B2", ls="--", lw=1.6, label="Maxwellian"),
    "sonine_dist": dict(color="#009E73", ls=":", lw=2.0, label="Maxwellian × (1 + a₂ S₂), a₂ measured"),
    "eos": dict(color="#0072B2", ls="--", lw=1.8, label="equation of state"),
    "eos2": dict(color="#E69F00", ls="-.", lw=1.6, label="equation of state (alt.)"),
    "fit": dict(color="black", ls=(0, (4, 2)), lw=1.0, label="fit to the simulation"),
}

plt.rcParams.update({
    "figure.figsize": (7.0, 4.4),
    "figure.dpi": 110,
    "savefig.dpi": 110,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.titlesize": 11,
    "axes.labelsize": 10.5,
    "legend.fontsize": 8.5,
    "legend.framealpha": 0.9,
    "font.size": 10,
})


def theory_style(name, **over):
    d = dict(THEORY[name])
    d.update(over)
    return d


class Context:
    """Where the section functions put their PNGs."""

    def __init__(self, report_dir):
        self.report_dir = report_dir
        self.saved = []

    def save(self, fig, name):
        path = os.path.join(self.report_dir, name + ".png")
        fig.tight_layout()
        # "tight": the saved image takes in everything drawn, a legend placed outside the axes too
        fig.savefig(path, bbox_inches="tight")
        plt.close(fig)
        self.saved.append(path)
        return path


def subplots(*args, **kw):
    return plt.subplots(*args, **kw)
