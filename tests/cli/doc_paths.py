#!/usr/bin/python3
"""doc_paths: the files and folders the documents name exist.

Every path under a folder of this repository (cases/, scripts/, docs/, tests/, src/,
operators/, closures/, hydro/, bench/, python/, cmake/, fuzz/) written in README.md,
docs/*.md, docs/validation/*.md, python/README.md or a case README must exist: a file or
folder renamed or removed otherwise leaves the documents pointing at nothing. A module may be named without its extension (closures/hcs
for closures/hcs.hpp and .cpp). Not checked: what runs write (a path with an output or sweep
folder, report/, or under a run's --out), patterns (*, <, >), shell variables ($nu) and the
placeholders of the error-message examples (cases/NAME, cases/x, cases/nope).

usage: doc_paths.py SOURCE_DIR"""
import glob
import os
import re
import sys

os.chdir(sys.argv[1])
files = sorted(set(glob.glob("cases/**/README.md", recursive=True) + glob.glob("docs/*.md") +
                   glob.glob("docs/validation/*.md") + ["README.md", "python/README.md"]))
files = [f for f in files if "/output" not in f]
top = "cases|scripts|docs|tests|src|operators|closures|hydro|bench|python|cmake|fuzz"
path = re.compile(r"(?<![\w/.$-])((?:" + top + r")/[A-Za-z0-9_.*$/<>-]*[A-Za-z0-9_*$>])")
written_by_runs = re.compile(r"(^|/)(output[^/]*|sweep|report)(/|$)")
placeholders = {"cases/NAME", "cases/x", "cases/nope"}
missing, checked = [], 0
for f in files:
    for number, line in enumerate(open(f, encoding="utf-8"), 1):
        for m in path.finditer(line):
            p = m.group(1).rstrip(".")
            if any(c in p for c in "*<>$") or written_by_runs.search(p):
                continue
            if any(p == h or p.startswith(h + "/") for h in placeholders):
                continue
            checked += 1
            if not (os.path.exists(p) or glob.glob(p + ".*")):
                missing.append(f"{f}:{number}: {p}")
if checked < 200:
    missing.append(f"only {checked} paths found in the documents (expected at least 200): is the pattern still right?")
if missing:
    print("FAIL: the documents name paths that do not exist:\n  " + "\n  ".join(missing))
    sys.exit(1)
print(f"ok   {checked} paths named in the documents exist")
