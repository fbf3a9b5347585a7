#!/usr/bin/env python3
"""Runs this case over a range of packing fractions and tabulates Z against the references.

    GRAINBATH=build/grainbath python3 cases/hard-disk-eos/sweep.py [--quick] [--reuse] [--out DIR]

Writes output-sweep/<packing>/summary.json, eos.csv and eos.png into DIR: by default into
output/ beside this script (git ignores it), with --quick into output-quick/ beside it; then
compares eos.csv with the shipped one beside this script (scripts/compare_tables.py; the
collisions_per_second column is a timing and always differs). `--out` with this script's own
folder replaces the shipped eos.csv and eos.png.
cases/hard-sphere-eos/sweep.py is a link to this file: it reads the dimension from the
case.toml beside the path it was called by."""
import csv
import json
import math
import os
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
exe = os.environ.get("GRAINBATH", "build/grainbath")
quick = "--quick" in sys.argv
reuse = "--reuse" in sys.argv  # only tabulate / plot existing outputs
base = os.path.join(here, "output-quick" if quick else "output")
if "--out" in sys.argv:
    k = sys.argv.index("--out")
    if k + 1 >= len(sys.argv):
        sys.exit("sweep.py: --out needs a directory")
    base = os.path.abspath(sys.argv[k + 1])
os.makedirs(base, exist_ok=True)
print(f"sweep.py: outputs, eos.csv and eos.png in {base}", flush=True)
dims = 2 if "dimensions = 2" in open(os.path.join(here, "case.toml")).read() else 3
points = [0.1, 0.2, 0.3, 0.4, 0.5, 0.55, 0.6, 0.65] if dims == 2 else [0.1, 0.2, 0.3, 0.35, 0.4, 0.45]


def z_henderson(nu):
    return (1 + nu ** 2 / 8) / (1 - nu) ** 2


def z_kr(nu):
    return (1 + nu ** 2 / 8 + nu ** 3 / 18 - 4 * nu ** 4 / 21) / (1 - nu) ** 2


def z_klm(phi):
    return (1 + phi + phi ** 2 - 2 / 3 * (phi ** 3 + phi ** 4)) / (1 - phi) ** 3


def z_cs(phi):
    return (1 + phi + phi ** 2 - phi ** 3) / (1 - phi) ** 3


rows = []
for p in points:
    out = os.path.join(base, "output-sweep", f"{p:.2f}")
    cmd = [exe, "run", here, "--set", f"edmd.packing_fraction={p}", "--out", out, "-q"]
    if quick:
        cmd += ["--set", "edmd.collisions=200", "--set", "edmd.equilibrate=50"]
    if not (reuse and os.path.exists(os.path.join(out, "summary.json"))):
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    s = json.load(open(os.path.join(out, "summary.json")))
    z, ze = s["pressure"]["Z"], s["pressure"]["Z_stderr"]
    ref = z_kr(p) if dims == 2 else z_cs(p)
    row = {"packing": p, "Z": z, "Z_stderr": ze, "Z_ref": ref, "dev_percent": 100 * (z / ref - 1),
           "dev_sigma": (z - ref) / ze, "collision_over_enskog": s["collision"]["frequency_over_enskog"],
           "collisions_per_second": s["performance"]["collisions_per_second"]}
    if dims == 2:
        row["Z_henderson"] = z_henderson(p)
    else:
        row["Z_klm"] = z_klm(p)
        row["dev_klm_sigma"] = (z - z_klm(p)) / ze
    rows.append(row)
    print(" ".join(f"{k}={v:.5g}" for k, v in row.items()), flush=True)

with open(os.path.join(base, "eos.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
x = np.linspace(0.01, max(points) + 0.02, 200)
if dims == 2:
    a.plot(x, z_kr(x), "k-", label="Kolafa-Rottner fit (Liu 2020)")
    a.plot(x, z_henderson(x), "k--", label="Henderson")
else:
    a.plot(x, z_cs(x), "k-", label="Carnahan-Starling")
    a.plot(x, z_klm(x), "k:", label="Kolafa-Labik-Malijevsky")
a.errorbar([r["packing"] for r in rows], [r["Z"] for r in rows], [r["Z_stderr"] for r in rows], fmt="o", label="EDMD")
a.set_xlabel("packing fraction"), a.set_ylabel("Z = P/(nT)"), a.legend()
b.errorbar([r["packing"] for r in rows], [r["dev_percent"] for r in rows],
           [100 * r["Z_stderr"] / r["Z_ref"] for r in rows], fmt="o")
if dims == 2:
    b.plot(x, 100 * (z_henderson(x) / z_kr(x) - 1), "k--", label="Henderson vs KR fit")
else:
    b.plot(x, 100 * (z_klm(x) / z_cs(x) - 1), "k:", label="KLM vs CS")
b.legend()
b.axhline(0, color="k", lw=0.5), b.axhspan(-0.5, 0.5, color="0.9")
b.set_xlabel("packing fraction"), b.set_ylabel("Z / Z_ref - 1  [%]")
fig.tight_layout()
fig.savefig(os.path.join(base, "eos.png"), dpi=120)
if os.path.realpath(base) != os.path.realpath(here):
    subprocess.run([sys.executable, os.path.join(here, "..", "..", "scripts", "compare_tables.py"),
                    os.path.join(here, "eos.csv"), os.path.join(base, "eos.csv")], check=True)
