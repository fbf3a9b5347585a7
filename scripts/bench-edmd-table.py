#!/usr/bin/env python3
# Table of the EDMD-1 benchmark (docs/performance/edmd.md) from the Google Benchmark JSON
# files written by scripts/bench-edmd.sh: medians over all repetitions of all directories given.
#   scripts/bench-edmd-table.py OUT_DIR [OUT_DIR ...]
import argparse, json, sys, glob, os, statistics
ap = argparse.ArgumentParser(prog="bench-edmd-table.py", description="Table of the EDMD-1 benchmark from the JSON "
                             "files of scripts/bench-edmd.sh (medians over all repetitions of all directories).")
ap.add_argument("dirs", metavar="OUT_DIR", nargs="+", help="a directory of bench-edmd.sh's JSON files")
runs = {}
for d in ap.parse_args().dirs:
    for f in sorted(glob.glob(os.path.join(d, '*.json'))):
        try: j = json.load(open(f))
        except Exception: continue
        if 'benchmarks' not in j: continue
        for b in j['benchmarks']:
            if b.get('run_type') != 'iteration': continue
            name = b['name'].split('/min_time')[0].replace('BM_Edmd/', '')
            runs.setdefault(name, []).append(b)
order = ['spheres_phi0.30/10000','spheres_phi0.30/100000','spheres_phi0.45/10000','spheres_phi0.45/100000',
         'disks_nu0.50/10000','disks_nu0.50/1000000','disks_nu0.70/10000','disks_nu0.70/1000000']
med = {}
for k in order:
    if k not in runs: continue
    r = runs[k]
    cps = sorted(x['collisions_per_second'] for x in r); wall = sorted(x['collisions_per_wall_second'] for x in r)
    med[k] = statistics.median(cps)
    print(f"| {k} | {statistics.median(cps)/1e3:.0f} k ({cps[0]/1e3:.0f}–{cps[-1]/1e3:.0f}) | {statistics.median(wall)/1e3:.0f} k | {statistics.median(x['events_per_collision'] for x in r):.2f} | {max(x['peak_rss_MiB'] for x in r):.0f} | {max(x['bytes_per_particle'] for x in r):.0f} | {len(r)} |")
print('ratio to target (6.5e5) spheres 0.30 1e5:', med.get('spheres_phi0.30/100000', 0)/6.5e5)
for a,b in [('disks_nu0.50/10000','disks_nu0.50/1000000'),('disks_nu0.70/10000','disks_nu0.70/1000000'),('spheres_phi0.30/10000','spheres_phi0.30/100000'),('spheres_phi0.45/10000','spheres_phi0.45/100000')]:
    if a in med and b in med: print('slowdown', a, '->', b, med[a]/med[b])
