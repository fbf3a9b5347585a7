#pragma once
// The body of the case-loader fuzzer, shared by the libFuzzer entry point
// (fuzz/fuzz_case_reader.cpp) and the corpus replay test (tests/cli/corpus_replay_test.cpp,
// which runs every file of fuzz/corpus/ through it in the ordinary and sanitizer builds).
//
// Input format: the case file text; if it contains a line "--set", every following line is
// a command-line override (section.key=value) applied before the getters, as the CLI does.
// The only exception allowed out of the loader is CaseError; anything else (another
// exception, a crash, a sanitizer report, a leak) is a bug.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/case_file.hpp"
#include "core/physics_config.hpp"

namespace grainbath::fuzz {

inline void exercise(CaseReader& r) {
  // [run] as the CLI reads it, then the solver keys (same getters and bounds as
  // dsmc::read_config and the shared readers).
  r.choice("run", "solver", "dsmc", {"dsmc", "edmd"});
  r.integer("run", "seed", 1, 0, INT64_MAX);
  r.integer("run", "threads", 0, 0, 4096);
  r.real("grains", "density", 1.0, Bounds::positive(), "grains per volume");
  r.real("grains", "mass", 1.0, Bounds::positive(), "mass");
  r.real("grains", "temperature", 1.0, Bounds::positive(), "energy");
  r.vec3("grains", "drift", {});
  read_background(r);
  read_restitution(r);
  r.integer_required("dsmc", "particles", 2, 2'000'000'000);
  r.real_required("dsmc", "dt", Bounds::positive(), "time");
  r.real("dsmc", "t_end", 10.0, Bounds::positive(), "time");
  r.real("sampling", "every", 0.1, Bounds::positive(), "time");
  r.real("sampling", "steady_from", 0.0, Bounds::non_negative(), "time");
  r.integer("sampling", "histogram_bins", 100, 4, 100000);
  r.boolean("sampling", "relaxation_theory", true);
  r.reals("sampling", "levels", {}, 0, 8, Bounds::closed(-1.0, 1.0));
  r.texts("output", "fields", {"T"});
  r.text("output", "name", "x");
  r.has("run", "solver");
  r.has_section("edmd");
  r.accept("edmd", "box");
  if (r.has("dsmc", "dt") && r.has("dsmc", "t_end")) r.problem("dsmc", "dt", "consistency check");
  (void)r.resolved();
}

// Returns 0 always (libFuzzer convention); lets only CaseError pass silently.
inline int run_one(const std::uint8_t* data, std::size_t size) {
  std::string all(reinterpret_cast<const char*>(data), size);
  std::string text = all;
  std::vector<std::string> overrides;
  const std::string marker = "\n--set\n";
  if (const auto at = all.find(marker); at != std::string::npos) {
    text = all.substr(0, at + 1);
    std::string rest = all.substr(at + marker.size());
    std::size_t start = 0;
    while (start <= rest.size() && overrides.size() < 8) {
      const auto nl = rest.find('\n', start);
      overrides.push_back(rest.substr(start, nl == std::string::npos ? std::string::npos : nl - start));
      if (nl == std::string::npos) break;
      start = nl + 1;
    }
  }
  try {
    CaseReader r(text, "fuzz/case.toml");
    for (const auto& o : overrides) {
      try {
        r.apply_override(o);
      } catch (const CaseError& e) {
        if (e.problems().empty()) __builtin_trap();  // an error must say what is wrong
      }
    }
    exercise(r);
    r.finish();
  } catch (const CaseError& e) {
    // Every problem must name its file and say what is wrong, in one line.
    if (e.problems().empty() || std::string_view(e.what()).empty()) __builtin_trap();
    for (const auto& p : e.problems()) {
      if (p.file.empty() || p.message.empty() || p.line < 0) __builtin_trap();
      if (p.to_string().find_first_of("\n\r") != std::string::npos) __builtin_trap();
    }
  }
  return 0;
}

}  // namespace grainbath::fuzz
