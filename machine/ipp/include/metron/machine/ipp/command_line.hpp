// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <tl/expected.hpp>

#include "metron/machine/ipp/error_code.hpp"

namespace metron::machine::ipp {

// One I++ DME command line, as the client sends it: `00012 PtMeas(X(10),Y(20),IJK(0,0,1))`.
// Columns 1-5 are the tag, column 6 a space, then the command name and its argument list.

/// A command tag: five digits, or `E` and four digits for a fast (event) command.
struct Tag {
  bool event = false;        ///< `E0001`: an event tag (daemons, E-commands)
  std::uint32_t number = 0;  ///< 1..99999 (command), 1..9999 (event); 0 only for E0000
  /// The five characters, e.g. "00012" or "E0001".
  [[nodiscard]] std::string text() const;
  friend bool operator==(const Tag&, const Tag&) = default;
};

/// One argument of a command (and, recursively, of a call argument).
struct Argument {
  enum class Kind {
    Number,  ///< 12.5, -2.6E01
    String,  ///< "Probe1" (the quotes are not part of `text`)
    Name,    ///< a bare word or dotted name: MachineCsy, E0006, OBB
    Call,    ///< a name with an argument list: X(1), IJK(0,0,1), Tool.PtMeasPar.Speed()
    Empty,   ///< nothing between two commas (kept so the checker can say what was wrong)
  };
  Kind kind = Kind::Empty;
  std::string text;            ///< the number as written, the string's content, or the name
  double number = 0;           ///< for Number
  std::vector<Argument> args;  ///< for Call

  [[nodiscard]] bool is_number() const { return kind == Kind::Number; }
  [[nodiscard]] bool is_call(std::string_view name) const;
  /// A call with exactly one number argument, e.g. X(1.5): that number.
  [[nodiscard]] std::optional<double> call_number() const;
};

/// A parsed command line.
struct CommandLine {
  Tag tag;
  std::string name;  ///< e.g. "PtMeas" (case as sent)
  std::vector<Argument> args;
  std::string text;  ///< the line as received, without the line terminator
};

/// Why a line could not be parsed, with the specification's error number.
struct ParseError {
  ErrorCode code = ErrorCode::IncorrectArguments;
  std::string message;     ///< lowercase detail, e.g. "two decimal points in a number"
  std::optional<Tag> tag;  ///< the tag, when it could be read
};

/// The tag of a line (columns 1-5), when it has one: what a server needs to acknowledge a line
/// before it parses the rest; parse_command_line reads the same tag.
std::optional<Tag> read_tag(std::string_view line);

/// Parses one line (CR/LF already removed or present at the end). Any byte sequence is accepted
/// as input; malformed lines give a ParseError, never an exception.
tl::expected<CommandLine, ParseError> parse_command_line(std::string_view line);

/// Parses the argument list text between a command's parentheses (also used by the response
/// reader for data lines such as `X(1), Y(2)`).
tl::expected<std::vector<Argument>, ParseError> parse_arguments(std::string_view text);

/// The argument as I++ DME writes it (numbers as they were written, strings quoted).
std::string to_string(const Argument& argument);

}  // namespace metron::machine::ipp
