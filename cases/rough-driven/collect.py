#!/usr/bin/python3
"""Collects the EDMD runs of cases/rough-driven (run.sh) into small CSV files for plot.py:
  edmd_curves.csv   mu, t_nu0, Ttr, Trot (EDMD) and the models' Ttr_A..E, Trot_A..E at the same
                    times (results.h5 /theory/rough_model_*: integrated by the driver from the
                    measured start with the Enskog nu and the run's collision-keyed driving);
                    thinned logarithmically in time
  edmd_r_vs_mu.csv  mu, R, R_stderr, Ttr, Ttr_stderr (the seed-1 run and its blocked errors),
                    R_A..R_E, Ttr_E, and over the seeds of run.sh's SEEDS (output-sweep/mu-MU,
                    mu-MU-seedS): seeds, R_seeds, R_seeds_sem, Ttr_seeds, Ttr_seeds_sem (mean and
                    standard error of the mean over the seeds; nan with one seed). The blocked
                    errors understate the scatter between runs (docs/edmd.md "Errors of the
                    window means"): quote the seeds' columns.
Time unit: 1/nu(0), nu(0) = G sqrt(Ttr(0)), G = 2 n sigma chi sqrt(pi) (docs/rough.md R1,
Henderson chi), as in theory_curves.csv.

    /usr/bin/python3 cases/rough-driven/collect.py [--out DIR]

Both files go to DIR (default output/ beside this script, which git ignores) and are compared
with the shipped ones beside this script (scripts/compare_tables.py); `--out cases/rough-driven`
replaces the shipped ones."""
import argparse
import csv
import glob
import json
import math
import os
import subprocess
import sys

import h5py

here = os.path.dirname(os.path.abspath(__file__))
ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--out", default=os.path.join(here, "output"), help="where the two tables go")
out = ap.parse_args().out
os.makedirs(out, exist_ok=True)


def prefactor_2d(phi):
    n = 4.0 * phi / math.pi
    chi = (1.0 - 7.0 * phi / 16.0) / (1.0 - phi) ** 2
    return 2.0 * n * chi * math.sqrt(math.pi)


with open(os.path.join(out, "edmd_curves.csv"), "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["mu", "t_nu0", "Ttr", "Trot"] + [f"Ttr_{m}" for m in "ABCDE"] + [f"Trot_{m}" for m in "ABCDE"])
    for sub, mu in (("mu-inf", "inf"), ("mu-0.5", "0.5")):
        h = h5py.File(os.path.join(here, sub, "output", "results.h5"), "r")
        s = json.load(open(os.path.join(here, sub, "output", "summary.json")))
        phi = 0.0866
        # /timeseries/t (the layout DSMC writes); results.h5 of older builds have /series/time only
        g, time = ("timeseries", "t") if "timeseries/t" in h else ("series", "time")
        t = h[f"/{g}/{time}"][:]
        T = h[f"/{g}/temperature"][:]
        nu0 = prefactor_2d(phi) * math.sqrt(T[0])
        cols = [h[f"/{g}/temperature"][:], h[f"/{g}/rotational_temperature"][:]]
        cols += [h[f"/theory/rough_model_{m}/Ttr"][:] for m in "ABCDE"]
        cols += [h[f"/theory/rough_model_{m}/Trot"][:] for m in "ABCDE"]
        last = -1.0
        for k in range(len(t)):
            x = t[k] * nu0
            if k > 0 and x < 1.04 * last and k != len(t) - 1:
                continue  # ~60 points per decade
            last = x
            w.writerow([mu, f"{x:.6g}"] + [f"{c[k]:.6g}" for c in cols])

groups = {}
for d in glob.glob(os.path.join(here, "output-sweep", "mu-*")):
    name = os.path.basename(d)[3:]
    mu_s, _, seed = name.partition("-seed")
    s = json.load(open(os.path.join(d, "summary.json")))
    groups.setdefault(float(mu_s), {})[int(seed or 1)] = s
rows = []
for mu, runs in groups.items():
    first = runs[min(runs)]
    r, th = first["rotation"], first["theory"]
    R = [x["rotation"]["R"] for x in runs.values()]
    T = [x["rotation"]["Ttr_mean"] for x in runs.values()]

    def mean_sem(v):
        m = sum(v) / len(v)
        if len(v) < 2:
            return m, float("nan")
        return m, math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1) / len(v))

    rows.append([mu, r["R"], r["R_stderr"], r["Ttr_mean"], r["Ttr_stderr"]] +
                [th[f"model_{m}"]["R"] for m in "ABCDE"] + [th["model_E"]["Ttr"], len(runs)] +
                list(mean_sem(R)) + list(mean_sem(T)))
rows.sort()
with open(os.path.join(out, "edmd_r_vs_mu.csv"), "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["mu", "R", "R_stderr", "Ttr", "Ttr_stderr", "R_A", "R_B", "R_C", "R_D", "R_E", "Ttr_E",
                "seeds", "R_seeds", "R_seeds_sem", "Ttr_seeds", "Ttr_seeds_sem"])
    for r in rows:
        w.writerow([f"{x:.6g}" for x in r])
print(f"wrote {os.path.join(out, 'edmd_curves.csv')} and edmd_r_vs_mu.csv beside it")
if os.path.realpath(out) != os.path.realpath(here):
    subprocess.run([sys.executable, os.path.join(here, "..", "..", "scripts", "compare_tables.py")] +
                   [p for name in ("edmd_curves.csv", "edmd_r_vs_mu.csv")
                    for p in (os.path.join(here, name), os.path.join(out, name))], check=True)
