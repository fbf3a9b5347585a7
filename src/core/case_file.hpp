#pragma once
// Reading a case file (CASE_DIR/case.toml) strictly.
//
// Every getter records that its key was used; finish() then reports every key in the file
// that no getter asked for (AMReX-style: an unknown key is an error, never a silent
// default) with a "did you mean" suggestion. Problems are collected, not thrown one at a
// time, so a user sees every mistake in one go: one line per problem naming the file, the
// line, the key, what was expected and what was found. The CLI exits with code 2 on them.
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "operators/vec3.hpp"

namespace grainbath {

struct CaseProblem {
  std::string file;
  int line = 0;  // 0: not tied to a line (missing key, command-line override)
  std::string key;
  std::string message;
  std::string to_string() const;
};

class CaseError : public std::runtime_error {
 public:
  explicit CaseError(std::vector<CaseProblem> problems, bool about_names = false);
  const std::vector<CaseProblem>& problems() const { return problems_; }
  // true if a problem is an unknown name (a law, model, profile...): then, and only then,
  // is `grainbath list-models` worth pointing at.
  bool about_names() const { return about_names_; }

 private:
  std::vector<CaseProblem> problems_;
  bool about_names_ = false;
};

// An allowed interval for a real parameter; open or closed at each end.
struct Bounds {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;
  static Bounds any() { return {}; }
  static Bounds positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Bounds non_negative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
  static Bounds closed(double a, double b) { return {a, b, false, false}; }
  static Bounds open(double a, double b) { return {a, b, true, true}; }
  static Bounds half_open(double a, double b) { return {a, b, true, false}; }  // (a, b]
  bool contains(double x) const;
  std::string describe() const;
};

class CaseReader {
 public:
  // Parses `text` (named `file` in messages). Throws CaseError on syntax errors,
  // binary garbage or non-ASCII bytes outside strings and comments.
  CaseReader(std::string text, std::string file);
  ~CaseReader();
  CaseReader(CaseReader&&) noexcept;
  CaseReader& operator=(CaseReader&&) noexcept;

  // Reads CASE_DIR/case.toml. Throws CaseError if it is missing or unreadable.
  static CaseReader from_directory(const std::string& case_dir);

  // Applies a command-line override "section.key=value" (value in TOML syntax; a bare word
  // is taken as a string). Throws CaseError naming the override on a malformed one.
  void apply_override(const std::string& assignment);

  bool has(std::string_view section, std::string_view key) const;
  bool has_section(std::string_view section) const;

  // Typed getters. A missing key takes `fallback` (recorded as a default in resolved());
  // the *_required forms record a problem instead. Range and type problems are recorded.
  double real(std::string_view section, std::string_view key, double fallback, Bounds bounds,
              std::string_view unit = "");
  double real_required(std::string_view section, std::string_view key, Bounds bounds,
                       std::string_view unit = "");
  std::int64_t integer(std::string_view section, std::string_view key, std::int64_t fallback,
                       std::int64_t lo, std::int64_t hi);
  std::int64_t integer_required(std::string_view section, std::string_view key, std::int64_t lo,
                                std::int64_t hi);
  bool boolean(std::string_view section, std::string_view key, bool fallback);
  std::string choice(std::string_view section, std::string_view key, std::string_view fallback,
                     const std::vector<std::string>& allowed);
  std::string text(std::string_view section, std::string_view key, std::string_view fallback);
  Vec3 vec3(std::string_view section, std::string_view key, Vec3 fallback);
  std::vector<double> reals(std::string_view section, std::string_view key,
                            std::vector<double> fallback, std::size_t min_len, std::size_t max_len,
                            Bounds bounds);
  std::vector<std::string> texts(std::string_view section, std::string_view key,
                                 std::vector<std::string> fallback);

  // Records a problem about a key (e.g. a consistency check between keys).
  void problem(std::string_view section, std::string_view key, std::string message);
  // A problem between two keys: blamed on section.key, or on other_section.other_key when
  // only that one came from --set (the user changed it, not the file's line).
  void problem(std::string_view section, std::string_view key, std::string message,
               std::string_view other_section, std::string_view other_key);
  // Marks a key as known without reading it (e.g. a key only one solver uses).
  void accept(std::string_view section, std::string_view key);
  // Declares a section valid for this case even when absent (e.g. [domain]), for messages.
  void accept_section(std::string_view section);
  // A key (key "": a whole section) this case does not read but another setting would:
  // finish() reports it, if present, with `message` instead of "unknown key/section".
  void used_elsewhere(std::string_view section, std::string_view key, std::string message);
  // Marks a present key as deliberately not read; finish() prints `note` for it.
  void ignore(std::string_view section, std::string_view key, std::string note);
  // A note about a key's value that is accepted but not used as written (e.g. rounded to a
  // whole number of steps); finish() prints it as "note: FILE:LINE: section.key: note".
  void note(std::string_view section, std::string_view key, std::string note);

  bool overridden(std::string_view section, std::string_view key) const;
  // The file's own string value of section.key, before any --set ("" if none or no string).
  std::string file_string(std::string_view section, std::string_view key) const;
  // Where section.key's value comes from, for messages: "--set", "case.toml:N" or "default".
  std::string origin(std::string_view section, std::string_view key) const;

  // Reports unknown sections/keys, then throws CaseError if any problem was recorded.
  void finish();
  // Notes (ignored keys) are printed once per process by finish(); this makes the next
  // finish() print them again (the MPI sweep, before each variant it runs into its log).
  static void forget_said_notes();
  bool ok() const;

  // The parameters as resolved (file, overrides, defaults), "section.key" -> TOML value text.
  const std::map<std::string, std::string>& resolved() const { return resolved_; }
  // Records what a file the case names contained (a checksum of the values read from it), as
  // the resolved parameter "section.key": not a key of the case file, but part of what the
  // run used, so that --resume and `sweep --resume` notice a file changed in place and
  // results.h5 /parameters records it. The key must end in "_checksum".
  void record_file_checksum(std::string_view section, std::string_view key, std::uint64_t checksum);
  const std::string& file() const { return file_; }
  const std::string& source_text() const { return text_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string text_;
  std::string file_;
  std::map<std::string, std::string> resolved_;
  std::vector<CaseProblem> problems_;
  bool about_names_ = false;  // an unknown value of a choice() was reported
};

// s without the spaces, tabs and CRs around it: how a --set section.key=value is split and
// read (shell quoting's spaces are not part of it); `sweep` trims its keys and values alike.
std::string_view trim(std::string_view s);

// The shortest decimal form of x that reads back exactly ("0.01", "1.0"), as messages show numbers.
std::string format_real(double x);
// The name of `known` that `word` most likely misspells (as in the case files' "did you mean"),
// or "" when none is close.
std::string closest_name(std::string_view word, const std::set<std::string>& known);

// Rejects bytes toml++ 3.3 mishandles: control characters other than tab/CR/LF anywhere,
// and non-ASCII bytes outside strings and comments. Returns problems (empty if clean).
std::vector<CaseProblem> scan_case_bytes(std::string_view text, const std::string& file);

}  // namespace grainbath
