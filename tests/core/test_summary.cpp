// src/core/summary.hpp: summary.json, the dotted keys written as nested JSON in the order they
// were first set (docs/OUTPUT.md): numbers with 17 significant digits (they round-trip), NaN
// and ±Inf as null, integers and booleans as such, strings escaped; a key set again replaces
// its value in place; a key that is a prefix of another is a programming error (thrown).
// Written for the sweep/summary mutation audit (docs/reviews/mutation-audit-sweep-summary.md).
#include "src/core/summary.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace {

using grainbath::Summary;

TEST(Summary, WritesNestedJsonInTheOrderKeysWereFirstSet) {
  Summary s;
  s.set("run.solver", std::string("dsmc"));
  s.set("temperature.mean", 0.1);
  s.set("temperature.stderr", 1.0 / 3.0);
  s.set("run.seed", std::int64_t{9007199254740993});  // 2^53 + 1: no double holds it
  s.set("a2.mean", std::nan(""));
  s.set("a2.stderr", std::numeric_limits<double>::infinity());
  s.set("a2.low", -std::numeric_limits<double>::infinity());
  s.set("theory.homogeneous", true);
  s.set("temperature.stderr_plateau", false);
  s.set("temperature.mean", 0.25);  // replaced in place: keeps its first position
  s.set_all("", {{"top", 2.5}});
  s.set_all("profile", {{"exponent", -0.8}, {"exponent_stderr", 1e-300}});
  s.set("run.note", std::string("a \"b\" \\ c\nd\te\rf\x01g\x1fh\x7f"));
  EXPECT_EQ(s.entries().size(), 13u);
  const std::string want =
      "{\n"
      "  \"run\": {\n"
      "    \"solver\": \"dsmc\",\n"
      "    \"seed\": 9007199254740993,\n"
      "    \"note\": \"a \\\"b\\\" \\\\ c\\nd\\te\\rf\\u0001g\\u001fh\x7f\"\n"
      "  },\n"
      "  \"temperature\": {\n"
      "    \"mean\": 0.25,\n"
      "    \"stderr\": 0.33333333333333331,\n"
      "    \"stderr_plateau\": false\n"
      "  },\n"
      "  \"a2\": {\n"
      "    \"mean\": null,\n"
      "    \"stderr\": null,\n"
      "    \"low\": null\n"
      "  },\n"
      "  \"theory\": {\n"
      "    \"homogeneous\": true\n"
      "  },\n"
      "  \"top\": 2.5,\n"
      "  \"profile\": {\n"
      "    \"exponent\": -0.80000000000000004,\n"
      "    \"exponent_stderr\": 1e-300\n"
      "  }\n"
      "}\n";
  EXPECT_EQ(s.to_json(), want);
}

TEST(Summary, NumbersAreReadBackAsSetAndAbsentKeysAreNaN) {
  Summary s;
  s.set("x.d", 0.1);
  s.set("x.i", std::int64_t{-42});
  s.set("x.b", true);
  s.set("x.s", std::string("1.5"));
  s.set("x.d", 0.2);
  EXPECT_EQ(s.number("x.d"), 0.2);
  EXPECT_EQ(s.number("x.i"), -42.0);
  EXPECT_TRUE(std::isnan(s.number("x.b")));  // a flag, no number
  EXPECT_TRUE(std::isnan(s.number("x.s")));
  EXPECT_TRUE(std::isnan(s.number("x.missing")));
  ASSERT_NE(s.get("x.s"), nullptr);
  EXPECT_EQ(std::get<std::string>(*s.get("x.s")), "1.5");
  EXPECT_EQ(s.get("x"), nullptr);
  EXPECT_EQ(s.entries().size(), 4u);
}

TEST(Summary, AKeyThatIsAPrefixOfAnotherIsRefused) {
  Summary a;
  a.set("temperature", 1.0);
  a.set("temperature.mean", 1.0);
  EXPECT_THROW(a.to_json(), std::logic_error);
  Summary b;
  b.set("temperature.mean.x", 1.0);
  b.set("temperature.mean", 1.0);
  EXPECT_THROW(b.to_json(), std::logic_error);
}

}  // namespace
