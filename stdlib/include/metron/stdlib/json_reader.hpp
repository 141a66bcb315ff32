// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <initializer_list>
#include <set>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>
#include <tl/expected.hpp>

#include "metron/stdlib/geometry/vec.hpp"

/// The one strict JSON reader of metron (world files, the scanning record, characterisation
/// files): typed getters that name the JSON pointer (RFC 6901) of every value they reject, range
/// checks, and objects that reject keys their schema does not know, with a did-you-mean
/// suggestion (a typo must not be ignored silently).
namespace metron::strict_json {

/// A value that does not match its schema: where it is and what was expected.
struct ReadError {
  std::string pointer;  ///< e.g. "/machine/dt_s" ("/" for the document)
  std::string message;  ///< e.g. "expected a positive number"
};

/// Thrown by the getters; read() turns it into a value (the reader's only exception).
[[noreturn]] void fail(const std::string& pointer, std::string message);

/// Runs `parse` (which throws ReadError through fail()) and returns its value or the error.
template <class Parse>
auto read(Parse&& parse) -> tl::expected<decltype(parse()), ReadError> {
  try {
    if constexpr (std::is_void_v<decltype(parse())>) {
      parse();
      return {};
    } else {
      return parse();
    }
  } catch (const ReadError& e) {
    return tl::unexpected(e);
  }
}

/// The deepest nesting of arrays and objects a document may have: metron's schemas need fewer
/// than 10 levels; nlohmann's copy, merge_patch and destructor recurse once per level, so an
/// attacker's 70,000 levels would overflow the stack.
inline constexpr std::size_t max_document_depth = 256;

/// Parses a JSON document (comments allowed) without ever throwing: nesting deeper than
/// `max_depth`, numbers out of the double range (1e400) and syntax errors all come back as a
/// message ("parse error at line L, column C: ...").
tl::expected<nlohmann::json, std::string> parse_document(std::string_view text,
                                                         std::size_t max_depth = max_document_depth);
/// Reads a file (a regular file within metron's input size cap, so /dev/zero is refused) and
/// parses it with parse_document; the message names the file.
tl::expected<nlohmann::json, std::string> read_document(const std::string& path);

/// RFC 6901 escaping of one reference token ('~' -> "~0", '/' -> "~1").
std::string pointer_token(std::string_view key);
/// Levenshtein distance (for the did-you-mean suggestions).
std::size_t edit_distance(std::string_view a, std::string_view b);

double number(const nlohmann::json& j, const std::string& ptr);        ///< a finite number
double positive(const nlohmann::json& j, const std::string& ptr);      ///< a finite number > 0
double non_negative(const nlohmann::json& j, const std::string& ptr);  ///< a finite number >= 0
/// A finite number in the open interval (lo, hi).
double open_interval(const nlohmann::json& j, const std::string& ptr, double lo, double hi);
Vec3 vec3(const nlohmann::json& j, const std::string& ptr);           ///< [x, y, z]
Vec3 unit(const nlohmann::json& j, const std::string& ptr);           ///< a non-zero [x, y, z], normalised
std::string string(const nlohmann::json& j, const std::string& ptr);  ///< a string
/// An array of finite numbers (its size checked when `size` >= 0).
std::vector<double> numbers(const nlohmann::json& j, const std::string& ptr, long size = -1);
bool boolean(const nlohmann::json& j, const std::string& ptr);  ///< true or false
/// One of `choices` (a string); the message lists them.
std::string one_of(const nlohmann::json& j, const std::string& ptr, std::initializer_list<std::string_view> choices);
std::uint64_t unsigned_integer(const nlohmann::json& j, const std::string& ptr);  ///< an integer >= 0
/// An integer in [min, max]; the message names only `min` when max is 1e6 or more (a sanity bound).
std::int64_t integer(const nlohmann::json& j, const std::string& ptr, std::int64_t min, std::int64_t max = 1000000);

/// An object being read: remembers which keys the schema knows, so that finish() can report
/// every other key as unknown, with the nearest known key as a suggestion.
class Object {
 public:
  /// Fails with "expected an object" when `j` is not one.
  Object(const nlohmann::json& j, std::string pointer);
  /// The pointer of `key` in this object.
  [[nodiscard]] std::string at(std::string_view key) const;
  [[nodiscard]] const std::string& pointer() const { return m_pointer; }
  /// The value of `key` (null when absent); the key becomes known either way.
  const nlohmann::json* find(const std::string& key);
  /// The value of `key`; fails with "missing key" when absent.
  const nlohmann::json& required(const std::string& key);
  /// Calls read_value(value, pointer) when `key` is present.
  template <class Read>
  void read(const std::string& key, Read read_value) {
    if (const nlohmann::json* j = find(key)) read_value(*j, at(key));
  }
  void number(const std::string& key, double& out);        ///< optional key, number()
  void positive(const std::string& key, double& out);      ///< optional key, positive()
  void non_negative(const std::string& key, double& out);  ///< optional key, non_negative()
  void vec3(const std::string& key, Vec3& out);            ///< optional key, vec3()
  void unit(const std::string& key, Vec3& out);            ///< optional key, unit()
  /// The required key's value read by `get` (e.g. strict_json::positive).
  template <class Get>
  auto get(const std::string& key, Get get_value) {
    return get_value(required(key), at(key));
  }
  /// Fails on the first key that no find(), required() or read() asked for.
  void finish() const;

 private:
  const nlohmann::json& m_json;
  std::string m_pointer;
  std::set<std::string> m_known;
};

}  // namespace metron::strict_json
