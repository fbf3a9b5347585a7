#!/usr/bin/python3
"""cli_compare_tables: scripts/compare_tables.py, which the case scripts call to compare the
tables they just made (in the case's output folder) with the shipped ones.

Hand-made reference and new tables in CSV, TSV and Markdown; every line of the report is
worked out here (a summary.json as a one-row table too): identical columns, the largest relative change and its row, the largest
distance in the two tables' standard errors (error columns by their names, "±" in a cell; none
where an error is missing, zero or nan), a text cell that
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

# 1b. Errors: T with T_err (row a: 0.3/hypot(0.1, 0.1) = 2.1 sigma, row b: 0.1/hypot(0.3, 0.4)
# = 0.2; the largest relative change is row b's, the largest distance row a's), Z with Z_stderr
# given only by the reference (no distance), x.mean with x.stderr (0.5/hypot(0.3, 0.4) = 1),
# y_mean with y_stderr where one error is 0 and the other nan (no distance); the error columns
# themselves change without one
err_ref = write("err_ref.csv", "run,T,T_err,Z,Z_stderr,x.mean,x.stderr,y_mean,y_stderr\n"
                               "a,2.0,0.1,1,0.1,1.0,0.3,5,0\nb,0.4,0.3,1,0.1,2.0,0.3,6,nan\n")
err_new = write("err_new.csv", "run,T,T_err,Z,x.mean,x.stderr,y_mean,y_stderr\n"
                               "a,2.3,0.1,2,1.5,0.4,5.5,0.2\nb,0.5,0.4,1,2.0,0.4,6,0.2\n")
code, out, err = run(err_ref, err_new)
expect("errors exit", (code, err), (0, ""))
expect("errors report", out, f"""{err_new} against the shipped {err_ref}: 2 rows and 7 columns in both
  columns only in the reference: Z_stderr
  changed: y_stderr: largest in row b: nan -> 0.2 (not a number)
  changed: Z: largest in row a: 1 -> 2 (0.5 relative)
  changed: x.mean: largest in row a: 1.0 -> 1.5 (0.33 relative; at most 1 sigma, row a)
  changed: T_err: largest in row b: 0.3 -> 0.4 (0.25 relative)
  changed: x.stderr: largest in row a: 0.3 -> 0.4 (0.25 relative)
  changed: T: largest in row b: 0.4 -> 0.5 (0.2 relative; at most 2.1 sigma, row a)
  changed: y_mean: largest in row a: 5 -> 5.5 (0.091 relative)
""")

# 1c. R with R_sem over three rows: the largest relative change in row b (0.2/0.6), the largest
# distance in the last row, c (0.3/hypot(0.1, 0.1) = 2.1 sigma; a: 0.1/0.5, b: 0.2/0.14)
sem_ref = write("sem_ref.csv", "run,R,R_sem\na,1.0,0.3\nb,0.4,0.1\nc,1.0,0.1\n")
sem_new = write("sem_new.csv", "run,R,R_sem\na,1.1,0.4\nb,0.6,0.1\nc,1.3,0.1\n")
code, out, err = run(sem_ref, sem_new)
expect("sem report", (code, out, err), (0, f"""{sem_new} against the shipped {sem_ref}: 3 rows and 2 columns in both
  changed: R: largest in row b: 0.4 -> 0.6 (0.33 relative; at most 2.1 sigma, row c)
  changed: R_sem: largest in row a: 0.3 -> 0.4 (0.25 relative)
""", ""))

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
  changed: rate: largest in row 0.1: 1.00 ± 0.05 -> 1.02 ± 0.06 (0.02 relative; at most 0.26 sigma, row 0.1)
""")

# 3b. summary.json: nested keys flattened to columns ("a.b"), one row, so no row is named;
# temperature.mean with temperature.stderr (0.03/hypot(0.01, 0.01) = 2.1 sigma), a string and a
# list compared as text, a null against a number is not a number, a key only in one
js_ref = write("ref.json", '{"temperature": {"mean": 1.0, "stderr": 0.01}, "state": {"hash": "ab"},'
                           ' "run": {"seed": 1, "theory": {"hcs": {"a2": 0.1}}}, "box": [1, 2], "z": null, "old": 3}')
js_new = write("new.json", '{"temperature": {"mean": 1.03, "stderr": 0.01}, "state": {"hash": "cd"},'
                           ' "run": {"seed": 1, "theory": {"hcs": {"a2": 0.1}}}, "box": [1, 3], "z": 0.5}')
code, out, err = run(js_ref, js_new)
expect("json report", (code, out, err), (0, f"""{js_new} against the shipped {js_ref}: 1 rows and 7 columns in both
  columns only in the reference: old
  identical: temperature.stderr, run.seed, run.theory.hcs.a2
  changed: state.hash: "ab" -> "cd" (not a number)
  changed: box: [1, 2] -> [1, 3] (not a number)
  changed: z: null -> 0.5 (not a number)
  changed: temperature.mean: 1.0 -> 1.03 (0.029 relative; 2.1 sigma)
""", ""))

# 3c. More than 20 identical columns are counted, not listed
wide_ref = write("wide_ref.csv", "k," + ",".join(f"c{i}" for i in range(22)) + "\nr," + ",".join("1" * 22) + "\n")
wide_new = write("wide_new.csv", "k," + ",".join(f"c{i}" for i in range(22)) + "\nr," + ",".join("1" * 21) + ",2\n")
code, out, err = run(wide_ref, wide_new)
expect("wide report", (code, out, err), (0, f"""{wide_new} against the shipped {wide_ref}: 1 rows and 22 columns in both
  identical: 21 columns
  changed: c21: largest in row r: 1 -> 2 (0.5 relative)
""", ""))

# 4. Errors: exit 2, the file and the reason, nothing on stdout
missing = os.path.join(a.work, "missing.csv")
empty = write("empty.md", "no table here\n")
ragged = write("ragged.csv", "name,T\na,1,2\n")
for label, args, want in [
        ("missing file", (ref, missing), f"compare_tables.py: {missing}: no such file\n"),
        ("no table", (empty, ref), f"compare_tables.py: {empty}: expected a table with a header and at least one row, found 0 line(s)\n"),
        ("ragged row", (ragged, ref), f"compare_tables.py: {ragged}: row 1 has 3 cells, the header 2\n"),
        ("json list", (write("list.json", "[1, 2]"), ref),
         f"compare_tables.py: {os.path.join(a.work, 'list.json')}: expected a JSON object (a summary.json), found list\n"),
        ("odd arguments", (ref,), "compare_tables.py: usage: compare_tables.py REFERENCE NEW [REFERENCE NEW ...]\n")]:
    code, out, err = run(*args)
    expect(label, (code, out, err), (2, "", want))

if failures:
    print("\n".join(failures))
    sys.exit(1)
print("ok   compare_tables.py: csv, tsv and markdown reports, and its errors")
