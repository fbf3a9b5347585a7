// Replays every file of fuzz/corpus/ through the fuzz harness body (in the ordinary build and,
// more usefully, the asan-ubsan preset), so the regression inputs are checked without clang.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fuzz/case_reader_harness.hpp"

namespace fs = std::filesystem;

TEST(CorpusReplay, EveryCorpusFileLoadsOrFailsCleanly) {
  const fs::path dir = fs::path(GRAINBATH_SOURCE_DIR) / "fuzz" / "corpus";
  ASSERT_TRUE(fs::is_directory(dir)) << dir;
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    const std::string bytes = ss.str();
    SCOPED_TRACE(e.path().string());
    EXPECT_EQ(grainbath::fuzz::run_one(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()), 0);
    ++n;
  }
  EXPECT_GE(n, 10);
}

TEST(CorpusReplay, ExampleCasesAreClean) {
  // The shipped cases load without a problem through the same getters.
  for (const char* c : {"equilibrium", "relaxation", "free-cooling"}) {
    const fs::path p = fs::path(GRAINBATH_SOURCE_DIR) / "cases" / c;
    if (!fs::exists(p / "case.toml")) continue;
    EXPECT_NO_THROW({ auto r = grainbath::CaseReader::from_directory(p.string()); (void)r; }) << p;
  }
}
