// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

/// Strict reading of JSON objects for the error-space file and the machine error model: every
/// unknown key and every bad value is an error naming its JSON pointer (RFC 6901).
namespace metron::strict_json {

/// A rejected value: where (JSON pointer) and what was expected.
struct Error {
  std::string pointer;  ///< RFC 6901 pointer, "/" for the root
  std::string message;  ///< lowercase, what was expected
};

/// Throws Error (the readers below are used inside one try block per document).
[[noreturn]] void fail(const std::string& pointer, std::string message);

/// A finite number.
double number(const nlohmann::json& j, const std::string& pointer);
/// A finite number > 0.
double positive(const nlohmann::json& j, const std::string& pointer);
/// A string.
std::string string(const nlohmann::json& j, const std::string& pointer);
/// An integer in [min, max].
int integer(const nlohmann::json& j, const std::string& pointer, int min, int max);
/// An array of finite numbers (size checked when `size` >= 0).
std::vector<double> numbers(const nlohmann::json& j, const std::string& pointer, long size = -1);

/// An object being read: remembers the keys asked for, so finish() reports any other as unknown.
class Object {
 public:
  /// Fails unless `j` is an object.
  Object(const nlohmann::json& j, std::string pointer);
  /// Pointer of a member.
  [[nodiscard]] std::string at(std::string_view key) const;
  /// The member or nullptr (the key becomes known).
  const nlohmann::json* find(const std::string& key);
  /// The member; fails when missing.
  const nlohmann::json& required(const std::string& key);
  /// Fails on the first key never asked for.
  void finish() const;

 private:
  const nlohmann::json& m_json;
  std::string m_pointer;
  std::set<std::string> m_known;
};

}  // namespace metron::strict_json
