// The case file's pre-scan (src/core/case_file.cpp prepare_case_text, utf8_decode, too_deep):
// toml++ is given only ASCII, so every valid TOML string, comment and whitespace must mean
// the same after the rewrite, and every bad byte must be said with its line. Found by the
// mutation audit of the EDMD reader (docs/reviews/mutation-audit-edmd-reader.md): the readers'
// CLI tests covered the refusals, not the values read back through the rewrite.
#include <gtest/gtest.h>

#include <string>

#include "core/case_file.hpp"

using grainbath::CaseError;
using grainbath::CaseProblem;
using grainbath::CaseReader;

namespace {

// The string value of [s] v in `toml` as the reader gives it back.
std::string string_of(const std::string& toml) {
  CaseReader r(toml, "t.toml");
  return r.text("s", "v", "(missing)");
}

// The problems the constructor throws for `toml` (empty if it reads).
std::vector<CaseProblem> problems_of(const std::string& toml) {
  try {
    CaseReader r(toml, "t.toml");
  } catch (const CaseError& e) {
    return e.problems();
  }
  return {};
}

std::string all_messages(const std::vector<CaseProblem>& ps) {
  std::string s;
  for (const auto& p : ps) s += p.to_string() + "\n";
  return s;
}

}  // namespace

TEST(CaseText, TabsAreWhitespaceNotControlBytes) {
  CaseReader r("[s]\n\tv\t=\t3\t# tab-indented\n", "t.toml");
  EXPECT_EQ(r.integer("s", "v", 0, 0, 10), 3);
}

TEST(CaseText, Utf8InsideStringsIsReadBackUnchanged) {
  // 2-, 3- and 4-byte sequences (é, —, U+1F600): the rewrite's \u and \U escapes
  EXPECT_EQ(string_of("[s]\nv = \"caf\xC3\xA9 \xE2\x80\x94 \xF0\x9F\x98\x80\"\n"), "caf\xC3\xA9 \xE2\x80\x94 \xF0\x9F\x98\x80");
  EXPECT_EQ(string_of("[s]\nv = 'caf\xC3\xA9 \xF0\x9F\x98\x80'\n"), "caf\xC3\xA9 \xF0\x9F\x98\x80");
  EXPECT_EQ(string_of("[s]\nv = \"\"\"\n\xF0\x9F\x98\x80\"\"\"\n"), "\xF0\x9F\x98\x80");
}

TEST(CaseText, LiteralStringsKeepBackslashesAndQuotes) {
  // a literal string has no escapes: it becomes a basic string with them escaped
  EXPECT_EQ(string_of("[s]\nv = 'C:\\data\\\"x\"'\n"), "C:\\data\\\"x\"");
  EXPECT_EQ(string_of("[s]\nv = ''\n"), "");
  EXPECT_EQ(string_of("[s]\nv = '''a\\b\"c'''\n"), "a\\b\"c");
  // up to two quotes before the closing three belong to the string
  EXPECT_EQ(string_of("[s]\nv = '''a'''''\n"), "a''");
  const auto six = problems_of("[s]\nv = '''a''''''\n");
  ASSERT_EQ(six.size(), 1u) << all_messages(six);
  EXPECT_EQ(six[0].line, 2);
  EXPECT_NE(six[0].message.find("ends with more than five quotes"), std::string::npos) << six[0].message;
}

TEST(CaseText, MultiLineBasicStringsKeepInnerQuotesAndLineEndingBackslashes) {
  EXPECT_EQ(string_of("[s]\nv = \"\"\"a\"\"b\"\"\"\n"), "a\"\"b");
  // (two quotes do not close it: UTF-8 after them is still inside the string)
  EXPECT_EQ(string_of("[s]\nv = \"\"\"a\"\"\xC3\xA9\"\"\"\n"), "a\"\"\xC3\xA9");
  // a backslash at a line end joins the lines (TOML), and the line count stays right after it
  EXPECT_EQ(string_of("[s]\nv = \"\"\"a \\\n    b\"\"\"\n"), "a b");
  const auto after = problems_of("[s]\nv = \"\"\"a \\\n    b\"\"\"\nw = 1 2\n");
  ASSERT_EQ(after.size(), 1u) << all_messages(after);
  EXPECT_EQ(after[0].line, 4) << all_messages(after);
  EXPECT_EQ(after[0].key, "s.w");
}

TEST(CaseText, EveryBadByteIsSaidWithItsLineUpToFive) {
  const auto ps = problems_of("[s]\na = 1\xC2\xA0\nb = \"\x01\"\nc = 2\xFF\n");
  ASSERT_EQ(ps.size(), 3u) << all_messages(ps);
  EXPECT_EQ(ps[0].line, 2);
  EXPECT_EQ(ps[1].line, 3);
  EXPECT_EQ(ps[2].line, 4);
  std::string many = "[s]\n";
  for (int k = 0; k < 8; ++k) many += "k" + std::to_string(k) + " = 1\xFF\n";
  EXPECT_EQ(problems_of(many).size(), 5u);
}

TEST(CaseText, OverlongAndOutOfRangeUtf8AndEscapedDeleteAreRefused) {
  struct T {
    const char* text;
    const char* what;
  };
  for (const T& t : {T{"[s]\nv = \"\xE0\x80\xAF\"\n", "not valid UTF-8"},   // '/' as a 3-byte overlong
                     T{"[s]\nv = \"\xF0\x80\x80\xAF\"\n", "not valid UTF-8"},  // as a 4-byte overlong
                     T{"[s]\nv = \"\xF4\x90\x80\x80\"\n", "not valid UTF-8"},  // U+110000
                     T{"[s]\nv = \"\\\x7f\"\n", "control byte 0x7f"}}) {
    SCOPED_TRACE(t.text);
    const auto ps = problems_of(t.text);  // (each byte of a bad sequence is said)
    ASSERT_FALSE(ps.empty());
    EXPECT_EQ(ps[0].line, 2);
    EXPECT_EQ(ps[0].key, "s.v");
    EXPECT_NE(ps[0].message.find(t.what), std::string::npos) << ps[0].message;
  }
}

TEST(CaseText, NestingLimitsCountTablesNotDecimalPoints) {
  // 300 decimal numbers on one line are no nesting (the per-line limit is 128 levels)
  std::string numbers = "[s]\nv = [";
  for (int k = 0; k < 300; ++k) numbers += (k ? ", " : "") + std::to_string(k) + ".5";
  CaseReader r(numbers + "]\n", "t.toml");
  EXPECT_EQ(r.reals("s", "v", {}, 300, 300, grainbath::Bounds::any()).size(), 300u);
  // 200 inline tables on one line are stopped by the pre-scan, before toml++ recurses
  std::string inline_deep = "[s]\nv = ";
  for (int k = 0; k < 200; ++k) inline_deep += "{a=";
  const auto ps = problems_of(inline_deep + "1" + std::string(200, '}') + "\n");
  ASSERT_EQ(ps.size(), 1u) << all_messages(ps);
  EXPECT_NE(ps[0].message.find("too deeply nested keys or tables (more than 128 levels on one line)"), std::string::npos)
      << ps[0].message;
}
