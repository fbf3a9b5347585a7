#!/usr/bin/python3
"""cli_compare_tables: scripts/compare_tables.py, which the case scripts call to compare the
tables they just made (in the case's output folder) with the shipped ones.

Hand-made reference and new tables in CSV, TSV and Markdown; every line of the report is
worked out here: identical columns, the largest relative change and its row, a text cell that
changed, a number written otherwise (1.0 and 1) counted as the same, rows and columns that only
one side has, a repeated first column paired row by row, Markdown cells with "±" errors, and exit 2 with the reason for a missing file, a
file without a table and a row with the wrong number of cells. Standard library only."""
import argparse
import os
import shutil
import subprocess
import sys

ap = argparse.ArgumentParser()
ap.add_argument("--script", required=True)
ap.add_argument("--work", required=True)
a = ap.parse_args()
shutil.rmtree(a.work, ignore_errors=True)
os.makedirs(a.work)
failures = []


def write(name, text):
    path = os.path.join(a.work, name)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path


def run(*paths):
    r = subprocess.run([sys.executable, a.script, *paths], capture_output=True, text=True)
    return r.returncode, r.stdout, r.stderr


def expect(label, got, want):
    if got != want:
        failures.append(f"{label}:\n--- got\n{got}--- want\n{want}")


# 1. CSV: T changes most in row "b" (|1.1 - 1.0| / 1.1), Z less in row "a", the text column
# "law" changes, "n" is 1.0 against 1 (the same number), row "c" and column "old" only in the
# reference, row "d" and column "extra" only in the new table
ref = write("ref.csv", "name,T,Z,law,n,old\na,2.0,3.0,bizon,1.0,7\nb,1.0,4.0,const,2,7\nc,5,5,x,1,7\n")
new = write("new.csv", "name,T,Z,law,n,extra\na,2.0,3.03,bizon,1,0\nb,1.1,4.0,power,2.0,0\nd,1,1,y,1,0\n")
code, out, err = run(ref, new)
expect("csv exit", (code, err), (0, ""))
expect("csv report", out, f"""{new} against the shipped {ref}: 2 rows and 4 columns in both
  rows only in the reference: c
  rows only in the new table: d
  columns only in the reference: old
  columns only in the new table: extra
  identical: n
  changed: law: largest in row b: const -> power (not a number)
  changed: T: largest in row b: 1.0 -> 1.1 (0.091 relative)
  changed: Z: largest in row a: 3.0 -> 3.03 (0.0099 relative)
""")

# 2. TSV, identical, and two pairs in one call
tsv = write("t.tsv", "variant\tT\tZ\nv0\t1\t2\nv1\t3\t4\n")
code, out, err = run(tsv, tsv, ref, ref)
expect("tsv exit", (code, err), (0, ""))
expect("tsv report", out, f"""{tsv} against the shipped {tsv}: 2 rows and 2 columns in both
  every column identical
{ref} against the shipped {ref}: 3 rows and 5 columns in both
  every column identical
""")

# 2b. A first column that repeats (a time series per run): the n-th rows of a value are paired,
# "KEY #n" names them; the third row of "inf" only in the reference
rep_ref = write("rep_ref.csv", "mu,t,T\ninf,0,1.0\ninf,1,0.5\ninf,2,0.25\n0.5,0,1.0\n")
rep_new = write("rep_new.csv", "mu,t,T\ninf,0,1.0\ninf,1,0.4\n0.5,0,1.0\n")
code, out, err = run(rep_ref, rep_new)
expect("repeated keys exit", (code, err), (0, ""))
expect("repeated keys report", out, f"""{rep_new} against the shipped {rep_ref}: 3 rows and 2 columns in both
  rows only in the reference: inf #3
  identical: t
  changed: T: largest in row inf #2: 0.5 -> 0.4 (0.2 relative)
""")

# 3. Markdown: the first table only, the separator row skipped, "±" errors and a minus sign
# (U+2212) read as numbers: the rate's value changes by 0.02/1.02, the error column identical
md_ref = write("ref.md", "Intro\n\n| eps | rate | err |\n|---|:--:|---|\n| 0.1 | 1.00 ± 0.05 | \u22120.5 |\n"
                         "\n| other | table |\n|---|---|\n| 1 | 2 |\n")
md_new = write("new.md", "| eps | rate | err |\n|---|---|---|\n| 0.1 | 1.02 ± 0.06 | -0.5 |\n")
code, out, err = run(md_ref, md_new)
expect("md exit", (code, err), (0, ""))
expect("md report", out, f"""{md_new} against the shipped {md_ref}: 1 rows and 2 columns in both
  identical: err
  changed: rate: largest in row 0.1: 1.00 ± 0.05 -> 1.02 ± 0.06 (0.02 relative)
""")

# 4. Errors: exit 2, the file and the reason, nothing on stdout
missing = os.path.join(a.work, "missing.csv")
empty = write("empty.md", "no table here\n")
ragged = write("ragged.csv", "name,T\na,1,2\n")
for label, args, want in [
        ("missing file", (ref, missing), f"compare_tables.py: {missing}: no such file\n"),
        ("no table", (empty, ref), f"compare_tables.py: {empty}: expected a table with a header and at least one row, found 0 line(s)\n"),
        ("ragged row", (ragged, ref), f"compare_tables.py: {ragged}: row 1 has 3 cells, the header 2\n"),
        ("odd arguments", (ref,), "compare_tables.py: usage: compare_tables.py REFERENCE NEW [REFERENCE NEW ...]\n")]:
    code, out, err = run(*args)
    expect(label, (code, out, err), (2, "", want))

if failures:
    print("\n".join(failures))
    sys.exit(1)
print("ok   compare_tables.py: csv, tsv and markdown reports, and its errors")
