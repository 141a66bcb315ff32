// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/json_reader.hpp"

#include "metron/stdlib/file_access.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <fmt/format.h>

namespace metron::strict_json {

using nlohmann::json;

void fail(const std::string& pointer, std::string message) {
  throw ReadError{pointer.empty() ? "/" : pointer, std::move(message)};
}

std::string pointer_token(std::string_view key) {
  std::string out;
  for (char c : key) {
    if (c == '~')
      out += "~0";
    else if (c == '/')
      out += "~1";
    else
      out += c;
  }
  return out;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

double number(const json& j, const std::string& ptr) {
  if (!j.is_number()) fail(ptr, "expected a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail(ptr, "expected a finite number");
  return v;
}

double positive(const json& j, const std::string& ptr) {
  const double v = number(j, ptr);
  if (!(v > 0)) fail(ptr, "expected a positive number");
  return v;
}

double non_negative(const json& j, const std::string& ptr) {
  const double v = number(j, ptr);
  if (v < 0) fail(ptr, "expected a number >= 0");
  return v;
}

double open_interval(const json& j, const std::string& ptr, double lo, double hi) {
  const double v = number(j, ptr);
  if (!(v > lo && v < hi)) fail(ptr, fmt::format("expected a number in ({}, {})", lo, hi));
  return v;
}

Vec3 vec3(const json& j, const std::string& ptr) {
  if (!j.is_array() || j.size() != 3) fail(ptr, "expected an array of 3 numbers");
  return {number(j[0], ptr + "/0"), number(j[1], ptr + "/1"), number(j[2], ptr + "/2")};
}

Vec3 unit(const json& j, const std::string& ptr) {
  const Vec3 v = vec3(j, ptr);
  if (!(v.norm() > 1e-12)) fail(ptr, "expected a non-zero direction");
  return v.normalized();
}

std::vector<double> numbers(const json& j, const std::string& ptr, long size) {
  if (!j.is_array()) fail(ptr, "expected an array of numbers");
  if (size >= 0 && static_cast<long>(j.size()) != size)
    fail(ptr, fmt::format("expected {} numbers, got {}", size, j.size()));
  std::vector<double> out;
  out.reserve(j.size());
  for (std::size_t i = 0; i < j.size(); ++i) out.push_back(number(j[i], fmt::format("{}/{}", ptr, i)));
  return out;
}

std::string string(const json& j, const std::string& ptr) {
  if (!j.is_string()) fail(ptr, "expected a string");
  return j.get<std::string>();
}

bool boolean(const json& j, const std::string& ptr) {
  if (!j.is_boolean()) fail(ptr, "expected true or false");
  return j.get<bool>();
}

std::string one_of(const json& j, const std::string& ptr, std::initializer_list<std::string_view> choices) {
  std::string list;
  for (std::string_view c : choices) list += fmt::format("{}\"{}\"", list.empty() ? "" : ", ", c);
  if (!j.is_string()) fail(ptr, fmt::format("expected one of {}", list));
  const std::string v = j.get<std::string>();
  for (std::string_view c : choices)
    if (v == c) return v;
  fail(ptr, fmt::format("expected one of {} (got \"{}\")", list, v));
}

std::uint64_t unsigned_integer(const json& j, const std::string& ptr) {
  if (!j.is_number_unsigned()) fail(ptr, "expected a non-negative integer");
  return j.get<std::uint64_t>();
}

std::int64_t integer(const json& j, const std::string& ptr, std::int64_t min, std::int64_t max) {
  if (!j.is_number_integer()) fail(ptr, "expected an integer");
  const auto v = j.get<std::int64_t>();
  if (v < min || v > max)
    fail(ptr, max >= 1000000 ? fmt::format("expected an integer >= {}", min)
                             : fmt::format("expected an integer in [{}, {}]", min, max));
  return v;
}

Object::Object(const json& j, std::string pointer) : m_json(j), m_pointer(std::move(pointer)) {
  if (!j.is_object()) fail(m_pointer, "expected an object");
}

std::string Object::at(std::string_view key) const { return m_pointer + "/" + pointer_token(key); }

const json* Object::find(const std::string& key) {
  m_known.insert(key);
  const auto it = m_json.find(key);
  return it == m_json.end() ? nullptr : &*it;
}

const json& Object::required(const std::string& key) {
  const json* j = find(key);
  if (!j) fail(m_pointer, fmt::format("missing key '{}'", key));
  return *j;
}

void Object::number(const std::string& key, double& out) {
  read(key, [&](const json& j, const std::string& p) { out = strict_json::number(j, p); });
}
void Object::positive(const std::string& key, double& out) {
  read(key, [&](const json& j, const std::string& p) { out = strict_json::positive(j, p); });
}
void Object::non_negative(const std::string& key, double& out) {
  read(key, [&](const json& j, const std::string& p) { out = strict_json::non_negative(j, p); });
}
void Object::vec3(const std::string& key, Vec3& out) {
  read(key, [&](const json& j, const std::string& p) { out = strict_json::vec3(j, p); });
}
void Object::unit(const std::string& key, Vec3& out) {
  read(key, [&](const json& j, const std::string& p) { out = strict_json::unit(j, p); });
}

void Object::finish() const {
  for (const auto& item : m_json.items()) {
    if (m_known.count(item.key())) continue;
    std::string message = fmt::format("unknown key '{}'", item.key());
    std::string best;
    std::size_t best_distance = 3;
    for (const std::string& k : m_known) {
      const std::size_t d = edit_distance(item.key(), k);
      if (d < best_distance) best_distance = d, best = k;
    }
    if (!best.empty()) {
      message += fmt::format(" (did you mean '{}'?)", best);
    } else if (!m_known.empty()) {
      std::string known;
      for (const std::string& k : m_known) known += (known.empty() ? "" : ", ") + k;
      message += fmt::format(" (expected one of: {})", known);
    }
    fail(at(item.key()), message);
  }
}

namespace {
/// The deepest nesting of `text`, counted outside strings and comments; stops counting once past
/// `limit` (returns the offset where it was passed).
std::optional<std::size_t> too_deep_at(std::string_view text, std::size_t limit) {
  std::size_t depth = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {
      for (++i; i < text.size() && text[i] != '"'; ++i)
        if (text[i] == '\\') ++i;
    } else if (c == '/' && i + 1 < text.size() && text[i + 1] == '/') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '/' && i + 1 < text.size() && text[i + 1] == '*') {
      const auto close = text.find("*/", i + 2);
      i = close == std::string_view::npos ? text.size() : close + 1;
    } else if (c == '[' || c == '{') {
      if (++depth > limit) return i;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return std::nullopt;
}
}  // namespace

tl::expected<nlohmann::json, std::string> parse_document(std::string_view text, std::size_t max_depth) {
  if (const auto at = too_deep_at(text, max_depth)) {
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; i < *at; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    return tl::unexpected(fmt::format("line {}, column {}: nested more than {} levels deep", line, column, max_depth));
  }
  try {
    return nlohmann::json::parse(text, nullptr, true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::exception& e) {
    // what() is "[json.exception.parse_error.101] parse error at line L, column C: ..." (or
    // out_of_range.406 "number overflow parsing '1e400'").
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    return tl::unexpected(what);
  }
}

tl::expected<nlohmann::json, std::string> read_document(const std::string& path) {
  auto text = read_input_file(path);
  if (!text) return tl::unexpected(text.error());
  auto j = parse_document(*text);
  if (!j) return tl::unexpected(fmt::format("{}: invalid JSON: {}", path, j.error()));
  return j;
}

}  // namespace metron::strict_json
