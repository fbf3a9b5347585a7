// Strict case-file reader on toml++ (header-only, compiled here with NDEBUG: Debian's
// toml++ 3.3.0 aborts on some malformed inputs when its asserts are enabled).
// GRAINBATH_TOML_ASSERTS (fuzz/ only) keeps toml++'s assertions on instead, so the fuzzer
// reports inputs that break toml++'s internal assumptions.
#ifdef GRAINBATH_TOML_ASSERTS
#undef NDEBUG
#elif !defined(NDEBUG)
#define NDEBUG
#endif
#include "core/case_file.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>

#define TOML_EXCEPTIONS 1
#ifdef GRAINBATH_TOML_ASSERTS
// Fuzzing diagnostic: report toml++'s assertions, except those reviewed as benign in
// toml++ 3.3.0's parser.inl: the entry assertions of parse_key (3037: "[|"), parse_date
// (2291), parse_time (2345), parse_date_time (2433: "a = 1979-05-27T(07:32") and
// parse_value (2549, 2636: "x = [1, }"), whose functions then fail with a syntax error on
// exactly the inputs that break the assertion.
#include <cstdlib>
#include <cstring>
inline void grainbath_toml_assert_failed(const char* expr, const char* file, int line) {
  static const struct { const char* expr; int line; } benign[] = {
      {"is_bare_key_character(*cp) || is_string_delimiter(*cp)", 3037},
      {"is_decimal_digit(*cp)", 2291},
      {"is_decimal_digit(*cp)", 2345},
      {"is_decimal_digit(*cp)", 2433},
      {"!is_value_terminator(*cp)", 2549},  // parse_value on "x = [1, }": "could not determine value type"
      {"!is_value_terminator(*cp)", 2636},  // the same character, first pass of its type scan
  };
  for (const auto& b : benign)
    if (line == b.line && std::strcmp(expr, b.expr) == 0 && std::strstr(file, "parser.inl")) return;
  std::fprintf(stderr, "%s:%d: toml++ assertion failed: %s\n", file, line, expr);
  std::abort();
}
#define TOML_ASSERT(expr) ((expr) ? (void)0 : grainbath_toml_assert_failed(#expr, __FILE__, __LINE__))
#endif
#include <toml++/impl/preprocessor.h>
// With NDEBUG, toml++ turns its assertions into optimiser assumptions (__builtin_assume under
// clang). Some are false on malformed input (see above), which would make them undefined
// behaviour; toml++'s parser handles those cases itself, so the assumptions are dropped.
#undef TOML_ASSUME
#define TOML_ASSUME(...) static_assert(true)
#include <toml++/toml.h>

namespace grainbath {

std::string format_real(double x) {
  char buf[64];
  for (int digits = 15; digits <= 17; ++digits) {  // the shortest form that reads back exactly
    std::snprintf(buf, sizeof buf, "%.*g", digits, x);
    if (std::isnan(x) || std::strtod(buf, nullptr) == x) break;
  }
  std::string s = buf;
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

namespace {

std::string describe_node(const toml::node& n) {
  std::ostringstream os;
  switch (n.type()) {
    case toml::node_type::string: os << "the string \"" << *n.value<std::string>() << "\""; break;
    case toml::node_type::integer: os << "the integer " << *n.value<std::int64_t>(); break;
    case toml::node_type::floating_point: os << "the number " << format_real(*n.value<double>()); break;
    case toml::node_type::boolean: os << "the boolean " << (*n.value<bool>() ? "true" : "false"); break;
    case toml::node_type::array: os << "an array of " << n.as_array()->size() << " element(s)"; break;
    case toml::node_type::table: os << "a table"; break;
    default: os << "a date/time"; break;
  }
  return os.str();
}

std::string fmt_hex(unsigned c) {
  char b[8];
  std::snprintf(b, sizeof b, "%02x", c);
  return b;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string suggestion(std::string_view word, const std::set<std::string>& known) {
  // a word that is part of exactly one name ("sine" of "isobaric_sine", "temp" of
  // "temperature") means that name, rather than another a few letters away ("file")
  if (word.size() >= 3) {
    std::string part;
    int parts = 0;
    for (const auto& k : known)
      if (k.size() > word.size() && lower(k).find(lower(word)) != std::string::npos) part = k, ++parts;
    if (parts == 1) return part;
  }
  std::string best;
  std::size_t best_d = 3;  // suggest only close matches
  for (const auto& k : known) {
    // a word that differs only in case is the closest match ("EDMD" for "edmd")
    const std::size_t d = lower(word) == lower(k) ? 0 : edit_distance(word, k);
    if (d < best_d) { best_d = d; best = k; }
  }
  return best;
}

std::string join(const std::set<std::string>& s) {
  std::string out;
  for (const auto& x : s) out += (out.empty() ? "" : ", ") + x;
  return out;
}

}  // namespace

std::string closest_name(std::string_view word, const std::set<std::string>& known) { return suggestion(word, known); }

// Problems are printed one per line: control characters that come from the case (a string
// value "a\nb", a quoted key, a file name) are shown escaped, never raw.
static std::string one_line(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c == '\n') out += "\\n";
    else if (c == '\r') out += "\\r";
    else if (c == '\t') out += "\\t";
    else if (c < 0x20 || c == 0x7f) out += "\\x" + fmt_hex(c);
    else out += ch;
  }
  return out;
}

std::string CaseProblem::to_string() const {
  std::string s = one_line(file);
  if (line > 0) s += ":" + std::to_string(line);
  s += ": ";
  if (!key.empty()) s += one_line(key) + ": ";
  return s + one_line(message);
}

static std::string join_problems(const std::vector<CaseProblem>& problems) {
  std::string s;
  for (const auto& p : problems) {
    if (!s.empty()) s += '\n';
    s += p.to_string();
  }
  return s;
}

CaseError::CaseError(std::vector<CaseProblem> problems, bool about_names)
    : std::runtime_error(join_problems(problems)), problems_(std::move(problems)), about_names_(about_names) {}

bool Bounds::contains(double x) const {
  if (!std::isfinite(x)) return false;
  if (lo_open ? !(x > lo) : !(x >= lo)) return false;
  if (hi_open ? !(x < hi) : !(x <= hi)) return false;
  return true;
}

std::string Bounds::describe() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi)
    return std::string("in ") + (lo_open ? "(" : "[") + format_real(lo) + ", " + format_real(hi) + (hi_open ? ")" : "]");
  if (has_lo) return std::string(lo_open ? "> " : ">= ") + format_real(lo);
  if (has_hi) return std::string(hi_open ? "< " : "<= ") + format_real(hi);
  return "finite";
}

namespace {
// "a value in (0.0, 1.0)", "a number > 0.0 (time)", "a finite value": what a bounded key
// expects, as the messages say it (review 4: "a value in > 0.0", "a value in a finite number")
std::string expected_number(const Bounds& b, std::string_view noun, std::string_view unit) {
  const std::string u = unit.empty() ? "" : " (" + std::string(unit) + ")";
  const std::string d = b.describe();
  if (d == "finite") return "a finite " + std::string(noun) + u;
  return "a " + std::string(noun) + " " + d + u;
}
}  // namespace

std::string_view trim(std::string_view s) {
  const auto a = s.find_first_not_of(" \t\r");
  if (a == std::string_view::npos) return {};
  const auto b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

namespace {

// Strict UTF-8: returns the sequence length at t[i] (0 if invalid) and its code point.
std::size_t utf8_decode(std::string_view t, std::size_t i, char32_t& cp) {
  const auto b = [&](std::size_t k) { return i + k < t.size() ? static_cast<unsigned char>(t[i + k]) : 0u; };
  const unsigned c0 = b(0);
  auto cont = [&](std::size_t k, unsigned lo = 0x80, unsigned hi = 0xBF) { return b(k) >= lo && b(k) <= hi; };
  if (c0 >= 0xC2 && c0 <= 0xDF && cont(1)) {
    cp = ((c0 & 0x1F) << 6) | (b(1) & 0x3F);
    return 2;
  }
  if (c0 >= 0xE0 && c0 <= 0xEF) {
    const unsigned lo = c0 == 0xE0 ? 0xA0 : 0x80, hi = c0 == 0xED ? 0x9F : 0xBF;  // no overlongs, no surrogates
    if (cont(1, lo, hi) && cont(2)) {
      cp = ((c0 & 0x0F) << 12) | ((b(1) & 0x3F) << 6) | (b(2) & 0x3F);
      return 3;
    }
  }
  if (c0 >= 0xF0 && c0 <= 0xF4) {
    const unsigned lo = c0 == 0xF0 ? 0x90 : 0x80, hi = c0 == 0xF4 ? 0x8F : 0xBF;  // <= U+10FFFF
    if (cont(1, lo, hi) && cont(2) && cont(3)) {
      cp = ((c0 & 0x07) << 18) | ((b(1) & 0x3F) << 12) | ((b(2) & 0x3F) << 6) | (b(3) & 0x3F);
      return 4;
    }
  }
  return 0;
}

std::string unicode_escape(char32_t cp) {
  char b[16];
  if (cp <= 0xFFFF) std::snprintf(b, sizeof b, "\\u%04X", static_cast<unsigned>(cp));
  else std::snprintf(b, sizeof b, "\\U%08X", static_cast<unsigned>(cp));
  return b;
}

// Printable form of a piece of the case file for a message: ASCII kept, anything else \xNN.
std::string printable(std::string_view s, std::size_t max_len = 60) {
  std::string out;
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c >= 0x7f) out += "\\x" + fmt_hex(c);
    else out += ch;
    if (out.size() >= max_len) return out + "...";
  }
  return out;
}


// Best effort, for messages about bytes and syntax (there is no parsed key yet): the key a
// line defines ("section.key"), or the table header on it ("[section]"); searching upwards
// for the statement a continuation line belongs to (a multi-line array or string).
std::string key_near_line(std::string_view text, int line) {
  std::vector<std::string_view> lines;
  for (std::size_t a = 0;;) {
    const auto nl = text.find('\n', a);
    lines.push_back(text.substr(a, nl == std::string_view::npos ? std::string_view::npos : nl - a));
    if (nl == std::string_view::npos) break;
    a = nl + 1;
  }
  if (line < 1 || line > static_cast<int>(lines.size())) return "";
  auto header = [](std::string_view l) -> std::string_view {
    l = trim(l);
    if (l.empty() || l[0] != '[') return {};
    const auto close = l.rfind(']', l.find('#'));
    return close == std::string_view::npos ? l : l.substr(0, close + 1);
  };
  auto key_of = [](std::string_view l) -> std::string_view {
    l = trim(l);
    if (l.empty() || l[0] == '#' || l[0] == '[') return {};
    const auto eq = l.find('=');
    if (eq == std::string_view::npos || eq == 0) return {};
    return trim(l.substr(0, eq));
  };
  std::string_view key;
  int at = line;
  for (; at >= 1; --at) {
    const std::string_view l = lines[static_cast<std::size_t>(at - 1)];
    if (!header(l).empty()) {
      if (at == line) return printable(header(l));
      break;
    }
    if (!(key = key_of(l)).empty()) break;
  }
  if (key.empty()) return "";
  for (int h = at - 1; h >= 1; --h) {
    std::string_view hd = header(lines[static_cast<std::size_t>(h - 1)]);
    if (hd.empty()) continue;
    while (!hd.empty() && (hd.front() == '[' || hd.front() == ' ')) hd.remove_prefix(1);
    while (!hd.empty() && (hd.back() == ']' || hd.back() == ' ')) hd.remove_suffix(1);
    return printable(std::string(hd) + "." + std::string(key));
  }
  return printable(key);
}

struct PreparedText {
  std::string ascii;  // what toml++ parses: the same TOML, pure ASCII, same line numbers
  std::vector<CaseProblem> problems;
};

// toml++ 3.3.0 classifies non-ASCII code points outside strings with functions that reach
// __builtin_unreachable for some of them (is_non_ascii_horizontal_whitespace), and its
// value scanner reads ahead past quotes on malformed input, so "outside a string" cannot be
// decided reliably by a separate pre-scan. Instead toml++ is given only ASCII: control
// bytes and non-ASCII bytes outside strings/comments are problems; UTF-8 inside strings is
// rewritten as \uXXXX escapes (literal strings become equivalent basic strings); comments
// are kept with non-ASCII bytes replaced. Valid TOML means the same after the rewrite;
// whatever our tokenisation of malformed input, toml++ never sees a byte >= 0x80.
PreparedText prepare_case_text(std::string_view text, const std::string& file) {
  PreparedText p;
  std::string& out = p.ascii;
  out.reserve(text.size() + text.size() / 8 + 16);
  int line = 1;
  enum { plain, comment, basic, literal, ml_basic, ml_literal } state = plain;
  auto add = [&](int at, std::string message) {
    if (p.problems.size() < 5) p.problems.push_back({file, at, key_near_line(text, at), std::move(message)});
  };
  auto run_of = [&](std::size_t i, char q) {
    std::size_t n = 0;
    while (i + n < text.size() && text[i + n] == q) ++n;
    return n;
  };
  std::size_t i = 0;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") i = 3;  // a UTF-8 byte-order mark: skipped, as toml++ would
  for (; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '\n') {
      ++line;
      if (state == comment || state == basic || state == literal) state = plain;  // unterminated: toml++ says so
      out += '\n';
      continue;
    }
    if ((c < 0x20 && c != '\t' && c != '\r') || c == 0x7f) {
      add(line, "control byte 0x" + fmt_hex(c) + " in the file: a case file is text (is it binary?)");
      out += ' ';
      continue;
    }
    if (c >= 0x80) {
      char32_t cp = 0;
      const std::size_t len = utf8_decode(text, i, cp);
      if (len == 0) {
        add(line, "byte 0x" + fmt_hex(c) + " is not valid UTF-8 (a case file is UTF-8 text)");
        out += '?';
        continue;
      }
      switch (state) {
        case plain:
          add(line, "non-ASCII character " + printable(text.substr(i, len)) +
                        " outside a string or comment (only strings and comments may hold UTF-8)");
          out += '?';
          break;
        case comment: out += '?'; break;
        default: out += unicode_escape(cp); break;  // inside a string
      }
      i += len - 1;
      continue;
    }
    switch (state) {
      case plain:
        if (c == '#') {
          state = comment;
          out += '#';
        } else if (c == '"' || c == '\'') {
          const bool ml = run_of(i, static_cast<char>(c)) >= 3;
          state = c == '"' ? (ml ? ml_basic : basic) : (ml ? ml_literal : literal);
          out += ml ? "\"\"\"" : "\"";  // a literal string becomes a basic one
          if (ml) i += 2;
        } else {
          out += static_cast<char>(c);
        }
        break;
      case comment:
        out += static_cast<char>(c);
        break;
      case basic:
      case ml_basic:
        if (c == '\\') {
          out += '\\';
          if (i + 1 < text.size() && text[i + 1] != '\n') {
            const unsigned char e = static_cast<unsigned char>(text[i + 1]);
            if (e >= 0x80) {
              add(line, "invalid escape sequence: a backslash before a non-ASCII character");
              out += '?';
            } else if ((e < 0x20 && e != '\t' && e != '\r') || e == 0x7f) {
              add(line, "control byte 0x" + fmt_hex(e) + " in the file: a case file is text (is it binary?)");
              out += ' ';
            } else {
              out += static_cast<char>(e);
            }
            ++i;
          }
        } else if (c == '"') {
          const std::size_t n = state == ml_basic ? run_of(i, '"') : 1;
          if (state == basic || n >= 3) state = plain;
          out.append(n, '"');
          i += n - 1;
        } else {
          out += static_cast<char>(c);
        }
        break;
      case literal:
      case ml_literal:
        if (c == '\'') {
          const std::size_t n = state == ml_literal ? run_of(i, '\'') : 1;
          if (state == literal) {
            out += '"';
            state = plain;
          } else if (n >= 3) {
            if (n > 5) add(line, "TOML syntax error: a multi-line literal string ends with more than five quotes");
            out.append(n - 3, '\'');
            out += "\"\"\"";
            state = plain;
          } else {
            out.append(n, '\'');
          }
          i += n - 1;
        } else if (c == '\\') {
          out += "\\\\";
        } else if (c == '"') {
          out += "\\\"";
        } else {
          out += static_cast<char>(c);
        }
        break;
    }
  }
  return p;
}

// toml++ says "could not determine value type" for law = constant: TOML strings need quotes,
// which users coming from INI or shell files forget. The hint for a value that is one bare word.
std::string bare_word_hint(std::string_view text, int line) {
  std::size_t a = 0;
  for (int l = 1; l < line && a != std::string_view::npos; ++l) {
    a = text.find('\n', a);
    if (a != std::string_view::npos) ++a;
  }
  if (a == std::string_view::npos) return "";
  std::string_view l = text.substr(a, text.find('\n', a) == std::string_view::npos ? std::string_view::npos
                                                                                  : text.find('\n', a) - a);
  const auto eq = l.find('=');
  if (eq == std::string_view::npos) return "";
  std::string_view key = trim(l.substr(0, eq)), value = trim(l.substr(eq + 1, l.find('#') == std::string_view::npos
                                                                                   ? std::string_view::npos
                                                                                   : l.find('#') - eq - 1));
  const auto word_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'; };
  if (value.empty() || !std::isalpha(static_cast<unsigned char>(value[0])) ||
      !std::all_of(value.begin(), value.end(), word_char) || value == "true" || value == "false" || value == "inf" ||
      value == "nan")
    return "";
  return " (a string needs quotes: " + std::string(key) + " = \"" + std::string(value) + "\")";
}

// toml++'s own words for two common slips, said in the case's terms (review 4): a key given
// twice in a table ("cannot redefine existing ... 'key'": where the first one is), and a string
// left open at the end of its line ("unescaped control characters": the line end inside it).
std::string syntax_error_text(std::string_view description, std::string_view text, int line) {
  const std::string d(description);
  if (d.find("cannot redefine existing") != std::string::npos) {
    const auto q1 = d.rfind('\''), q0 = q1 == std::string::npos ? q1 : d.rfind('\'', q1 - 1);
    if (q0 != std::string::npos && q1 > q0 + 1) {
      const std::string key = d.substr(q0 + 1, q1 - q0 - 1);
      // the earlier line of the same table that sets it: back from `line` to the table's header
      std::vector<std::string_view> lines;
      for (std::size_t a = 0; a <= text.size();) {
        const std::size_t b = text.find('\n', a);
        lines.push_back(text.substr(a, b == std::string_view::npos ? std::string_view::npos : b - a));
        if (b == std::string_view::npos) break;
        a = b + 1;
      }
      for (int l = std::min<int>(line - 1, static_cast<int>(lines.size())); l >= 1; --l) {
        const std::string_view t = trim(lines[l - 1]);
        if (!t.empty() && t.front() == '[') break;
        const auto eq = t.find('=');
        if (eq != std::string_view::npos && trim(t.substr(0, eq)) == key)
          return "the key '" + key + "' is given twice in its table (first on line " + std::to_string(l) +
                 "): keep one (toml++: " + d + ")";
      }
      return "the key '" + key + "' is given twice in its table: keep one (toml++: " + d + ")";
    }
  }
  if (d.find("unescaped control characters") != std::string::npos)
    return "a string is not closed on its line (a missing \"?) (toml++: " + d + ")";
  return d;
}

constexpr std::size_t kMaxCaseBytes = 1 << 20;

constexpr int kMaxKeyDotsPerLine = 128, kMaxKeyDots = 1000;

// toml++ builds and walks tables recursively: a header [a.a.a....] with 10^5 parts
// overflows the stack. Counts the dots outside strings and comments that can nest tables
// (not the decimal point of a number that starts a value) and the braces of inline tables;
// a case file needs a handful, so generous limits per line and per file stop the recursion.
std::optional<CaseProblem> too_deep(std::string_view t, const std::string& file) {
  int line = 1, on_line = 0, total = 0;
  enum { plain, comment, basic, ml_basic } state = plain;
  auto report = [&](const std::string& what) {
    return CaseProblem{file, line, key_near_line(t, line), "too deeply nested keys or tables (" + what + ")"};
  };
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c == '\n') {
      ++line;
      on_line = 0;
      if (state == comment || state == basic) state = plain;
      continue;
    }
    switch (state) {
      case comment: break;
      case basic:
        if (c == '\\') ++i;
        else if (c == '"') state = plain;
        break;
      case ml_basic:
        if (c == '\\' && i + 1 < t.size() && t[i + 1] != '\n') ++i;
        else if (t.substr(i, 3) == "\"\"\"") {
          while (i + 1 < t.size() && t[i + 1] == '"') ++i;
          state = plain;
        }
        break;
      case plain: {
        if (c == '#') { state = comment; break; }
        if (c == '"') {
          if (t.substr(i, 3) == "\"\"\"") { state = ml_basic; i += 2; }
          else state = basic;
          break;
        }
        bool nests = c == '{';
        if (c == '.') {
          // a decimal point: digits (after an optional sign) right after a value delimiter
          std::size_t j = i;
          while (j > 0 && (std::isdigit(static_cast<unsigned char>(t[j - 1])) || t[j - 1] == '_')) --j;
          if (j > 0 && (t[j - 1] == '+' || t[j - 1] == '-')) --j;
          const bool digits_before = j < i && std::isdigit(static_cast<unsigned char>(t[i - 1]));
          const bool value_start = j == 0 || std::string_view("=[,{ \t\r\n").find(t[j - 1]) != std::string_view::npos;
          const bool digit_after = i + 1 < t.size() && std::isdigit(static_cast<unsigned char>(t[i + 1]));
          nests = !(digits_before && value_start && digit_after);
        }
        if (nests) {
          if (++on_line > kMaxKeyDotsPerLine) return report("more than " + std::to_string(kMaxKeyDotsPerLine) + " levels on one line");
          if (++total > kMaxKeyDots) return report("more than " + std::to_string(kMaxKeyDots) + " in the file");
        }
        break;
      }
    }
  }
  return std::nullopt;
}

}  // namespace

std::vector<CaseProblem> scan_case_bytes(std::string_view text, const std::string& file) {
  return prepare_case_text(text, file).problems;
}

struct CaseReader::Impl {
  toml::table root;
  std::set<std::string> used;                   // "section.key" asked for by a getter
  std::map<std::string, std::set<std::string>> known;  // section -> keys asked for
  std::set<std::string> overridden;             // "section.key" set by --set
  std::map<std::string, std::string> file_strings;  // "section.key" -> the file's string a --set replaced
  std::map<std::string, std::string> elsewhere;     // "section.key" ("section." for a section) -> message
  std::map<std::string, std::string> ignored;       // "section.key" -> note
  // sections one of whose choice() keys has an unknown value (already reported): which other
  // keys the section takes depends on that choice (law, profile, model), so finish() does not
  // call them unknown; an unknown run.solver leaves every section and key unjudged
  std::set<std::string> unsettled;
  std::string file;

  const toml::table* section(std::string_view s) const {
    return root.get_as<toml::table>(s);
  }
  const toml::node* find(std::string_view s, std::string_view k) const {
    const toml::table* t = section(s);
    return t ? t->get(k) : nullptr;
  }
  int line_of(const toml::node* n) const { return n ? static_cast<int>(n->source().begin.line) : 0; }
};


CaseReader::CaseReader(std::string text, std::string file)
    : impl_(std::make_unique<Impl>()), text_(std::move(text)), file_(std::move(file)) {
  impl_->file = file_;
  if (text_.size() > kMaxCaseBytes)
    throw CaseError({{file_, 0, "", "the file is " + std::to_string(text_.size()) + " bytes; a case file is at most " +
                                        std::to_string(kMaxCaseBytes) + " bytes of text"}});
  PreparedText prepared = prepare_case_text(text_, file_);
  if (!prepared.problems.empty()) throw CaseError(std::move(prepared.problems));
  if (auto deep = too_deep(prepared.ascii, file_)) throw CaseError({*deep});
  try {
    impl_->root = toml::parse(std::string_view(prepared.ascii), std::string_view(file_));
  } catch (const toml::parse_error& e) {
    const int line = static_cast<int>(e.source().begin.line);
    throw CaseError({{file_, line, key_near_line(text_, line),
                      "TOML syntax error: " + syntax_error_text(e.description(), text_, line) +
                          bare_word_hint(text_, line)}});
  }
}

CaseReader::~CaseReader() = default;
CaseReader::CaseReader(CaseReader&&) noexcept = default;
CaseReader& CaseReader::operator=(CaseReader&&) noexcept = default;

CaseReader CaseReader::from_directory(const std::string& case_dir) {
  namespace fs = std::filesystem;
  const fs::path dir(case_dir);
  const fs::path path = dir / "case.toml";
  std::error_code ec;
  if (!fs::exists(dir, ec))
    throw CaseError({{case_dir, 0, "", "case directory does not exist"}});
  if (!fs::is_directory(dir, ec))
    throw CaseError({{case_dir, 0, "", "not a directory (expected a case directory holding case.toml)"}});
  if (!fs::exists(path, ec)) {
    // a study directory (cases/bizon-heat-baths) holds its cases one level down: name them
    std::set<std::string> inner;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
      if (fs::is_regular_file(it->path() / "case.toml", ec)) inner.insert(it->path().filename().string());
    std::string hint;
    if (!inner.empty()) {
      std::size_t shown = 0;
      for (const auto& name : inner) {
        if (shown == 8) {
          hint += ", ...";
          break;
        }
        hint += (shown++ ? ", " : "") + (dir / name).string();
      }
      hint = "; the case directories here are " + hint +
             (fs::exists(dir / "run.sh", ec) ? " (" + (dir / "run.sh").string() + " runs the study)" : "");
    }
    throw CaseError({{path.string(), 0, "", "missing: a case directory must hold case.toml" + hint}});
  }
  if (!fs::is_regular_file(path, ec))
    throw CaseError({{path.string(), 0, "", "not a regular file (expected the case's TOML text)"}});
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CaseError({{path.string(), 0, "", "cannot be read (permissions?)"}});
  std::ostringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  if (text.find_first_not_of(" \t\r\n") == std::string::npos)
    throw CaseError({{path.string(), 0, "", "the file is empty: expected at least a [run] section"}});
  CaseReader reader(std::move(text), path.string());
  if (reader.impl_->root.empty())
    throw CaseError({{path.string(), 0, "", "the file holds no settings (only comments?): expected at least a [run] section"}});
  return reader;
}

void CaseReader::apply_override(const std::string& assignment) {
  const auto eq = assignment.find('=');
  const auto dot = assignment.rfind('.', eq);
  if (eq == std::string::npos || dot == std::string::npos || dot == 0 || dot + 1 >= eq)
    throw CaseError({{"--set", 0, assignment, "expected section.key=value, e.g. --set background.knudsen=0.02"}});
  // Spaces around the parts are the shell quoting's, not the key's: 'dsmc.dt = 0.02'.
  const std::string section(trim(std::string_view(assignment).substr(0, dot)));
  const std::string key(trim(std::string_view(assignment).substr(dot + 1, eq - dot - 1)));
  const std::string value(trim(std::string_view(assignment).substr(eq + 1)));
  if (section.empty() || key.empty())
    throw CaseError({{"--set", 0, assignment, "expected section.key=value, e.g. --set background.knudsen=0.02"}});
  const std::string dotted = section + "." + key;
  for (const char ch : assignment) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if ((c < 0x20 && c != '\t') || c == 0x7f)
      throw CaseError({{"--set", 0, dotted, "the override holds control bytes"}});
  }
  // The value in TOML syntax; failing that, a bare word is taken as a string.
  std::string error;
  auto parse_value = [&](const std::string& toml_text) -> std::optional<toml::table> {
    PreparedText prepared = prepare_case_text(toml_text, "--set");
    if (!prepared.problems.empty()) {
      if (error.empty()) error = prepared.problems.front().message;
      return std::nullopt;
    }
    try {
      toml::table t = toml::parse(std::string_view(prepared.ascii), std::string_view("--set"));
      if (t.size() != 1 || !t.get("v")) return std::nullopt;
      return t;
    } catch (const toml::parse_error& e) {
      if (error.empty()) error = std::string(e.description());
      return std::nullopt;
    }
  };
  std::optional<toml::table> parsed = parse_value("v = " + value);
  if (!parsed) parsed = parse_value("v = \"" + value + "\"");
  if (!parsed)
    throw CaseError({{"--set", 0, dotted, "cannot parse the value '" + value + "': " + error}});
  toml::table* sec = impl_->root.get_as<toml::table>(section);
  if (!sec) {
    if (impl_->root.contains(section))
      throw CaseError({{"--set", 0, dotted, "'" + section + "' is not a section"}});
    impl_->root.insert(section, toml::table{});
    sec = impl_->root.get_as<toml::table>(section);
  }
  if (!impl_->overridden.count(dotted))
    if (const auto* old = sec->get_as<std::string>(key)) impl_->file_strings[dotted] = old->get();
  sec->insert_or_assign(key, *parsed->get("v"));
  impl_->overridden.insert(dotted);
}

bool CaseReader::has(std::string_view section, std::string_view key) const {
  return impl_->find(section, key) != nullptr;
}
bool CaseReader::has_section(std::string_view section) const {
  return impl_->section(section) != nullptr;
}

void CaseReader::accept(std::string_view section, std::string_view key) {
  impl_->used.insert(std::string(section) + "." + std::string(key));
  impl_->known[std::string(section)].insert(std::string(key));
}

void CaseReader::problem(std::string_view section, std::string_view key, std::string message) {
  const std::string dotted = std::string(section) + "." + std::string(key);
  const toml::node* n = impl_->find(section, key);
  const bool from_set = impl_->overridden.count(dotted) > 0;
  problems_.push_back({from_set ? "--set" : file_, from_set ? 0 : impl_->line_of(n), dotted, std::move(message)});
}

void CaseReader::problem(std::string_view section, std::string_view key, std::string message,
                         std::string_view other_section, std::string_view other_key) {
  if (!overridden(section, key) && overridden(other_section, other_key))
    problem(other_section, other_key, std::move(message));
  else
    problem(section, key, std::move(message));
}

void CaseReader::accept_section(std::string_view section) { impl_->known[std::string(section)]; }

void CaseReader::used_elsewhere(std::string_view section, std::string_view key, std::string message) {
  impl_->elsewhere[std::string(section) + "." + std::string(key)] = std::move(message);
}

void CaseReader::ignore(std::string_view section, std::string_view key, std::string note) {
  const std::string dotted = std::string(section) + "." + std::string(key);
  impl_->used.insert(dotted);
  const bool from_set = overridden(section, key);
  impl_->ignored[dotted] =
      CaseProblem{from_set ? "--set" : file_, from_set ? 0 : impl_->line_of(impl_->find(section, key)), dotted,
                  std::move(note)}
          .to_string();
}

void CaseReader::note(std::string_view section, std::string_view key, std::string note) {
  const std::string dotted = std::string(section) + "." + std::string(key);
  const bool from_set = overridden(section, key);
  // printed with the ignored keys' notes (finish(), once per process); "#" keeps it apart
  // from an ignore() of the same key
  impl_->ignored[dotted + "#note"] =
      CaseProblem{from_set ? "--set" : file_, from_set ? 0 : impl_->line_of(impl_->find(section, key)), dotted,
                  std::move(note)}
          .to_string();
}

bool CaseReader::overridden(std::string_view section, std::string_view key) const {
  return impl_->overridden.count(std::string(section) + "." + std::string(key)) > 0;
}

std::string CaseReader::file_string(std::string_view section, std::string_view key) const {
  const std::string dotted = std::string(section) + "." + std::string(key);
  if (auto it = impl_->file_strings.find(dotted); it != impl_->file_strings.end()) return it->second;
  if (overridden(section, key)) return "";
  const toml::node* n = impl_->find(section, key);
  return n && n->is_string() ? *n->value<std::string>() : "";
}

std::string CaseReader::origin(std::string_view section, std::string_view key) const {
  if (overridden(section, key)) return "--set";
  const toml::node* n = impl_->find(section, key);
  return n ? std::filesystem::path(file_).filename().string() + ":" + std::to_string(impl_->line_of(n)) : "default";
}

double CaseReader::real(std::string_view section, std::string_view key, double fallback, Bounds bounds,
                        std::string_view unit) {
  accept(section, key);
  const std::string dotted = std::string(section) + "." + std::string(key);
  const toml::node* n = impl_->find(section, key);
  if (!n) {
    resolved_[dotted] = format_real(fallback);
    return fallback;
  }
  if (!n->is_number()) {
    problem(section, key, "expected " + expected_number(bounds, "number", unit) + ", found " + describe_node(*n));
    return fallback;
  }
  const double x = n->is_integer() ? static_cast<double>(*n->value<std::int64_t>()) : *n->value<double>();
  if (!bounds.contains(x)) {
    problem(section, key, "expected " + expected_number(bounds, "value", unit) + ", found " + format_real(x));
    return fallback;
  }
  resolved_[dotted] = format_real(x);
  return x;
}

// For a required key missing where --set replaced a named setting of its section (a law
// switched on the command line needs its own keys there too): how to give it. Only an
// override that replaced one of the file's strings counts (`replaced`: "section.key" -> the
// file's value), not any --set of the section.
static std::string set_hint(const std::map<std::string, std::string>& replaced, std::string_view section,
                            std::string_view key) {
  const std::string prefix = std::string(section) + ".";
  for (const auto& [o, old] : replaced)
    if (o.rfind(prefix, 0) == 0)
      return "; " + o + " came from --set: give this key there too, --set " + prefix + std::string(key) + "=VALUE";
  return "";
}

double CaseReader::real_required(std::string_view section, std::string_view key, Bounds bounds,
                                 std::string_view unit) {
  if (!has(section, key)) {
    accept(section, key);
    problem(section, key, "missing: expected " + expected_number(bounds, "number", unit) +
                              set_hint(impl_->file_strings, section, key));
    return std::isfinite(bounds.lo) ? bounds.lo : 0.0;
  }
  return real(section, key, 0.0, bounds, unit);
}

std::int64_t CaseReader::integer(std::string_view section, std::string_view key, std::int64_t fallback,
                                 std::int64_t lo, std::int64_t hi) {
  accept(section, key);
  const std::string dotted = std::string(section) + "." + std::string(key);
  const toml::node* n = impl_->find(section, key);
  if (!n) {
    resolved_[dotted] = std::to_string(fallback);
    return fallback;
  }
  std::int64_t v = 0;
  if (n->is_integer()) {
    v = *n->value<std::int64_t>();
  } else if (n->is_floating_point() && std::isfinite(*n->value<double>()) &&
             std::floor(*n->value<double>()) == *n->value<double>() && std::abs(*n->value<double>()) < 9e15) {
    v = static_cast<std::int64_t>(*n->value<double>());  // 1e6 is a fine particle count
  } else {
    problem(section, key, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                              "], found " + describe_node(*n));
    return fallback;
  }
  if (v < lo || v > hi) {
    problem(section, key, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                              "], found " + std::to_string(v));
    return fallback;
  }
  resolved_[dotted] = std::to_string(v);
  return v;
}

std::int64_t CaseReader::integer_required(std::string_view section, std::string_view key, std::int64_t lo,
                                          std::int64_t hi) {
  if (!has(section, key)) {
    accept(section, key);
    problem(section, key, "missing: expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]" +
                              set_hint(impl_->file_strings, section, key));
    return lo;
  }
  return integer(section, key, lo, lo, hi);
}

bool CaseReader::boolean(std::string_view section, std::string_view key, bool fallback) {
  accept(section, key);
  const std::string dotted = std::string(section) + "." + std::string(key);
  const toml::node* n = impl_->find(section, key);
  if (!n) {
    resolved_[dotted] = fallback ? "true" : "false";
    return fallback;
  }
  if (!n->is_boolean()) {
    problem(section, key, "expected true or false, found " + describe_node(*n));
    return fallback;
  }
  resolved_[dotted] = *n->value<bool>() ? "true" : "false";
  return *n->value<bool>();
}

std::string CaseReader::text(std::string_view section, std::string_view key, std::string_view fallback) {
  accept(section, key);
  const std::string dotted = std::string(section) + "." + std::string(key);
  const toml::node* n = impl_->find(section, key);
  if (!n) {
    resolved_[dotted] = "\"" + std::string(fallback) + "\"";
    return std::string(fallback);
  }
  if (!n->is_string()) {
    problem(section, key, "expected a string, found " + describe_node(*n));
    return std::string(fallback);
  }
  resolved_[dotted] = "\"" + *n->value<std::string>() + "\"";
  return *n->value<std::string>();
}

std::string CaseReader::choice(std::string_view section, std::string_view key, std::string_view fallback,
                               const std::vector<std::string>& allowed) {
  const std::size_t before = problems_.size();
  std::string v = text(section, key, fallback);
  if (problems_.size() != before) return std::string(fallback);
  if (std::find(allowed.begin(), allowed.end(), v) == allowed.end()) {
    std::set<std::string> s(allowed.begin(), allowed.end());
    std::string hint = suggestion(v, s);
    problem(section, key, "unknown value \"" + v + "\"" + (hint.empty() ? "" : " (did you mean \"" + hint + "\"?)") +
                              "; valid values are: " + join(s));
    about_names_ = true;
    impl_->unsettled.insert(std::string(section));
    return std::string(fallback);
  }
  return v;
}

std::vector<double> CaseReader::reals(std::string_view section, std::string_view key, std::vector<double> fallback,
                                      std::size_t min_len, std::size_t max_len, Bounds bounds) {
  accept(section, key);
  const std::string dotted = std::string(section) + "." + std::string(key);
  const toml::node* n = impl_->find(section, key);
  auto show = [](const std::vector<double>& v) {
    std::string s = "[";
    for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + format_real(v[i]);
    return s + "]";
  };
  if (!n) {
    resolved_[dotted] = show(fallback);
    return fallback;
  }
  const std::string expect = min_len == max_len ? "an array of " + std::to_string(min_len) + " numbers"
                                                : "an array of " + std::to_string(min_len) + " to " +
                                                      std::to_string(max_len) + " numbers";
  const toml::array* a = n->as_array();
  if (!a || a->size() < min_len || a->size() > max_len) {
    problem(section, key, "expected " + expect + ", found " + describe_node(*n));
    return fallback;
  }
  std::vector<double> out;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::node* e = a->get(i);
    if (!e->is_number()) {
      problem(section, key, "element " + std::to_string(i) + ": expected a number, found " + describe_node(*e));
      return fallback;
    }
    const double x = e->is_integer() ? static_cast<double>(*e->value<std::int64_t>()) : *e->value<double>();
    if (!bounds.contains(x)) {
      problem(section, key, "element " + std::to_string(i) + ": expected " + expected_number(bounds, "value", "") +
                                ", found " + format_real(x));
      return fallback;
    }
    out.push_back(x);
  }
  resolved_[dotted] = show(out);
  return out;
}

Vec3 CaseReader::vec3(std::string_view section, std::string_view key, Vec3 fallback) {
  auto v = reals(section, key, {fallback.x, fallback.y, fallback.z}, 3, 3, Bounds::any());
  return {v[0], v[1], v[2]};
}

std::vector<std::string> CaseReader::texts(std::string_view section, std::string_view key,
                                           std::vector<std::string> fallback) {
  accept(section, key);
  const std::string dotted = std::string(section) + "." + std::string(key);
  const toml::node* n = impl_->find(section, key);
  auto show = [](const std::vector<std::string>& v) {
    std::string s = "[";
    for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", \"" : "\"") + v[i] + "\"";
    return s + "]";
  };
  if (!n) {
    resolved_[dotted] = show(fallback);
    return fallback;
  }
  std::vector<std::string> out;
  if (n->is_string()) {
    out.push_back(*n->value<std::string>());
  } else if (const toml::array* a = n->as_array()) {
    for (std::size_t i = 0; i < a->size(); ++i) {
      if (!a->get(i)->is_string()) {
        problem(section, key, "element " + std::to_string(i) + ": expected a string, found " + describe_node(*a->get(i)));
        return fallback;
      }
      out.push_back(*a->get(i)->value<std::string>());
    }
  } else {
    problem(section, key, "expected a string or an array of strings, found " + describe_node(*n));
    return fallback;
  }
  resolved_[dotted] = show(out);
  return out;
}

bool CaseReader::ok() const { return problems_.empty(); }

void CaseReader::record_file_checksum(std::string_view section, std::string_view key, std::uint64_t checksum) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(checksum));
  resolved_[std::string(section) + "." + std::string(key)] = "\"fnv1a-" + std::string(hex) + "\"";
}

namespace {
// The notes said so far: a sweep validates every variant in its own process, and the file's
// ignored keys are mostly the same for all of them, so each is said once there. An MPI sweep
// also runs its variants in that process, each into its own log: it forgets them before
// each run (CaseReader::forget_said_notes), so that every log holds its variant's notes.
std::mutex g_said_mutex;
std::set<std::string> g_said;
}  // namespace

void CaseReader::forget_said_notes() {
  const std::lock_guard<std::mutex> lock(g_said_mutex);
  g_said.clear();
}

void CaseReader::finish() {
  for (const auto& [_, note] : impl_->ignored) {
    const std::lock_guard<std::mutex> lock(g_said_mutex);
    if (g_said.insert(note).second) std::fprintf(stderr, "note: %s\n", note.c_str());
  }
  // an unknown solver: which sections and keys are right depends on it (the reader read the
  // case as the default solver's), so the only problems are those already found
  if (impl_->unsettled.count("run")) {
    if (!problems_.empty()) throw CaseError(problems_, about_names_);
    return;
  }
  std::set<std::string> known_sections;
  for (const auto& [s, _] : impl_->known) known_sections.insert(s);
  // The sections are the solver's: a section of the other solver is not a typo.
  const auto solver = resolved_.find("run.solver");
  const std::string valid_sections =
      solver == resolved_.end() ? "valid sections: " : "valid sections for solver = " + solver->second + ": ";
  for (const auto& [k, node] : impl_->root) {
    const std::string section(k.str());
    if (node.is_array_of_tables()) {
      problems_.push_back({file_, static_cast<int>(node.source().begin.line), "[[" + section + "]]",
                           "an array of tables: expected a single [" + section + "] section"});
      continue;
    }
    if (!node.is_table()) {
      problems_.push_back({file_, static_cast<int>(node.source().begin.line), section,
                           "a top-level key outside any [section]; keys belong in sections such as " +
                               join(known_sections)});
      continue;
    }
    auto it = impl_->known.find(section);
    if (it == impl_->known.end()) {
      // a section only --set created is the override's doing, not a line of the file
      bool from_set = !node.as_table()->empty();
      for (const auto& [kk, _] : *node.as_table())
        from_set = from_set && impl_->overridden.count(section + "." + std::string(kk.str())) > 0;
      const auto other = impl_->elsewhere.find(section + ".");
      std::string hint = suggestion(section, known_sections);
      std::string why = other != impl_->elsewhere.end() ? " (" + other->second + ")"
                        : hint.empty()                  ? ""
                                                        : " (did you mean [" + hint + "]?)";
      problems_.push_back({from_set ? "--set" : file_, from_set ? 0 : static_cast<int>(node.source().begin.line),
                           "[" + section + "]",
                           "unknown section" + why + "; " + valid_sections + join(known_sections)});
      continue;
    }
    for (const auto& [kk, sub] : *node.as_table()) {
      const std::string key(kk.str());
      const std::string dotted = section + "." + key;
      if (it->second.count(key) || impl_->ignored.count(dotted)) continue;
      const bool overridden = impl_->overridden.count(dotted) > 0;
      const std::string where = overridden ? "--set" : file_;
      const int line = overridden ? 0 : static_cast<int>(sub.source().begin.line);
      if (auto other = impl_->elsewhere.find(dotted); other != impl_->elsewhere.end()) {
        problems_.push_back({where, line, dotted, other->second});
        continue;
      }
      // the right key in the wrong table: name the table(s) of this case that hold it
      std::set<std::string> holders;
      for (const auto& [s2, keys] : impl_->known)
        if (s2 != section && keys.count(key)) holders.insert("[" + s2 + "]");
      std::string hint = suggestion(key, it->second);
      // a key of a law, profile or model that an unknown value of the section's choice
      // (reported above) did not select: not judged; a misspelt valid key still is
      if (holders.empty() && hint.empty() && impl_->unsettled.count(section)) continue;
      std::string why = !holders.empty() ? " (" + key + " is a key of " + join(holders) + ")"
                        : hint.empty()    ? ""
                                          : " (did you mean '" + hint + "'?)";
      problems_.push_back({where, line, dotted, "unknown key" + why + "; valid keys in [" + section + "]: " +
                                                    (it->second.empty() ? "none" : join(it->second))});
    }
  }
  if (!problems_.empty()) throw CaseError(problems_, about_names_);
}

}  // namespace grainbath
