// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/ipp/response_line.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace metron::machine::ipp {

char kind_char(ResponseLine::Kind kind) {
  switch (kind) {
    case ResponseLine::Kind::Ack: return '&';
    case ResponseLine::Kind::Data: return '#';
    case ResponseLine::Kind::Complete: return '%';
    case ResponseLine::Kind::Error: return '!';
  }
  return '?';
}

std::string format_ack(const Tag& tag) { return tag.text() + " &"; }
std::string format_complete(const Tag& tag) { return tag.text() + " %"; }
std::string format_data(const Tag& tag, std::string_view body) { return tag.text() + " # " + std::string(body); }

std::string format_error(const Tag& tag, ErrorCode code, std::string_view cause) {
  const auto& info = error_info(code);
  std::string c(cause);
  for (char& ch : c)
    if (ch == '"') ch = '#';
  char head[32];
  std::snprintf(head, sizeof head, "Error(%d, %04d, \"", static_cast<int>(info.severity), static_cast<int>(code));
  return tag.text() + " ! " + head + c + "\", \"" + std::string(info.text) + "\")";
}

std::string format_number(double value, int decimals) {
  if (!std::isfinite(value)) return "0";
  char buffer[400];  // %f of 1e308 has 309 digits before the point
  std::snprintf(buffer, sizeof buffer, "%.*f", std::clamp(decimals, 0, 17), value);
  std::string s = buffer;
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s == "-0") s = "0";
  return s;
}

tl::expected<ResponseLine, std::string> parse_response_line(std::string_view line) {
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.remove_suffix(1);
  if (line.size() < 7 || line[5] != ' ')
    return tl::unexpected(std::string("a response line is a tag, a space and a kind"));
  ResponseLine r;
  r.tag.event = line[0] == 'E';
  for (std::size_t k = r.tag.event ? 1 : 0; k < 5; ++k) {
    if (line[k] < '0' || line[k] > '9') return tl::unexpected(std::string("a malformed tag"));
    r.tag.number = r.tag.number * 10 + static_cast<std::uint32_t>(line[k] - '0');
  }
  switch (line[6]) {
    case '&': r.kind = ResponseLine::Kind::Ack; break;
    case '#': r.kind = ResponseLine::Kind::Data; break;
    case '%': r.kind = ResponseLine::Kind::Complete; break;
    case '!': r.kind = ResponseLine::Kind::Error; break;
    default: return tl::unexpected(std::string("unknown response kind '") + line[6] + "'");
  }
  if (line.size() > 7) {
    if (line[7] != ' ') return tl::unexpected(std::string("expected a space after the kind"));
    r.body = std::string(line.substr(8));
  }
  if (r.kind == ResponseLine::Kind::Error) {
    // Error(severity, number, "cause", "text"): the numbers strictly, the strings best effort.
    const std::string b = r.body;
    if (std::sscanf(b.c_str(), "Error(%d ,%d", &r.severity, &r.error_number) != 2 &&
        std::sscanf(b.c_str(), "Error( %d , %d", &r.severity, &r.error_number) != 2)
      return tl::unexpected(std::string("malformed Error(severity, number, cause, text)"));
    const auto q1 = b.find('"');
    const auto q2 = q1 == std::string::npos ? q1 : b.find('"', q1 + 1);
    const auto q3 = q2 == std::string::npos ? q2 : b.find('"', q2 + 1);
    const auto q4 = q3 == std::string::npos ? q3 : b.find('"', q3 + 1);
    if (q2 != std::string::npos) r.error_cause = b.substr(q1 + 1, q2 - q1 - 1);
    if (q4 != std::string::npos) r.error_text = b.substr(q3 + 1, q4 - q3 - 1);
  }
  return r;
}

}  // namespace metron::machine::ipp
