#!/usr/bin/env python3
"""Table: steady granular temperature of EDMD vs the Maxwellian energy balance with the
Enskog factor (theory.medium_steady_temperature) vs the mapped DSMC.

    /usr/bin/python3 cases/dense-medium/compare.py [--out DIR]

Reads the runs' <case>/output/summary.json, writes compare.csv into DIR (default output/ beside
this script, which git ignores) and compares it with the shipped compare.csv beside this script
(scripts/compare_tables.py); `--out cases/dense-medium` replaces the shipped one."""
import argparse
import csv
import json
import os
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--out", default=os.path.join(here, "output"), help="where compare.csv goes")
out = ap.parse_args().out
os.makedirs(out, exist_ok=True)
rows = []
for phi, e, d in [(0.05, "nu0.05", "dsmc-0.05"), (0.30, "nu0.30", "dsmc-0.30")]:
    p = os.path.join(here, e, "output", "summary.json")
    if not os.path.exists(p):
        raise SystemExit(f"compare.py: {p}: no such file (run.sh makes it)")
    s = json.load(open(p))
    row = {"phi": phi, "T_edmd": s["temperature"]["mean"], "T_edmd_err": s["temperature"]["stderr"],
           "T_theory_enskog_maxwell": s["theory"]["medium_steady_temperature"],
           "edmd_over_theory": s["medium"]["temperature_over_theory"], "a2_edmd": s["velocity"]["a2"],
           "g_contact_CS": s["theory"]["g_contact"], "g_contact_from_rate": s["collision"]["g_contact_from_rate"]}
    p = os.path.join(here, d, "output", "summary.json")
    if os.path.exists(p):
        q = json.load(open(p))
        row.update({"T_dsmc": q["temperature"]["mean"], "T_dsmc_err": q["temperature"]["stderr"],
                    "a2_dsmc": q["a2"]["mean"],
                    "edmd_minus_dsmc_sigma": (row["T_edmd"] - q["temperature"]["mean"]) /
                    (row["T_edmd_err"] ** 2 + q["temperature"]["stderr"] ** 2) ** 0.5})
    rows.append(row)
keys = sorted({k for r in rows for k in r}, key=lambda k: list(rows[0].keys()).index(k) if k in rows[0] else 99)
with open(os.path.join(out, "compare.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=keys)
    w.writeheader()
    w.writerows(rows)
for r in rows:
    print(" ".join(f"{k}={v:.5g}" for k, v in r.items()))
if os.path.realpath(out) != os.path.realpath(here):
    subprocess.run([sys.executable, os.path.join(here, "..", "..", "scripts", "compare_tables.py"),
                    os.path.join(here, "compare.csv"), os.path.join(out, "compare.csv")], check=True)
