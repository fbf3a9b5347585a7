#!/usr/bin/env bash
# Short libFuzzer run of the case loader (the "fuzz" ctest; see docs/RELIABILITY.md).
#   tests/fuzz_smoke.sh [FUZZER_BINARY] [SECONDS]
# Without FUZZER_BINARY, builds fuzz/fuzz_case_reader.cpp with clang++ into a temporary
# directory (exit 77 = skipped if clang++ or libFuzzer is missing). Replays fuzz/corpus/,
# then mutates for SECONDS (default 30) in a scratch copy of the corpus; the repository is
# not modified. Any crash, leak, timeout or sanitizer report fails the run, and the
# offending input is printed in base64 (decode it into fuzz/corpus/ once the bug is fixed).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
fuzzer="${1:-}"
seconds="${2:-30}"
work="$(mktemp -d "${TMPDIR:-/tmp}/grainbath-fuzz.XXXXXX")"
trap 'rm -rf "$work"' EXIT

if [ -z "$fuzzer" ]; then
  cxx="${CXX_FUZZ:-$(command -v clang++ || true)}"
  if [ -z "$cxx" ]; then
    echo "fuzz_smoke: clang++ not found; skipped (apt-get install clang libclang-rt-14-dev)"
    exit 77
  fi
  echo "fuzz_smoke: building the fuzzer with $cxx"
  if ! "$cxx" -std=c++20 -g -O1 -fno-omit-frame-pointer -fsanitize=fuzzer,address,undefined \
      -fno-sanitize-recover=undefined -I"$here" -I"$here/src" \
      "$here/fuzz/fuzz_case_reader.cpp" "$here/src/core/case_file.cpp" "$here/src/core/physics_config.cpp" \
      -o "$work/fuzz_case_reader" 2>"$work/build.log"; then
    if grep -q -E "fuzzer|clang_rt" "$work/build.log"; then
      cat "$work/build.log"
      echo "fuzz_smoke: libFuzzer runtime missing; skipped (apt-get install libclang-rt-14-dev)"
      exit 77
    fi
    cat "$work/build.log"
    exit 1
  fi
  fuzzer="$work/fuzz_case_reader"
fi

mkdir -p "$work/corpus" "$work/artifacts"
cp "$here"/fuzz/corpus/* "$work/corpus/"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
set +e
"$fuzzer" "$work/corpus" -dict="$here/fuzz/toml.dict" -max_total_time="$seconds" -max_len=4096 \
  -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$work/artifacts/" \
  >"$work/fuzz.log" 2>&1
rc=$?
set -e
tail -n 25 "$work/fuzz.log"
if [ $rc -ne 0 ] || [ -n "$(ls -A "$work/artifacts")" ]; then
  echo "fuzz_smoke: FAILED (exit $rc); reproducers (base64):"
  for f in "$work"/artifacts/*; do
    [ -e "$f" ] || continue
    echo "--- $(basename "$f")"
    base64 -w0 "$f"
    echo
  done
  grep -E "ERROR|runtime error|SUMMARY" "$work/fuzz.log" | head -n 20 || true
  exit 1
fi
echo "fuzz_smoke: OK ($seconds s, no crash, leak or sanitizer report)"
