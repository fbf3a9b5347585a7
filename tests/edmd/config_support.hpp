#pragma once
// An EDMD case given as TOML text, read and checked the way the CLI reads case.toml (every
// key validated, misspelt keys rejected), for the tests in tests/edmd.
#include <string>

#include "core/case_file.hpp"
#include "edmd/edmd.hpp"

namespace grainbath::edmd::testing {

inline Config config_from(const std::string& toml) {
  CaseReader r(toml, "test.toml");
  Config c = read_config(r);
  r.finish();
  return c;
}

}  // namespace grainbath::edmd::testing
