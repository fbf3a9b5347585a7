"""Shared by the bizon-conductivity and bizon-viscosity plot scripts: the finished runs of a
case (every nu*/output with summary.json and results.h5) and the one-row-per-run CSV."""
import csv
import glob
import json
import os

import h5py


def load_runs(case_dir):
    """[(name, summary dict, {field: array} of /transport)] for every finished run."""
    runs = []
    for d in sorted(glob.glob(os.path.join(case_dir, "nu*"))):
        out = os.path.join(d, "output")
        if not os.path.exists(os.path.join(out, "summary.json")):
            continue
        s = json.load(open(os.path.join(out, "summary.json")))
        with h5py.File(os.path.join(out, "results.h5"), "r") as fh:
            h = fh["transport"]
            f = {k: h[k][:] for k in h.keys() if k != "blocks"}
        runs.append((os.path.basename(d), s, f))
    if not runs:
        raise SystemExit("no outputs in " + case_dir + ": run run.sh first")
    return runs


def write_csv(path, rows):
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.5g}" if isinstance(v, float) else v) for k, v in r.items()})
    for r in rows:
        print(r)
