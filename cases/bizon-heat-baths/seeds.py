#!/usr/bin/python3
"""The README's quantities (those of heat_baths.csv, plot.py) as mean ± standard error over
replica runs of one bath, e.g. seeds 1-12 of the white noise:

    for s in $(seq 1 12); do build/grainbath run cases/bizon-heat-baths/white-noise \
      --set run.threads=1 --set run.seed=$s --out /tmp/hb/wn/s$s -q; done
    /usr/bin/python3 cases/bizon-heat-baths/seeds.py /tmp/hb/wn/s*

A single run's blocked error of T and Z (`temperature.stderr`, `pressure.Z_stderr`) is too
small for these driven grains (white noise: the seeds scatter 2.6x it; docs/edmd.md "Errors
of the window means"), and the other columns come without an error: quote these.
Prints, per quantity: mean ± SE over the runs, the runs' SD, and for T and Z the rms of the
runs' blocked errors and the ratio SD/rms (1 when the blocked error is right)."""
import json
import math
import os
import sys

import h5py
import numpy as np

nu = 0.5
G_cs = nu * (16 - 7 * nu) / (16 * (1 - nu) ** 2)  # Bizon eq. 5, as plot.py


def row(path):
    s = json.load(open(os.path.join(path, "summary.json")))
    with h5py.File(os.path.join(path, "results.h5"), "r") as h:
        obs = h["observables"]
        rc, par, perp = obs["velocity_correlation/r"][:], obs["velocity_correlation/parallel"][:], \
            obs["velocity_correlation/perpendicular"][:]
    return {"T": (s["temperature"]["mean"], s["temperature"]["stderr"]),
            "Z": (s["pressure"]["Z"], s["pressure"]["Z_stderr"]),
            "G_s/G_CS": (s["pressure"]["G_s"] / G_cs, None),
            "g(sigma) fit": (s["g_r"]["contact_fit"], None),
            "g(sigma+) collisions": (s["g_r"].get("contact_from_collisions", float("nan")), None),
            "G_s/nu": (s["pressure"]["G_s"] / nu, None),
            "<v|| v||>/T at 2 sigma": (float(np.interp(2.0, rc, par)), None),
            "<vT vT>/T at 2 sigma": (float(np.interp(2.0, rc, perp)), None),
            "gamma/gamma0": (s["loss"].get("gamma_over_gamma0", float("nan")), None),
            "gamma/gamma_e": (s["loss"].get("gamma_over_gamma_e", float("nan")), None),
            "eq. 33 velocity ratio": (s["loss"]["velocity_ratio"], None),
            "Sonine a2": (s["velocity"]["a2"], None)}


def main(dirs):
    rows = [row(d) for d in dirs if os.path.exists(os.path.join(d, "summary.json"))]
    n = len(rows)
    if n < 2:
        sys.exit(__doc__)
    print(f"{n} runs")
    for k in rows[0]:
        v = np.array([r[k][0] for r in rows])
        sd = v.std(ddof=1)
        line = f"{k:24s} {v.mean():.5g} ± {sd / math.sqrt(n):.2g}   (SD {sd:.3g})"
        if rows[0][k][1] is not None:
            rms = math.sqrt(np.mean([r[k][1] ** 2 for r in rows]))
            line += f"   rms blocked error {rms:.3g}, SD/rms {sd / rms:.2f} ± {sd / rms / math.sqrt(2 * (n - 1)):.2f}"
        print(line)


if __name__ == "__main__":
    main(sys.argv[1:])
