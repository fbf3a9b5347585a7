#!/usr/bin/env python3
"""Table: steady granular temperature of EDMD vs the Maxwellian energy balance with the
Enskog factor (theory.medium_steady_temperature) vs the mapped DSMC. Writes compare.csv."""
import csv
import json
import os

here = os.path.dirname(os.path.abspath(__file__))
rows = []
for phi, e, d in [(0.05, "nu0.05", "dsmc-0.05"), (0.30, "nu0.30", "dsmc-0.30")]:
    s = json.load(open(os.path.join(here, e, "output", "summary.json")))
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
with open(os.path.join(here, "compare.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=keys)
    w.writeheader()
    w.writerows(rows)
for r in rows:
    print(" ".join(f"{k}={v:.5g}" for k, v in r.items()))
