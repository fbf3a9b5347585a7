#!/usr/bin/env python3
"""Exit 0 if two summary.json files hold the same values, key by key (nested keys
flattened to a.b.c), leaving out performance.* (wall times, rates, rank counts): the
comparison of the bitwise-reproducibility scripts (tests/mpi, tests/simd). Prints up to ten
differing keys. usage: same_summary.py A.json B.json"""
import json
import sys


def flat(d, prefix=""):
    out = {}
    for k, v in d.items():
        key = prefix + k
        if isinstance(v, dict):
            out.update(flat(v, key + "."))
        else:
            out[key] = v
    return out


a, b = (flat(json.load(open(f))) for f in sys.argv[1:3])
bad = [k for k in sorted(set(a) | set(b)) if not k.startswith("performance.") and a.get(k) != b.get(k)]
for k in bad[:10]:
    print(f"   {k}: {a.get(k)!r} vs {b.get(k)!r}")
sys.exit(1 if bad else 0)
