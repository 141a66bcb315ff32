// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <optional>
#include <string>
#include <string_view>

namespace metron {

/// The static/dynamic type of a DMIS value (DECL types map onto these).
enum class ValueType { Real, Integer, Bool, String, Label, Vector };
const char* to_string(ValueType type);
/// The type a DECL word names (INTGR, LONG, REAL, DOUBLE, BOOL, CHAR, VECTOR), if any.
std::optional<ValueType> declared_type(std::string_view word);

/// A DMIS run-time value: a number (REAL/DOUBLE or INTGR/LONG), a BOOL, a CHAR string, a VECTOR
/// (three components, DMIS 5.3 DECL/VECTOR), or a label passed to a macro (`text` = "F(P1)"
/// style prefix and name).
struct Value {
  ValueType type = ValueType::Real;
  double number = 0;
  bool boolean = false;
  std::string text;                    ///< String contents, or a label's name
  std::string prefix;                  ///< Label prefix (F, FA, ...)
  std::array<double, 3> components{};  ///< A VECTOR's x, y, z

  static Value real(double v) { return Value{ValueType::Real, v, false, {}, {}, {}}; }
  static Value integer(double v) { return Value{ValueType::Integer, v, false, {}, {}, {}}; }
  static Value boolean_value(bool b) { return Value{ValueType::Bool, 0, b, {}, {}, {}}; }
  static Value string(std::string s) { return Value{ValueType::String, 0, false, std::move(s), {}, {}}; }
  static Value label(std::string prefix, std::string name) {
    return Value{ValueType::Label, 0, false, std::move(name), std::move(prefix), {}};
  }
  static Value vector(double x, double y, double z) { return Value{ValueType::Vector, 0, false, {}, {}, {x, y, z}}; }
  [[nodiscard]] bool is_number() const { return type == ValueType::Real || type == ValueType::Integer; }
  /// For display: numbers with up to 10 significant digits, strings as they are, a vector as x,y,z.
  [[nodiscard]] std::string to_display() const;
};

}  // namespace metron
