// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/error_space/strict_json.hpp"

#include <cmath>

#include <fmt/format.h>

namespace metron::strict_json {

void fail(const std::string& pointer, std::string message) {
  throw Error{pointer.empty() ? "/" : pointer, std::move(message)};
}

double number(const nlohmann::json& j, const std::string& p) {
  if (!j.is_number()) fail(p, "expected a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail(p, "expected a finite number");
  return v;
}

double positive(const nlohmann::json& j, const std::string& p) {
  const double v = number(j, p);
  if (!(v > 0)) fail(p, "expected a positive number");
  return v;
}

std::string string(const nlohmann::json& j, const std::string& p) {
  if (!j.is_string()) fail(p, "expected a string");
  return j.get<std::string>();
}

int integer(const nlohmann::json& j, const std::string& p, int min, int max) {
  if (!j.is_number_integer()) fail(p, "expected an integer");
  const auto v = j.get<long long>();
  if (v < min || v > max) fail(p, fmt::format("expected an integer in [{}, {}]", min, max));
  return static_cast<int>(v);
}

std::vector<double> numbers(const nlohmann::json& j, const std::string& p, long size) {
  if (!j.is_array()) fail(p, "expected an array of numbers");
  if (size >= 0 && static_cast<long>(j.size()) != size) fail(p, fmt::format("expected {} numbers, got {}", size, j.size()));
  std::vector<double> out;
  out.reserve(j.size());
  for (std::size_t i = 0; i < j.size(); ++i) out.push_back(number(j[i], fmt::format("{}/{}", p, i)));
  return out;
}

Object::Object(const nlohmann::json& j, std::string pointer) : m_json(j), m_pointer(std::move(pointer)) {
  if (!j.is_object()) fail(m_pointer, "expected an object");
}

std::string Object::at(std::string_view key) const {
  std::string out = m_pointer + "/";
  for (char c : key) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

const nlohmann::json* Object::find(const std::string& key) {
  m_known.insert(key);
  const auto it = m_json.find(key);
  return it == m_json.end() ? nullptr : &*it;
}

const nlohmann::json& Object::required(const std::string& key) {
  const nlohmann::json* j = find(key);
  if (!j) fail(m_pointer, fmt::format("missing key '{}'", key));
  return *j;
}

void Object::finish() const {
  for (const auto& item : m_json.items())
    if (!m_known.count(item.key())) fail(at(item.key()), fmt::format("unknown key '{}'", item.key()));
}

}  // namespace metron::strict_json
