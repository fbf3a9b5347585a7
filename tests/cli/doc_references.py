#!/usr/bin/python3
"""doc_references: what the documents (README.md, docs/*.md, docs/validation/*.md,
python/README.md and the case READMEs) refer to still exists. Two checks, one ctest each:

commands GRAINBATH SOURCE_DIR (test doc_commands): every `grainbath run|sweep|check|theory CASE
...` written in the documents, with CASE a shipped directory under cases/ or bench/, is checked
as `grainbath check CASE --set ...` with the same overrides: a key renamed in the code, or
misspelt in a document, fails here instead of in a reader's terminal. Shell variables ($s,
${seed}) stand for 1; a sweep's list of values is checked with its first; a value written as a
placeholder (one capital letter: E, S, N) or elided ("1,2,...,16" past its first) is left out;
a command whose case is a variable (cases/dense-medium/$c) is skipped. At least 50 commands.

paths SOURCE_DIR (test doc_paths): every path under a folder of this repository (cases/,
scripts/, docs/, tests/, src/, operators/, closures/, hydro/, bench/, python/, cmake/, fuzz/)
the documents name must exist: a file or folder renamed or removed otherwise leaves them
pointing at nothing. A module may be named without its extension (closures/hcs for
closures/hcs.hpp and .cpp). Not checked: what runs write (a path with an output or sweep
folder, report/, or under a run's --out), patterns (*, <, >), shell variables ($nu) and the
placeholders of the error-message examples (cases/NAME, cases/x, cases/nope). At least 200
paths."""
import glob
import os
import re
import shlex
import subprocess
import sys


def documents():
    files = set(glob.glob("cases/**/README.md", recursive=True) + glob.glob("docs/*.md") +
                glob.glob("docs/validation/*.md") + ["README.md", "python/README.md"])
    return sorted(f for f in files if "/output" not in f and "/sweep/" not in f)


def check_commands(exe):
    """(number of commands checked, failures)"""
    command = re.compile(r"grainbath (run|sweep|check|theory) ((?:cases|bench)/[A-Za-z0-9_./-]*)(\$?)(.*)")
    checked, failures = 0, []
    for path in documents():
        text = open(path, encoding="utf-8").read().replace("\\\n", " ")  # shell line continuations
        for number, line in enumerate(text.split("\n"), 1):
            for m in command.finditer(line):
                verb, case, variable, rest = m.group(1), m.group(2).rstrip(".,)`"), m.group(3), m.group(4)
                if variable or not os.path.isfile(os.path.join(case, "case.toml")):
                    continue  # the case is a variable, or a study's folder named in prose
                rest = re.split(r"[`|;#)]|&&|>", rest)[0]  # the command ends at prose or a redirection
                rest = re.sub(r"\$\{?[A-Za-z_]+\}?", "1", rest)
                try:
                    words = shlex.split(rest)
                except ValueError:
                    continue  # an unbalanced quote: prose around the command
                sets = []
                for k, w in enumerate(words[:-1]):
                    if w != "--set":
                        continue
                    key, _, value = words[k + 1].partition("=")
                    if verb == "sweep":
                        value = re.split(r",(?![^\[]*\])", value)[0]  # top-level commas only
                    if not key or re.fullmatch(r"[A-Z]", value) or "..." in value or "\u2026" in value:
                        continue
                    sets += ["--set", f"{key}={value}"]
                checked += 1
                r = subprocess.run([exe, "check", case] + sets, capture_output=True, text=True)
                if r.returncode != 0:
                    failures.append(f"{path}:{number}: grainbath check {case} {' '.join(sets)}\n  {r.stderr.strip()}")
    return checked, failures


def check_paths():
    """(number of paths checked, failures)"""
    top = "cases|scripts|docs|tests|src|operators|closures|hydro|bench|python|cmake|fuzz"
    path = re.compile(r"(?<![\w/.$-])((?:" + top + r")/[A-Za-z0-9_.*$/<>-]*[A-Za-z0-9_*$>])")
    written_by_runs = re.compile(r"(^|/)(output[^/]*|sweep|report)(/|$)")
    placeholders = {"cases/NAME", "cases/x", "cases/nope"}
    checked, failures = 0, []
    for f in documents():
        for number, line in enumerate(open(f, encoding="utf-8"), 1):
            for m in path.finditer(line):
                p = m.group(1).rstrip(".")
                if any(c in p for c in "*<>$") or written_by_runs.search(p):
                    continue
                if any(p == h or p.startswith(h + "/") for h in placeholders):
                    continue
                checked += 1
                if not (os.path.exists(p) or glob.glob(p + ".*")):
                    failures.append(f"{f}:{number}: {p} does not exist")
    return checked, failures


mode = sys.argv[1] if len(sys.argv) > 1 else ""
if mode == "commands" and len(sys.argv) == 4:
    os.chdir(sys.argv[3])
    checked, failures = check_commands(sys.argv[2])
    minimum, what = 50, "grainbath commands in the documents name valid keys (grainbath check with their --set)"
elif mode == "paths" and len(sys.argv) == 3:
    os.chdir(sys.argv[2])
    checked, failures = check_paths()
    minimum, what = 200, "paths named in the documents exist"
else:
    sys.exit("usage: doc_references.py commands GRAINBATH SOURCE_DIR | paths SOURCE_DIR")
if checked < minimum:
    failures.append(f"only {checked} found (expected at least {minimum}): is the pattern still right?")
if failures:
    print("FAIL:\n  " + "\n  ".join(failures))
    sys.exit(1)
print(f"ok   {checked} {what}")
