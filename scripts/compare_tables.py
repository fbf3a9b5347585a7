#!/usr/bin/env python3
"""Compares a table a case script just made with the one shipped beside the case's README.

    /usr/bin/python3 scripts/compare_tables.py REFERENCE NEW [REFERENCE NEW ...]

The case scripts (run.sh, run.py, sweep.py, plot.py, ...) write their tables and figures into
the case's output folder, which git ignores, and end by calling this on each table: the shipped
tables are the reference that the same commands made, so a reader sees at once whether a run
reproduced them, and by how much each column moved if not.

Tables: CSV (.csv), tab-separated (.tsv) or Markdown pipe tables (.md, the first table of the
file). Rows are matched by the first column (the n-th row of a repeated value with the n-th),
columns by their headers. For each column present
in both, the report gives "identical" or the largest relative change |new - ref| / max(|ref|,
|new|) with its row. Rows or columns that only one of the two has are named.

Exit status: 0 when both tables were read, whatever they say (the comparison informs, it does
not judge: a run with another seed or another build differs within its errors); 2 when a file
is missing or holds no table, with the reason."""
import csv
import math
import os
import sys


def fail(message):
    print(f"compare_tables.py: {message}", file=sys.stderr)
    sys.exit(2)


def read_markdown(path):
    rows = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            s = line.strip()
            if not s.startswith("|"):
                if rows:
                    break  # the first table only
                continue
            cells = [c.strip() for c in s.strip("|").split("|")]
            if all(c and set(c) <= set("-: ") for c in cells):
                continue  # the header's separator row
            rows.append(cells)
    return rows


def read_table(path):
    if not os.path.isfile(path):
        fail(f"{path}: no such file")
    if path.endswith(".md"):
        rows = read_markdown(path)
    else:
        with open(path, newline="", encoding="utf-8") as f:
            rows = [r for r in csv.reader(f, delimiter="\t" if path.endswith(".tsv") else ",") if r]
    if len(rows) < 2:
        fail(f"{path}: expected a table with a header and at least one row, found {len(rows)} line(s)")
    header, body = rows[0], rows[1:]
    for k, r in enumerate(body):
        if len(r) != len(header):
            fail(f"{path}: row {k + 1} has {len(r)} cells, the header {len(header)}")
    # a key that repeats (a time series per run: edmd_curves.csv) names its n-th row "KEY #n",
    # so that the n-th rows of the two tables are compared
    keyed, seen = {}, {}
    for r in body:
        seen[r[0]] = seen.get(r[0], 0) + 1
        keyed[r[0] if seen[r[0]] == 1 else f"{r[0]} #{seen[r[0]]}"] = r
    return header, keyed, list(keyed)


def number(text):
    # Markdown cells may carry a "±" error or units after the value: the value is the first word
    word = text.replace("\u2212", "-").split(" ")[0].split("\u00b1")[0]
    try:
        return float(word)
    except ValueError:
        return None


def compare(ref_path, new_path):
    ref_header, ref, ref_order = read_table(ref_path)
    new_header, new, _ = read_table(new_path)
    rows = [k for k in ref_order if k in new]
    only_ref = [k for k in ref_order if k not in new]
    only_new = [k for k in new if k not in ref]
    columns = [c for c in ref_header[1:] if c in new_header[1:]]
    print(f"{new_path} against the shipped {ref_path}: {len(rows)} rows and {len(columns)} columns in both")
    if only_ref:
        print(f"  rows only in the reference: {', '.join(only_ref)}")
    if only_new:
        print(f"  rows only in the new table: {', '.join(only_new)}")
    missing = [c for c in ref_header[1:] if c not in new_header[1:]]
    extra = [c for c in new_header[1:] if c not in ref_header[1:]]
    if missing:
        print(f"  columns only in the reference: {', '.join(missing)}")
    if extra:
        print(f"  columns only in the new table: {', '.join(extra)}")
    identical, changed = [], []
    for c in columns:
        i, j = ref_header.index(c), new_header.index(c)
        worst = None  # (relative change, row, reference text, new text)
        for k in rows:
            a, b = ref[k][i], new[k][j]
            if a == b:
                continue
            x, y = number(a), number(b)
            if x is None or y is None or math.isnan(x) or math.isnan(y):
                rel = math.inf  # text, or a number against text/NaN: changed, not measurable
            else:
                scale = max(abs(x), abs(y))
                rel = abs(y - x) / scale if scale > 0 else 0.0
                if rel == 0.0:
                    continue  # the same number written otherwise (1.0 and 1)
            if worst is None or rel > worst[0]:
                worst = (rel, k, a, b)
        if worst is None:
            identical.append(c)
        else:
            changed.append((c, worst))
    if identical:
        print(f"  identical: {', '.join(identical)}" if changed else "  every column identical")
    for c, (rel, k, a, b) in sorted(changed, key=lambda t: -t[1][0]):
        size = "not a number" if math.isinf(rel) else f"{rel:.2g} relative"
        print(f"  changed: {c}: largest in row {k}: {a} -> {b} ({size})")


def main(argv):
    if len(argv) < 2 or len(argv) % 2:
        fail("usage: compare_tables.py REFERENCE NEW [REFERENCE NEW ...]")
    for ref_path, new_path in zip(argv[0::2], argv[1::2]):
        compare(ref_path, new_path)


if __name__ == "__main__":
    main(sys.argv[1:])
