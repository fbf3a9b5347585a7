"""Shared by the bizon-conductivity and bizon-viscosity plot scripts: the finished runs of a
case (every nu*/output with summary.json and results.h5), where the table and figure go
(--out DIR, default the case's output/, which git ignores) and the one-row-per-run CSV, compared
with the shipped one beside the case's README (scripts/compare_tables.py)."""
import argparse
import csv
import glob
import json
import os
import subprocess
import sys

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


def output_dir(case_dir, doc):
    """The --out directory of the plot script (created), by default case_dir/output."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(case_dir, "output"),
                    help="where the table and figure go (the case directory itself replaces the shipped ones)")
    out = ap.parse_args().out
    os.makedirs(out, exist_ok=True)
    return out


def save(case_dir, out, name, fig, rows):
    """NAME.png and NAME.csv into out; then the table against the shipped case_dir/NAME.csv,
    and each run's summary.json against its copy in case_dir/results/."""
    fig.savefig(os.path.join(out, name + ".png"), dpi=110)
    write_csv(os.path.join(out, name + ".csv"), rows)
    print(f"wrote {os.path.join(out, name + '.csv')} and {name}.png beside it")
    pairs = []
    if os.path.realpath(out) != os.path.realpath(case_dir):
        pairs += [os.path.join(case_dir, name + ".csv"), os.path.join(out, name + ".csv")]
    # each run's summary against the copy the case ships in results/ (same seed: the same
    # trajectory, so every key but the timings should agree)
    for summary in sorted(glob.glob(os.path.join(case_dir, "nu*", "output", "summary.json"))):
        run = os.path.basename(os.path.dirname(os.path.dirname(summary)))
        stored = os.path.join(case_dir, "results", run + ".summary.json")
        if os.path.exists(stored):
            pairs += [stored, summary]
    if pairs:
        subprocess.run([sys.executable, os.path.join(case_dir, "..", "..", "scripts", "compare_tables.py")] + pairs,
                       check=True)
