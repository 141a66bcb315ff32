// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/builtins.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <numbers>

#include <fmt/format.h>

namespace metron {
namespace {

std::string upper(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}
std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// VCROSS, VDOT, VMAG, VUNIT, VECX, VECY, VECZ on VECTOR arguments.
tl::expected<Value, std::string> call_vector_builtin(const std::string& name, const std::vector<Value>& args) {
  for (const auto& a : args)
    if (a.type != ValueType::Vector)
      return tl::unexpected(fmt::format("{} takes VECTOR arguments, got a {}", name, to_string(a.type)));
  const auto& u = args[0].components;
  const double magnitude = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  if (name == "VMAG") return Value::real(magnitude);
  if (name == "VECX" || name == "VECY" || name == "VECZ")
    return Value::real(u[static_cast<std::size_t>(name[3] - 'X')]);
  if (name == "VUNIT") {
    if (magnitude == 0) return tl::unexpected(std::string("VUNIT of a zero vector"));
    return Value::vector(u[0] / magnitude, u[1] / magnitude, u[2] / magnitude);
  }
  if (name != "VDOT" && name != "VCROSS")
    return tl::unexpected(fmt::format("{} is answered by the interpreter (it reads the alignment)", name));
  const auto& v = args[1].components;
  if (name == "VDOT") return Value::real(u[0] * v[0] + u[1] * v[1] + u[2] * v[2]);
  if (name == "VCROSS")
    return Value::vector(u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]);
  return tl::unexpected("unknown vector function " + name);
}

}  // namespace

const char* to_string(ValueType type) {
  switch (type) {
    case ValueType::Real: return "REAL";
    case ValueType::Integer: return "INTGR";
    case ValueType::Bool: return "BOOL";
    case ValueType::String: return "CHAR";
    case ValueType::Label: return "label";
    case ValueType::Vector: return "VECTOR";
  }
  return "?";
}

std::optional<ValueType> declared_type(std::string_view word) {
  if (word == "INTGR" || word == "LONG") return ValueType::Integer;
  if (word == "REAL" || word == "DOUBLE") return ValueType::Real;
  if (word == "BOOL") return ValueType::Bool;
  if (word == "CHAR") return ValueType::String;
  if (word == "VECTOR") return ValueType::Vector;
  return std::nullopt;
}

std::string Value::to_display() const {
  switch (type) {
    case ValueType::Real: return fmt::format("{:.10g}", number);
    case ValueType::Integer: return fmt::format("{:.0f}", number);
    case ValueType::Bool: return boolean ? ".TRUE." : ".FALSE.";
    case ValueType::String: return text;
    case ValueType::Label: return prefix + "(" + text + ")";
    case ValueType::Vector: return fmt::format("{:.10g},{:.10g},{:.10g}", components[0], components[1], components[2]);
  }
  return {};
}

const std::vector<Builtin>& builtins() {
  // DMIS 5 intrinsic functions (section 6.5), plus MN/MX aliases commonly used.
  static const std::vector<Builtin> table = {
      {"ABS", 1, 1, ValueType::Real, false},
      {"SQRT", 1, 1, ValueType::Real, false},
      {"SIN", 1, 1, ValueType::Real, false},
      {"COS", 1, 1, ValueType::Real, false},
      {"TAN", 1, 1, ValueType::Real, false},
      {"ASIN", 1, 1, ValueType::Real, false},
      {"ACOS", 1, 1, ValueType::Real, false},
      {"ATAN", 1, 1, ValueType::Real, false},
      {"ATAN2", 2, 2, ValueType::Real, false},
      {"EXP", 1, 1, ValueType::Real, false},
      {"LN", 1, 1, ValueType::Real, false},
      {"LOG", 1, 1, ValueType::Real, false},
      {"INT", 1, 1, ValueType::Integer, false},
      {"NINT", 1, 1, ValueType::Integer, false},
      {"MOD", 2, 2, ValueType::Real, false},
      {"SIGN", 2, 2, ValueType::Real, false},
      {"MN", 2, 16, ValueType::Real, false},
      {"MX", 2, 16, ValueType::Real, false},
      {"MIN", 2, 16, ValueType::Real, false},
      {"MAX", 2, 16, ValueType::Real, false},
      {"DTOR", 1, 1, ValueType::Real, false},
      {"RTOD", 1, 1, ValueType::Real, false},
      {"PI", 0, 0, ValueType::Real, false},
      {"RL", 1, 1, ValueType::Real, true},
      {"DBLE", 1, 1, ValueType::Real, false},
      {"STR", 1, 3, ValueType::String, false},
      {"LEN", 1, 1, ValueType::Integer, true},
      {"SUBSTR", 2, 3, ValueType::String, true},
      {"CONCAT", 1, 16, ValueType::String, true},
      {"INDX", 2, 2, ValueType::Integer, true},
      {"TRIM", 1, 1, ValueType::String, true},
      {"UPC", 1, 1, ValueType::String, true},
      {"LWC", 1, 1, ValueType::String, true},
      {"CHR", 1, 1, ValueType::String, false},
      {"ORD", 1, 1, ValueType::Integer, true},
      // Strings to numbers and fields (DMIS 5.3 6.5): VAL('12.5'), ELEMNT(n, ',', 'a,b,c').
      {"VAL", 1, 1, ValueType::Real, true},
      {"ELEMNT", 3, 3, ValueType::String, true},
      // Intrinsics of the run (the interpreter answers them: docs/language.md): the date and time
      // on the run's clock, the simulated seconds since the start, end of an input file, the
      // number of points of a feature.
      {"SDATE", 0, 0, ValueType::String, false},
      {"STIME", 0, 0, ValueType::String, false},
      {"SDATETIME", 0, 0, ValueType::String, false},
      {"SELAPSETIME", 0, 0, ValueType::Real, false},
      {"EOF", 1, 1, ValueType::Bool, true},
      {"EOLN", 1, 1, ValueType::Bool, true},
      {"PTDATA", 1, 1, ValueType::Integer, true},
      // RAND([flag]): a number in [0, 1) of the run's sequence (Fortran's RAND; docs/language.md).
      {"RAND", 0, 1, ValueType::Real, false},
      // EXIST(F(x)|FA(x)|D(x)|...): whether the label is defined (measured, saved, evaluated);
      // DMESYS('key'): what the measuring system says about `key` (docs/language.md).
      {"EXIST", 1, 1, ValueType::Bool, true},
      {"DMESYS", 1, 1, ValueType::String, true},
      // BADPT(), BADGT(): whether the last measurement failed under BADTST/ON, with a machine
      // fault (a missed or unexpected contact) or with points no feature fits.
      {"BADPT", 0, 0, ValueType::Bool, false},
      {"BADGT", 0, 0, ValueType::Bool, false},
      // SCSNS(), SMODE(), SCFEAT(), SERROR(): the current sensor's label, the MODE, the current
      // feature's label, the last machine fault the run went on after, as strings (read as their names say, after SDATE
      // and STIME: no public text of their definitions was found; docs/language.md).
      {"SCSNS", 0, 0, ValueType::String, false},
      {"SMODE", 0, 0, ValueType::String, false},
      {"SCFEAT", 0, 0, ValueType::String, false},
      {"SERROR", 0, 0, ValueType::String, false},
      // SCDAT(): the label of the current coordinate system ('MCS' before any), as RationalDMIS's
      // macros read it to RECALL/D(@label) it again (read as SCSNS's sibling: no public text found).
      {"SCDAT", 0, 0, ValueType::String, false},
      // QTEMP(sensor): a temperature, C (the machine's thermometer; a number or a name).
      {"QTEMP", 0, 1, ValueType::Real, true},
      // Vectors (DMIS 5.3 6.5, DECL/VECTOR): built from components (VCART x,y,z; VPOL r,a,h as
      // the POL coordinates of FEAT/POINT), combined (VCROSS, VDOT, VMAG, VUNIT), and turned
      // between the part and machine systems (VMCS, VPCS: the interpreter answers those, they
      // need the current alignment).
      {"VCART", 3, 3, ValueType::Vector, false},
      {"VPOL", 3, 3, ValueType::Vector, false},
      {"VCROSS", 2, 2, ValueType::Vector, false, true},
      {"VDOT", 2, 2, ValueType::Real, false, true},
      {"VMAG", 1, 1, ValueType::Real, false, true},
      {"VUNIT", 1, 1, ValueType::Vector, false, true},
      {"VMCS", 1, 1, ValueType::Vector, false, true},
      {"VPCS", 1, 1, ValueType::Vector, false, true},
      {"VECX", 1, 1, ValueType::Real, false, true},
      {"VECY", 1, 1, ValueType::Real, false, true},
      {"VECZ", 1, 1, ValueType::Real, false, true},
  };
  return table;
}

const Builtin* find_builtin(std::string_view name) {
  const auto& t = builtins();
  auto it = std::find_if(t.begin(), t.end(), [&](const Builtin& b) { return b.name == name; });
  return it == t.end() ? nullptr : &*it;
}

tl::expected<Value, std::string> call_builtin(const Builtin& fn, const std::vector<Value>& args, bool degrees) {
  const std::string name(fn.name);
  const double to_rad = degrees ? std::numbers::pi / 180.0 : 1.0;
  if (fn.vector_args) return call_vector_builtin(name, args);
  std::vector<double> x;
  std::vector<std::string> s;
  for (const auto& a : args) {
    if (a.type == ValueType::Vector) {
      if (name == "STR") return Value::string(a.to_display());
      return tl::unexpected(fmt::format("{} does not take a VECTOR argument", name));
    }
    if (a.is_number()) {
      x.push_back(a.number);
      s.push_back(a.to_display());
    } else if (a.type == ValueType::String || a.type == ValueType::Label) {
      s.push_back(a.text);
      x.push_back(0);
      if (!fn.string_args && name != "STR")
        return tl::unexpected(fmt::format("{} expects numbers, got the string '{}'", name, a.text));
    } else if (name == "STR" && args.size() == 1) {
      return Value::string(a.boolean ? ".TRUE." : ".FALSE.");  // as DMIS writes a BOOL
    } else {
      return tl::unexpected(fmt::format("{} does not take a BOOL argument", name));
    }
  }
  const auto real = [](double v) -> tl::expected<Value, std::string> {
    if (!std::isfinite(v)) return tl::unexpected(std::string("the result is not a finite number"));
    return Value::real(v);
  };
  if (name == "ABS") return real(std::abs(x[0]));
  if (name == "SQRT") {
    if (x[0] < 0) return tl::unexpected(std::string("SQRT of a negative number"));
    return real(std::sqrt(x[0]));
  }
  if (name == "SIN") return real(std::sin(x[0] * to_rad));
  if (name == "COS") return real(std::cos(x[0] * to_rad));
  if (name == "TAN") return real(std::tan(x[0] * to_rad));
  if (name == "ASIN" || name == "ACOS") {
    if (std::abs(x[0]) > 1) return tl::unexpected(fmt::format("{} of a number outside [-1, 1]", name));
    return real((name == "ASIN" ? std::asin(x[0]) : std::acos(x[0])) / to_rad);
  }
  if (name == "ATAN") return real(std::atan(x[0]) / to_rad);
  if (name == "ATAN2") return real(std::atan2(x[0], x[1]) / to_rad);
  if (name == "EXP") return real(std::exp(x[0]));
  if (name == "LN" || name == "LOG") {
    if (x[0] <= 0) return tl::unexpected(fmt::format("{} of a number that is not positive", name));
    return real(name == "LN" ? std::log(x[0]) : std::log10(x[0]));
  }
  if (name == "VCART") return Value::vector(x[0], x[1], x[2]);
  if (name == "VPOL") return Value::vector(x[0] * std::cos(x[1] * to_rad), x[0] * std::sin(x[1] * to_rad), x[2]);
  if (name == "INT") return Value::integer(std::trunc(x[0]));
  if (name == "NINT") return Value::integer(std::round(x[0]));
  if (name == "MOD") {
    if (x[1] == 0) return tl::unexpected(std::string("MOD by zero"));
    return real(std::fmod(x[0], x[1]));
  }
  if (name == "SIGN") return real(x[1] >= 0 ? std::abs(x[0]) : -std::abs(x[0]));
  if (name == "MN" || name == "MIN") return real(*std::min_element(x.begin(), x.end()));
  if (name == "MX" || name == "MAX") return real(*std::max_element(x.begin(), x.end()));
  if (name == "DTOR") return real(x[0] * std::numbers::pi / 180.0);
  if (name == "RTOD") return real(x[0] * 180.0 / std::numbers::pi);
  if (name == "PI") return real(std::numbers::pi);
  if (name == "DBLE") return real(x[0]);
  if (name == "RL") {
    try {
      std::size_t used = 0;
      const double v = std::stod(s[0], &used);
      if (used == 0) throw std::invalid_argument("");
      return real(v);
    } catch (...) {
      return tl::unexpected(fmt::format("RL cannot read a number from '{}'", s[0]));
    }
  }
  if (name == "STR") {
    if (args[0].type == ValueType::String) return Value::string(s[0]);
    if (args.size() == 2) return Value::string(fmt::format("{:.{}f}", x[0], std::clamp(static_cast<int>(x[1]), 0, 15)));
    // STR(x, width, decimals): right-justified in `width` characters (wider when it needs more).
    if (args.size() == 3)
      return Value::string(fmt::format("{:>{}.{}f}", x[0], std::clamp(static_cast<int>(x[1]), 0, 64),
                                       std::clamp(static_cast<int>(x[2]), 0, 15)));
    return Value::string(args[0].to_display());
  }
  if (name == "LEN") return Value::integer(static_cast<double>(s[0].size()));
  if (name == "SUBSTR") {
    // SUBSTR(string, start[, end]) with 1-based inclusive positions.
    const auto n = static_cast<long>(s[0].size());
    const long b = std::clamp(static_cast<long>(args[1].number), 1L, n + 1);
    const long e = args.size() > 2 ? std::clamp(static_cast<long>(args[2].number), b - 1, n) : n;
    return Value::string(s[0].substr(static_cast<std::size_t>(b - 1), static_cast<std::size_t>(e - b + 1)));
  }
  if (name == "CONCAT") {
    std::string out;
    for (const auto& p : s) out += p;
    return Value::string(out);
  }
  if (name == "INDX") {
    const auto pos = s[0].find(s[1]);
    return Value::integer(pos == std::string::npos ? 0.0 : static_cast<double>(pos + 1));
  }
  if (name == "TRIM") {
    std::string t = s[0];
    while (!t.empty() && t.back() == ' ') t.pop_back();
    return Value::string(t);
  }
  if (name == "UPC") return Value::string(upper(s[0]));
  if (name == "LWC") return Value::string(lower(s[0]));
  if (name == "CHR") {
    // A code outside 0..255 wrapped modulo 256 (and a huge one cast undefined): refused.
    if (!(x[0] >= 0 && x[0] <= 255) || x[0] != std::floor(x[0]))
      return tl::unexpected(fmt::format("CHR needs a character code from 0 to 255, got {:g}", x[0]));
    return Value::string(std::string(1, static_cast<char>(static_cast<int>(x[0]))));
  }
  if (name == "ORD") return Value::integer(s[0].empty() ? 0.0 : static_cast<unsigned char>(s[0][0]));
  if (name == "VAL") {
    std::string t = s[0];
    while (!t.empty() && t.front() == ' ') t.erase(0, 1);
    while (!t.empty() && t.back() == ' ') t.pop_back();
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (t.empty() || end != t.c_str() + t.size()) return tl::unexpected(fmt::format("VAL: '{}' is not a number", s[0]));
    return real(v);
  }
  if (name == "ELEMNT") {
    // ELEMNT(n, delimiter, string): the n-th field (1-based); '' past the last.
    if (!args[0].is_number() || args[0].number < 1)
      return tl::unexpected(std::string("ELEMNT: the index must be 1 or more"));
    const std::string& delimiter = s[1];
    if (delimiter.empty()) return tl::unexpected(std::string("ELEMNT: the delimiter is empty"));
    std::size_t start = 0;
    for (long k = 1; k < static_cast<long>(args[0].number); ++k) {
      const auto at = s[2].find(delimiter, start);
      if (at == std::string::npos) return Value::string("");
      start = at + delimiter.size();
    }
    const auto at = s[2].find(delimiter, start);
    return Value::string(s[2].substr(start, at == std::string::npos ? std::string::npos : at - start));
  }
  return tl::unexpected(fmt::format("intrinsic {} is not implemented", name));
}

}  // namespace metron
