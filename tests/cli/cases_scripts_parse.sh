#!/usr/bin/env bash
# cases_scripts_parse: every script shipped in cases/ and scripts/ parses (python3 compiles each .py, bash
# -n reads each .sh; run.sh scripts written for sh are read by sh -n too). No test runs the case
# scripts (minutes to hours each; each README gives its command), so a syntax error in one would
# otherwise reach a user first.
# usage: cases_scripts_parse.sh SOURCE_DIR
set -uo pipefail
cd "$1" || exit 1
fail=0 n=0
while IFS= read -r -d '' f; do
  n=$((n + 1))
  case $f in
    *.py) err=$(/usr/bin/python3 -c 'import ast, sys; ast.parse(open(sys.argv[1], encoding="utf-8").read(), sys.argv[1])' "$f" 2>&1) ;;
    *.sh) if head -1 "$f" | grep -q 'bin/sh$'; then err=$(sh -n "$f" 2>&1); else err=$(bash -n "$f" 2>&1); fi ;;
  esac
  if [ -n "$err" ]; then echo "FAIL: $f: $err"; fail=1; fi
done < <(find cases scripts -type f \( -name '*.py' -o -name '*.sh' \) -not -path '*/output*' -print0)
[ "$n" -gt 0 ] || { echo "FAIL: no scripts found under $1/cases and $1/scripts"; exit 1; }
[ "$fail" = 0 ] && echo "ok   $n scripts in cases/ and scripts/ parse"
exit $fail
