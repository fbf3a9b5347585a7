#pragma once
// summary.json: a flat list of dotted keys ("temperature.mean") written as nested JSON.
// Numbers are printed with 17 significant digits so the file is bitwise reproducible and
// round-trips; NaN/Inf become null.
#include <cstdint>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace grainbath {

class Summary {
 public:
  using Value = std::variant<double, std::int64_t, std::string, bool>;
  void set(const std::string& dotted_key, Value v);  // replaces an existing key
  void set_all(const std::string& prefix, const std::vector<std::pair<std::string, double>>& values);
  const Value* get(const std::string& dotted_key) const;
  double number(const std::string& dotted_key) const;  // NaN if absent
  std::string to_json() const;
  const std::vector<std::pair<std::string, Value>>& entries() const { return entries_; }

 private:
  std::vector<std::pair<std::string, Value>> entries_;
};

std::string json_escape(const std::string& s);
std::string json_number(double x);

}  // namespace grainbath
