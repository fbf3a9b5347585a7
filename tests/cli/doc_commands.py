#!/usr/bin/python3
"""doc_commands: the grainbath commands written in the documents still name valid keys.

Every `grainbath run|sweep|check|theory CASE ...` written in README.md, docs/*.md and the case
READMEs, with CASE a shipped directory under cases/ or bench/, is checked as `grainbath check
CASE --set ...` with the same overrides: a key renamed in the code, or misspelt in a document,
fails here instead of in a reader's terminal. Shell variables ($s, ${seed}) stand for 1; a
sweep's list of values is checked with its first; a value written as a placeholder (one
capital letter: E, S, N) or elided ("1,2,...,16" past its first) is left out; a command whose
case is a variable (cases/dense-medium/$c) is skipped. At least 50 commands must be found.

usage: doc_commands.py GRAINBATH SOURCE_DIR"""
import glob
import os
import re
import shlex
import subprocess
import sys

exe, root = sys.argv[1], sys.argv[2]
os.chdir(root)
files = sorted(set(glob.glob("cases/**/README.md", recursive=True) + glob.glob("docs/*.md") + ["README.md"]))
files = [f for f in files if "/output" not in f and "/sweep/" not in f]
command = re.compile(r"grainbath (run|sweep|check|theory) ((?:cases|bench)/[A-Za-z0-9_./-]*)(\$?)(.*)")
checked, failures = 0, []
for path in files:
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
if checked < 50:
    failures.append(f"only {checked} documented commands found (expected at least 50): is the pattern still right?")
if failures:
    print("FAIL:\n" + "\n".join(failures))
    sys.exit(1)
print(f"ok   {checked} grainbath commands in the documents name valid keys (grainbath check with their --set)")
