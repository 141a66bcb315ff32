// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <tl/expected.hpp>

#include "metron/machine/ipp/command_line.hpp"
#include "metron/machine/ipp/error_code.hpp"

namespace metron::machine::ipp {

// One I++ DME response line, as the server sends it: the tag of the command it answers, a space,
// the kind character, and for data and errors a space and the body:
//   `00012 &`  acknowledged      `00012 # X(1.5), Y(2)`  data      `00012 %`  complete
//   `00012 ! Error(3, 0507, "cause", "Illegal command")`  error
// Event data carries the daemon's tag (`E0001 # X(..)`), server events the tag E0000.

/// A response line, parsed or to be written.
struct ResponseLine {
  enum class Kind { Ack, Data, Complete, Error };
  Tag tag;
  Kind kind = Kind::Ack;
  std::string body;  ///< after "# " or "! " (empty for & and %)
  // For errors (parsed from the body):
  int severity = 0;      ///< 0, 1, 2, 3 or 9
  int error_number = 0;  ///< e.g. 507
  std::string error_cause;
  std::string error_text;
};

/// The kind character: '&', '#', '%' or '!'.
char kind_char(ResponseLine::Kind kind);

/// `00012 &`
std::string format_ack(const Tag& tag);
/// `00012 %`
std::string format_complete(const Tag& tag);
/// `00012 # body`
std::string format_data(const Tag& tag, std::string_view body);
/// `00012 ! Error(3, 0507, "cause", "Illegal command")`: severity and text from the
/// specification's table; double quotes in `cause` become '#' (as the NIST server does), so the
/// error line stays parseable.
std::string format_error(const Tag& tag, ErrorCode code, std::string_view cause);

/// A number as I++ DME data: fixed point, at most `decimals` decimals, trailing zeros dropped
/// (1.5, -0.0001, 12); never exponent notation, never "-0".
std::string format_number(double value, int decimals = 6);

/// Reads a response line (the client side, and the conformance comparison).
tl::expected<ResponseLine, std::string> parse_response_line(std::string_view line);

}  // namespace metron::machine::ipp
