// Strict case-file reader on toml++ (header-only, compiled here with NDEBUG: Debian's
// toml++ 3.3.0 aborts on some malformed inputs when its asserts are enabled).
#ifndef NDEBUG
#define NDEBUG
#endif
#include "core/case_file.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#define TOML_EXCEPTIONS 1
#include <toml++/toml.h>

namespace grainbath {

namespace {

std::string format_real(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  std::string s = buf;
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

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

std::string node_text(const toml::node& n) {
  if (auto v = n.value_exact<double>()) return format_real(*v);
  if (auto v = n.value_exact<std::int64_t>()) return std::to_string(*v);
  if (auto v = n.value_exact<bool>()) return *v ? "true" : "false";
  if (auto v = n.value_exact<std::string>()) return "\"" + *v + "\"";
  if (auto a = n.as_array()) {
    std::string s = "[";
    for (std::size_t i = 0; i < a->size(); ++i) s += (i ? ", " : "") + node_text(*a->get(i));
    return s + "]";
  }
  return "<table>";
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

std::string suggestion(std::string_view word, const std::set<std::string>& known) {
  std::string best;
  std::size_t best_d = 3;  // suggest only close matches
  for (const auto& k : known) {
    const std::size_t d = edit_distance(word, k);
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

std::string CaseProblem::to_string() const {
  std::string s = file;
  if (line > 0) s += ":" + std::to_string(line);
  s += ": ";
  if (!key.empty()) s += key + ": ";
  return s + message;
}

static std::string join_problems(const std::vector<CaseProblem>& problems) {
  std::string s;
  for (const auto& p : problems) s += (s.empty() ? "" : "\n") + p.to_string();
  return s;
}

CaseError::CaseError(std::vector<CaseProblem> problems)
    : std::runtime_error(join_problems(problems)), problems_(std::move(problems)) {}

bool Bounds::contains(double x) const {
  if (!std::isfinite(x)) return false;
  if (lo_open ? !(x > lo) : !(x >= lo)) return false;
  if (hi_open ? !(x < hi) : !(x <= hi)) return false;
  return true;
}

std::string Bounds::describe() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi)
    return std::string(lo_open ? "(" : "[") + format_real(lo) + ", " + format_real(hi) + (hi_open ? ")" : "]");
  if (has_lo) return std::string(lo_open ? "> " : ">= ") + format_real(lo);
  if (has_hi) return std::string(hi_open ? "< " : "<= ") + format_real(hi);
  return "a finite number";
}

std::vector<CaseProblem> scan_case_bytes(std::string_view text, const std::string& file) {
  std::vector<CaseProblem> out;
  int line = 1;
  enum { plain, comment, basic, literal, ml_basic, ml_literal } state = plain;
  auto starts = [&](std::size_t i, std::string_view s) { return text.substr(i, s.size()) == s; };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '\n') {
      ++line;
      if (state == comment || state == basic || state == literal) state = plain;
      continue;
    }
    if ((c < 0x20 && c != '\t' && c != '\r') || c == 0x7f) {
      out.push_back({file, line, "", "control byte 0x" + fmt_hex(c) + " in the file: a case file is text (is it binary?)"});
      if (out.size() >= 5) return out;
      continue;
    }
    switch (state) {
      case plain:
        if (c == '#') state = comment;
        else if (starts(i, "\"\"\"")) { state = ml_basic; i += 2; }
        else if (starts(i, "'''")) { state = ml_literal; i += 2; }
        else if (c == '"') state = basic;
        else if (c == '\'') state = literal;
        else if (c >= 0x80) {
          out.push_back({file, line, "", "non-ASCII byte outside a string or comment (only strings and comments may hold UTF-8)"});
          if (out.size() >= 5) return out;
          // skip the rest of this UTF-8 sequence
          while (i + 1 < text.size() && (static_cast<unsigned char>(text[i + 1]) & 0xC0) == 0x80) ++i;
        }
        break;
      case basic:
        if (c == '\\') ++i;
        else if (c == '"') state = plain;
        break;
      case literal:
        if (c == '\'') state = plain;
        break;
      case ml_basic:
        if (c == '\\') ++i;
        else if (starts(i, "\"\"\"")) { state = plain; i += 2; }
        break;
      case ml_literal:
        if (starts(i, "'''")) { state = plain; i += 2; }
        break;
      case comment:
        break;
    }
  }
  return out;
}

struct CaseReader::Impl {
  toml::table root;
  std::set<std::string> used;                   // "section.key" asked for by a getter
  std::map<std::string, std::set<std::string>> known;  // section -> keys asked for
  std::set<std::string> overridden;             // "section.key" set by --set
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
  auto bad = scan_case_bytes(text_, file_);
  if (!bad.empty()) throw CaseError(std::move(bad));
  try {
    impl_->root = toml::parse(std::string_view(text_), std::string_view(file_));
  } catch (const toml::parse_error& e) {
    throw CaseError({{file_, static_cast<int>(e.source().begin.line), "",
                      "TOML syntax error: " + std::string(e.description())}});
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
  if (!fs::exists(path, ec))
    throw CaseError({{path.string(), 0, "", "missing: a case directory must hold case.toml"}});
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CaseError({{path.string(), 0, "", "cannot be read (permissions?)"}});
  std::ostringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  if (text.find_first_not_of(" \t\r\n") == std::string::npos)
    throw CaseError({{path.string(), 0, "", "the file is empty: expected at least a [run] section"}});
  return CaseReader(std::move(text), path.string());
}

void CaseReader::apply_override(const std::string& assignment) {
  const auto eq = assignment.find('=');
  const auto dot = assignment.rfind('.', eq);
  if (eq == std::string::npos || dot == std::string::npos || dot == 0 || dot + 1 >= eq)
    throw CaseError({{"--set", 0, assignment, "expected section.key=value, e.g. --set background.knudsen=0.02"}});
  const std::string section = assignment.substr(0, dot);
  const std::string key = assignment.substr(dot + 1, eq - dot - 1);
  const std::string value = assignment.substr(eq + 1);
  if (!scan_case_bytes(value, "--set").empty())
    throw CaseError({{"--set", 0, section + "." + key, "the value holds control or non-ASCII bytes"}});
  toml::table parsed;
  try {
    parsed = toml::parse(std::string_view(std::string("v = ") + value), std::string_view("--set"));
  } catch (const toml::parse_error&) {
    try {
      parsed = toml::parse(std::string_view(std::string("v = \"") + value + "\""), std::string_view("--set"));  // a bare word: a string
    } catch (const toml::parse_error& e) {
      throw CaseError({{"--set", 0, section + "." + key, "cannot parse the value '" + value + "': " +
                                                             std::string(e.description())}});
    }
  }
  toml::table* sec = impl_->root.get_as<toml::table>(section);
  if (!sec) {
    if (impl_->root.contains(section))
      throw CaseError({{"--set", 0, section + "." + key, "'" + section + "' is not a section"}});
    impl_->root.insert(section, toml::table{});
    sec = impl_->root.get_as<toml::table>(section);
  }
  sec->insert_or_assign(key, *parsed.get("v"));
  impl_->overridden.insert(section + "." + key);
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
    problem(section, key, "expected a number" + (unit.empty() ? "" : " (" + std::string(unit) + ")") +
                              " in " + bounds.describe() + ", found " + describe_node(*n));
    return fallback;
  }
  const double x = n->is_integer() ? static_cast<double>(*n->value<std::int64_t>()) : *n->value<double>();
  if (!bounds.contains(x)) {
    problem(section, key, "expected a value in " + bounds.describe() +
                              (unit.empty() ? "" : " (" + std::string(unit) + ")") + ", found " + format_real(x));
    return fallback;
  }
  resolved_[dotted] = format_real(x);
  return x;
}

double CaseReader::real_required(std::string_view section, std::string_view key, Bounds bounds,
                                 std::string_view unit) {
  if (!has(section, key)) {
    accept(section, key);
    problem(section, key, "missing: expected a number in " + bounds.describe() +
                              (unit.empty() ? "" : " (" + std::string(unit) + ")"));
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
    problem(section, key, "missing: expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
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
      problem(section, key, "element " + std::to_string(i) + ": expected a value in " + bounds.describe() +
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

void CaseReader::finish() {
  std::set<std::string> known_sections;
  for (const auto& [s, _] : impl_->known) known_sections.insert(s);
  for (const auto& [k, node] : impl_->root) {
    const std::string section(k.str());
    if (!node.is_table()) {
      problems_.push_back({file_, static_cast<int>(node.source().begin.line), section,
                           "a top-level key outside any [section]; keys belong in sections such as " +
                               join(known_sections)});
      continue;
    }
    auto it = impl_->known.find(section);
    if (it == impl_->known.end()) {
      std::string hint = suggestion(section, known_sections);
      problems_.push_back({file_, static_cast<int>(node.source().begin.line), "[" + section + "]",
                           "unknown section" + (hint.empty() ? "" : " (did you mean [" + hint + "]?)") +
                               "; sections this case uses: " + join(known_sections)});
      continue;
    }
    for (const auto& [kk, sub] : *node.as_table()) {
      const std::string key(kk.str());
      if (it->second.count(key)) continue;
      const std::string dotted = section + "." + key;
      std::string hint = suggestion(key, it->second);
      const bool overridden = impl_->overridden.count(dotted) > 0;
      problems_.push_back({overridden ? "--set" : file_, overridden ? 0 : static_cast<int>(sub.source().begin.line),
                           dotted,
                           "unknown key" + (hint.empty() ? "" : " (did you mean '" + hint + "'?)") +
                               "; valid keys in [" + section + "]: " + join(it->second)});
    }
  }
  if (!problems_.empty()) throw CaseError(problems_);
}

}  // namespace grainbath
