// libFuzzer entry point for the case loader (CaseReader + the shared section readers).
// Build: cmake --preset fuzz && cmake --build build-fuzz (clang only), or tests/fuzz_smoke.sh.
// See docs/RELIABILITY.md for the short and long runs.
#include "fuzz/case_reader_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return grainbath::fuzz::run_one(data, size);
}
