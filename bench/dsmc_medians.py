#!/usr/bin/python3
"""Runs each DSMC benchmark several times, one process per run (so the peak RSS is the
benchmark's own), and prints the median and spread of every counter, with the load average
before each run. Usage (docs/PERFORMANCE.md):

    bench/dsmc_medians.py build/bench/bench_dsmc REPEATS FILTER [FILTER ...]
e.g.
    bench/dsmc_medians.py build/bench/bench_dsmc 5 'DSMC1_SpartaBox/1/' 'DSMC1_SpartaBox/2/'
"""
import json
import os
import statistics
import subprocess
import sys


def main():
    exe, repeats, filters = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
    for flt in filters:
        rows, loads = [], []
        for _ in range(repeats):
            loads.append(os.getloadavg()[0])
            out = subprocess.run([exe, f"--benchmark_filter={flt}", "--benchmark_format=json"],
                                 check=True, capture_output=True, text=True).stdout
            if out.strip():
                rows.extend(json.loads(out)["benchmarks"])
        if not rows:
            print(f"{flt}: no benchmark matched")
            continue
        name = rows[0]["name"]
        keys = [k for k, v in rows[0].items() if isinstance(v, (int, float)) and k not in
                ("family_index", "per_family_instance_index", "repetitions", "repetition_index", "threads", "iterations")]
        print(f"{name}: {len(rows)} runs, load average (1 min) before each: {', '.join(f'{x:.1f}' for x in loads)}")
        for k in keys:
            vals = [r[k] for r in rows]
            med = statistics.median(vals)
            print(f"  {k:34s} median {med:12.4g}   min {min(vals):12.4g}   max {max(vals):12.4g}")


if __name__ == "__main__":
    main()
