#!/usr/bin/env bash
# cases_check: every case.toml shipped under cases/ (the top-level cases and each study's
# sub-cases) passes `grainbath check`, and `grainbath theory` gives valid JSON for it. The
# reader is strict (an unknown or misspelt key is an error), so a key renamed in the code
# without the shipped cases would otherwise reach the first user of that case. About 4 s.
# usage: cases_check.sh GRAINBATH SOURCE_DIR
set -uo pipefail
exe=$1
cd "$2" || exit 1
# the tracked files in a checkout (outputs beside the cases hold copies of case.toml); find
# elsewhere, leaving out what runs write
if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  mapfile -t files < <(git ls-files 'cases/*case.toml' 'cases/**/case.toml' | sort -u)
else
  mapfile -t files < <(find cases -name case.toml -not -path '*/output*' -not -path '*/sweep/variant-*' \
                         -not -path '*.previous/*' | sort)
fi
[ "${#files[@]}" -ge 19 ] || { echo "FAIL: found ${#files[@]} case.toml files under cases/, expected at least 19"; exit 1; }
fail=0
for f in "${files[@]}"; do
  d=$(dirname "$f")
  if ! err=$("$exe" check "$d" 2>&1 > /dev/null); then
    echo "FAIL: grainbath check $d:"; echo "$err"; fail=1; continue
  fi
  if ! out=$("$exe" theory "$d" 2> /dev/null) ||
     ! printf '%s' "$out" | /usr/bin/python3 -c 'import json, sys; json.load(sys.stdin)' 2> /dev/null; then
    echo "FAIL: grainbath theory $d: exit or JSON broken:"; "$exe" theory "$d" 2>&1 | head -5; fail=1
  fi
done
[ "$fail" = 0 ] && echo "ok   ${#files[@]} shipped cases pass check, and theory gives JSON for each"
exit $fail
