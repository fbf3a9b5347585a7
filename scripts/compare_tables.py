#!/usr/bin/env python3
"""Compares a table a case script just made with the one shipped beside the case's README.

    /usr/bin/python3 scripts/compare_tables.py REFERENCE NEW [REFERENCE NEW ...]

The case scripts (run.sh, run.py, sweep.py, plot.py, ...) write their tables and figures into
the case's output folder, which git ignores, and end by calling this on each table: the shipped
tables are the reference that the same commands made, so a reader sees at once whether a run
reproduced them, and by how much each column moved if not.

Tables: CSV (.csv), tab-separated (.tsv), Markdown pipe tables (.md, the first table of the
file), or a run's summary.json (.json: one row, a column per key, "a.b.c"; e.g. a run against
the copy of its summary that a case ships in results/). Rows are matched by the first column
(the n-th row of a repeated value with the n-th), columns by their headers. For each column
present in both, the report gives "identical" or the largest relative change |new - ref| /
max(|ref|, |new|) with its row, and where both tables give the column's standard error (an
error column X_err, X_stderr, X_sem or X.stderr beside X, X.mean or X_mean, or "value ± error"
in the cell) the largest distance |new - ref| / sqrt(err_ref^2 + err_new^2) in those errors
("sigma": the two as independent estimates, as from another seed). Rows or columns that only
one of the two has are named; more than 20 identical columns are counted, not listed.

Exit status: 0 when both tables were read, whatever they say (the comparison informs, it does
not judge: a run with another seed or another build differs within its errors); 2 when a file
is missing or holds no table, with the reason."""
import csv
import json
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


def read_summary(path):
    """A summary.json as a table of one row: a column per key ("a.b.c"), the row named
    "summary"."""
    try:
        with open(path, encoding="utf-8") as f:
            tree = json.load(f)
    except (OSError, ValueError) as e:
        fail(f"{path}: not a JSON summary ({e})")
    if not isinstance(tree, dict):
        fail(f"{path}: expected a JSON object (a summary.json), found {type(tree).__name__}")
    flat = {}

    def walk(node, prefix):
        for k, v in node.items():
            if isinstance(v, dict):
                walk(v, prefix + k + ".")
            else:
                flat[prefix + k] = json.dumps(v)  # numbers at full precision, as written

    walk(tree, "")
    return [["row"] + list(flat), ["summary"] + list(flat.values())]


def read_table(path):
    if not os.path.isfile(path):
        fail(f"{path}: no such file")
    if path.endswith(".md"):
        rows = read_markdown(path)
    elif path.endswith(".json"):
        rows = read_summary(path)
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


def cell_error(text):
    """The error written in the cell itself ("1.00 ± 0.05"), or None."""
    if "\u00b1" not in text:
        return None
    return number(text.split("\u00b1", 1)[1].strip())


def error_column(column, header):
    """The column holding the standard error of `column`, by the names the case scripts and
    summaries use (X_err, X_stderr, X_sem, X.stderr; X.mean and X_mean with X.stderr,
    X_stderr), or None."""
    names = [column + s for s in ("_err", "_stderr", "_sem", ".stderr")]
    for mean, err in ((".mean", ".stderr"), ("_mean", "_stderr")):
        if column.endswith(mean):
            names.append(column[:-len(mean)] + err)
    return next((n for n in names if n in header), None)


def sigma(row, header, i, column):
    """The standard error of row[i] (the cell's own "±" or the error column), or None."""
    e = cell_error(row[i])
    if e is None:
        name = error_column(column, header)
        e = number(row[header.index(name)]) if name else None
    return e if e is not None and math.isfinite(e) and e > 0 else None


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
        farthest = None  # (|new - ref| / sigma, row), over the rows where both give an error
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
                ea, eb = sigma(ref[k], ref_header, i, c), sigma(new[k], new_header, j, c)
                if ea is not None and eb is not None:
                    # two independent estimates (another seed, another build's draws)
                    z = abs(y - x) / math.hypot(ea, eb)
                    if farthest is None or z > farthest[0]:
                        farthest = (z, k)
            if worst is None or rel > worst[0]:
                worst = (rel, k, a, b)
        if worst is None:
            identical.append(c)
        else:
            changed.append((c, worst, farthest))
    if identical and not changed:
        print("  every column identical")
    elif len(identical) > 20:  # a summary's hundred keys: the count says enough
        print(f"  identical: {len(identical)} columns")
    elif identical:
        print(f"  identical: {', '.join(identical)}")
    one_row = ref_path.endswith(".json")  # a summary.json: one row, none to name
    for c, (rel, k, a, b), farthest in sorted(changed, key=lambda t: -t[1][0]):
        size = "not a number" if math.isinf(rel) else f"{rel:.2g} relative"
        if farthest is not None:
            size += f"; {farthest[0]:.2g} sigma" if one_row else f"; at most {farthest[0]:.2g} sigma, row {farthest[1]}"
        where = "" if one_row else f"largest in row {k}: "
        print(f"  changed: {c}: {where}{a} -> {b} ({size})")


def main(argv):
    if len(argv) < 2 or len(argv) % 2:
        fail("usage: compare_tables.py REFERENCE NEW [REFERENCE NEW ...]")
    for ref_path, new_path in zip(argv[0::2], argv[1::2]):
        compare(ref_path, new_path)


if __name__ == "__main__":
    main(sys.argv[1:])
