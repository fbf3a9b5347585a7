#include "core/summary.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <stdexcept>

namespace grainbath {

std::string json_escape(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (c < 0x20) {
          char b[8];
          std::snprintf(b, sizeof b, "\\u%04x", c);
          out += b;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

std::string json_number(double x) {
  if (!std::isfinite(x)) return "null";
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

void Summary::set(const std::string& key, Value v) {
  for (auto& [k, val] : entries_)
    if (k == key) {
      val = std::move(v);
      return;
    }
  entries_.emplace_back(key, std::move(v));
}

void Summary::set_all(const std::string& prefix, const std::vector<std::pair<std::string, double>>& values) {
  for (const auto& [k, v] : values) set(prefix.empty() ? k : prefix + "." + k, v);
}

const Summary::Value* Summary::get(const std::string& key) const {
  for (const auto& [k, v] : entries_)
    if (k == key) return &v;
  return nullptr;
}

double Summary::number(const std::string& key) const {
  const Value* v = get(key);
  if (!v) return std::nan("");
  if (auto d = std::get_if<double>(v)) return *d;
  if (auto i = std::get_if<std::int64_t>(v)) return static_cast<double>(*i);
  return std::nan("");
}

namespace {
struct Node {
  std::vector<std::pair<std::string, std::unique_ptr<Node>>> children;  // insertion order
  const Summary::Value* leaf = nullptr;
  Node* child(const std::string& name) {
    for (auto& [n, c] : children)
      if (n == name) return c.get();
    children.emplace_back(name, std::make_unique<Node>());
    return children.back().second.get();
  }
};

void emit(const Node& node, std::string& out, int indent) {
  if (node.leaf) {
    std::visit(
        [&](const auto& v) {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, double>) out += json_number(v);
          else if constexpr (std::is_same_v<T, std::int64_t>) out += std::to_string(v);
          else if constexpr (std::is_same_v<T, bool>) out += v ? "true" : "false";
          else out += json_escape(v);
        },
        *node.leaf);
    return;
  }
  out += "{\n";
  for (std::size_t i = 0; i < node.children.size(); ++i) {
    out += std::string(indent + 2, ' ') + json_escape(node.children[i].first) + ": ";
    emit(*node.children[i].second, out, indent + 2);
    out += i + 1 < node.children.size() ? ",\n" : "\n";
  }
  out += std::string(indent, ' ') + "}";
}
}  // namespace

std::string Summary::to_json() const {
  Node root;
  for (const auto& [key, value] : entries_) {
    Node* n = &root;
    std::size_t start = 0;
    for (;;) {
      const std::size_t dot = key.find('.', start);
      n = n->child(key.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
      if (dot == std::string::npos) break;
      // a shorter key set earlier ("a" before "a.b"): emit would write its value and drop this
      // key without a word (until 2026-12-06 only the other order was caught)
      if (n->leaf) throw std::logic_error("summary key '" + key + "' collides with another key");
      start = dot + 1;
    }
    if (!n->children.empty() || n->leaf)
      throw std::logic_error("summary key '" + key + "' collides with another key");
    n->leaf = &value;
  }
  std::string out;
  emit(root, out, 0);
  return out + "\n";
}

}  // namespace grainbath
