// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/fitting/point_file.hpp"

#include "metron/stdlib/file_access.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include <fmt/format.h>

namespace metron::fitting {
namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

/// Splits a record on commas (CSV) or on runs of blanks.
std::vector<std::string_view> split_fields(std::string_view line, bool csv) {
  std::vector<std::string_view> fields;
  if (csv) {
    std::size_t start = 0;
    for (;;) {
      const std::size_t comma = line.find(',', start);
      fields.push_back(
          trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    return fields;
  }
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t begin = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > begin) fields.push_back(line.substr(begin, i - begin));
  }
  return fields;
}

/// The whole token as a number (from_chars takes "nan" and "inf", which callers reject).
std::optional<double> parse_number(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return std::nullopt;
  double value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (end != token.data() + token.size()) return std::nullopt;
  // Out of range: strtod gives +-HUGE_VAL on overflow (rejected as not finite) and the
  // nearest value, at most denormal, on underflow.
  if (ec == std::errc::result_out_of_range) return std::strtod(std::string(token).c_str(), nullptr);
  if (ec != std::errc()) return std::nullopt;
  return value;
}

std::string shorten(std::string_view token) {
  std::string s(token.substr(0, 32));
  for (char& c : s) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) c = '?';
  }
  return token.size() > 32 ? s + "..." : s;
}

PointFileError at_line(std::size_t line, std::string_view what) {
  return {fmt::format("line {}: {}", line, what), line};
}

}  // namespace

tl::expected<std::vector<Vec3>, PointFileError> parse_point_text(std::string_view text) {
  // Physical lines with their 1-based numbers, blank ones dropped.
  std::vector<std::pair<std::size_t, std::string_view>> lines;
  std::size_t line_no = 0;
  for (std::size_t start = 0; start <= text.size();) {
    const std::size_t nl = text.find('\n', start);
    const std::size_t end = nl == std::string_view::npos ? text.size() : nl;
    ++line_no;
    const std::string_view line = trim(text.substr(start, end - start));
    if (!line.empty()) lines.emplace_back(line_no, line);
    if (nl == std::string_view::npos) break;
    start = nl + 1;
  }
  if (lines.empty()) return tl::unexpected(PointFileError{"the file holds no points", 0});

  std::size_t first = 0;
  std::optional<std::size_t> declared;
  const bool csv = lines.front().second.find(',') != std::string_view::npos ||
                   (lines.size() > 1 && lines[1].second.find(',') != std::string_view::npos);
  const std::vector<std::string_view> head = split_fields(lines.front().second, csv);
  if (head.size() == 1) {
    // NIST .ds: the point count alone on the first line.
    std::size_t n = 0;
    const std::string_view t = head.front();
    const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), n);
    if (ec == std::errc() && end == t.data() + t.size()) {
      declared = n;
    } else if (parse_number(t)) {
      return tl::unexpected(
          at_line(lines.front().first, fmt::format("expected a point count or 3 numbers, got '{}'", shorten(t))));
    }  // else a one-word header
    first = 1;
  } else if (std::none_of(head.begin(), head.end(), [](std::string_view f) { return parse_number(f).has_value(); })) {
    first = 1;  // a header line such as "x,y,z"
  }

  std::vector<Vec3> points;
  for (std::size_t k = first; k < lines.size(); ++k) {
    const auto& [number, line] = lines[k];
    const std::vector<std::string_view> fields = split_fields(line, csv);
    if (fields.size() != 3) {
      return tl::unexpected(at_line(number, fmt::format("expected 3 numbers, got {}", fields.size())));
    }
    Vec3 p;
    for (int c = 0; c < 3; ++c) {
      const std::optional<double> v = parse_number(fields[static_cast<std::size_t>(c)]);
      if (!v) {
        const std::string_view field = fields[static_cast<std::size_t>(c)];
        return tl::unexpected(at_line(number, fmt::format("'{}' is not a number", shorten(field))));
      }
      if (!std::isfinite(*v)) {
        return tl::unexpected(at_line(number, fmt::format("coordinate {} is not finite", "xyz"[c])));
      }
      p(c) = *v;
    }
    points.push_back(p);
  }
  if (declared && *declared != points.size()) {
    return tl::unexpected(
        PointFileError{fmt::format("declared {} points but found {}", *declared, points.size()), lines.front().first});
  }
  if (!declared && points.empty()) return tl::unexpected(PointFileError{"the file holds no points", 0});
  return points;
}

tl::expected<std::vector<Vec3>, PointFileError> read_point_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return tl::unexpected(PointFileError{fmt::format("'{}' is a directory", path), 0});
  }
  if (!std::ifstream(path, std::ios::binary))
    return tl::unexpected(PointFileError{fmt::format("cannot open '{}'", path), 0});
  // The input size cap and regular files only: /dev/zero must not grow memory (docs/security.md).
  auto text = read_input_file(path);
  if (!text) return tl::unexpected(PointFileError{text.error(), 0});
  return parse_point_text(*text);
}

}  // namespace metron::fitting
