#!/usr/bin/env python3
"""T(t) of cases/free-cooling-disks against Haff's law (with and without the a2 correction).
    /usr/bin/python3 cases/free-cooling-disks/plot.py [OUTPUT_DIR]      -> OUTPUT_DIR/haff.png
OUTPUT_DIR is the run's output directory (default output/ beside this script); the figure goes
beside its results, never over the shipped haff.png beside this script."""
import json
import os
import sys

import h5py
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "output")
s = json.load(open(os.path.join(out, "summary.json")))
h = h5py.File(os.path.join(out, "results.h5"), "r")
# /timeseries/t (the layout DSMC writes); results.h5 of older builds have /series/time only
g, time = ("timeseries", "t") if "timeseries/t" in h else ("series", "time")
t, T = h[f"{g}/{time}"][:], h[f"{g}/temperature"][:]
T0 = T[0]
fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
a.plot(t, T, "o", ms=3, label="EDMD")
for key, style, lab in [("t0_theory", "k-", "Haff + a2 (van Noije-Ernst)"), ("t0_theory_no_a2", "k:", "Haff, Maxwellian")]:
    t0 = s["haff"][key]
    a.plot(t, T0 / (1 + t / t0) ** 2, style, label=lab)
a.set_xlabel("t"), a.set_ylabel("T"), a.legend()
b.plot(t, np.sqrt(T0 / T) - 1, "o", ms=3, label="EDMD")
b.plot(t, t / s["haff"]["t0_theory"], "k-", label="Haff + a2")
b.set_xlabel("t"), b.set_ylabel("√(T0/T) − 1"), b.legend()
fig.suptitle(f"free cooling, e = 0.9, ν = 0.1: t0 measured/theory = {s['haff']['ratio']:.4f}")
fig.tight_layout()
fig.savefig(os.path.join(out, "haff.png"), dpi=120)
print(s["haff"])
print(f"wrote {os.path.join(out, 'haff.png')}")
