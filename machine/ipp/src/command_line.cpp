// SPDX-License-Identifier: GPL-3.0-or-later
// The I++ DME command-line reader. Grammar (I++ DME 1.4, command syntax; error numbers as the
// NIST test suite's parser assigns them, parserCmdErrors.txt and numbersErrorCmd.txt):
//   line     = tag ' ' name '(' [args] ')' {' '}
//   tag      = 5 digits (00001..99999) | 'E' 4 digits (E0001..E9999)
//   args     = arg {',' arg}          arg = {' '} (number | string | word ['(' [args] ')']) {' '}
//   number   = [+-] digits ['.' digits] [('E'|'e') [+-] 1..3 digits], at most 16 digits
//   word     = ident {'.' ident}      string = '"' {printable but '"'} '"' (not empty)
#include "metron/machine/ipp/command_line.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace metron::machine::ipp {
namespace {

constexpr int k_max_depth = 16;  // X(..) nests one level in the standard; deeper is malformed

bool is_alpha(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_ident(char c) { return is_alpha(c) || is_digit(c) || c == '_'; }

struct Reader {
  std::string_view s;
  std::size_t i = 0;

  [[nodiscard]] bool end() const { return i >= s.size(); }
  [[nodiscard]] char peek() const { return end() ? '\0' : s[i]; }
  void skip_spaces() {
    while (!end() && s[i] == ' ') ++i;
  }

  tl::unexpected<ParseError> error(ErrorCode code, std::string message) const {
    return tl::unexpected(ParseError{code, std::move(message), std::nullopt});
  }

  tl::expected<Argument, ParseError> number() {
    const std::size_t begin = i;
    if (peek() == '+' || peek() == '-') ++i;
    int digits = 0;
    while (is_digit(peek())) ++i, ++digits;
    if (peek() == '.') {
      ++i;
      while (is_digit(peek())) ++i, ++digits;
    }
    if (digits == 0) return error(ErrorCode::BadArgument, "a number without digits");
    if (digits > 16) return error(ErrorCode::BadArgument, "a number with more than 16 digits");
    if (peek() == '.') return error(ErrorCode::BadArgument, "two decimal points in a number");
    if (peek() == 'E' || peek() == 'e') {
      ++i;
      if (peek() == '+' || peek() == '-') ++i;
      int exponent_digits = 0;
      while (is_digit(peek())) ++i, ++exponent_digits;
      if (exponent_digits < 1 || exponent_digits > 3)
        return error(ErrorCode::BadArgument, "an exponent must have one, two or three digits");
    }
    Argument a;
    a.kind = Argument::Kind::Number;
    a.text = std::string(s.substr(begin, i - begin));
    // strtod accepts every form the grammar above lets through ("1.", ".5", "2E-3").
    a.number = std::strtod(a.text.c_str(), nullptr);
    if (!std::isfinite(a.number)) return error(ErrorCode::BadArgument, "a number out of the double range");
    return a;
  }

  tl::expected<Argument, ParseError> string() {
    ++i;  // opening quote
    const std::size_t begin = i;
    while (!end() && s[i] != '"') ++i;
    if (end()) return error(ErrorCode::BadArgument, "a string without its closing quote");
    Argument a;
    a.kind = Argument::Kind::String;
    a.text = std::string(s.substr(begin, i - begin));
    ++i;
    if (a.text.empty()) return error(ErrorCode::BadArgument, "an empty string");
    return a;
  }

  tl::expected<Argument, ParseError> word(int depth) {
    const std::size_t begin = i;
    for (;;) {
      if (!is_alpha(peek()) && peek() != '_') return error(ErrorCode::IncorrectArguments, "a malformed name");
      while (is_ident(peek())) ++i;
      if (peek() != '.') break;
      ++i;
    }
    Argument a;
    a.kind = Argument::Kind::Name;
    a.text = std::string(s.substr(begin, i - begin));
    if (peek() == '(') {
      ++i;
      auto args = list(depth + 1);
      if (!args) return tl::unexpected(args.error());
      a.kind = Argument::Kind::Call;
      a.args = std::move(*args);
    } else if (peek() != ' ' && peek() != ',' && peek() != ')') {
      return error(ErrorCode::IncorrectArguments, "a bad character after a keyword");
    }
    return a;
  }

  tl::expected<Argument, ParseError> argument(int depth) {
    skip_spaces();
    Argument a;
    const char c = peek();
    if (c == ',' || c == ')') {
      a.kind = Argument::Kind::Empty;
      return a;
    }
    tl::expected<Argument, ParseError> r =
        error(ErrorCode::IncorrectArguments, "an unexpected character in the arguments");
    if (is_digit(c) || c == '+' || c == '-' || c == '.')
      r = number();
    else if (c == '"')
      r = string();
    else if (is_alpha(c) || c == '_')
      r = word(depth);
    if (!r) return r;
    skip_spaces();
    if (peek() != ',' && peek() != ')') {
      if (!end() && s[i - 1] == ' ') return error(ErrorCode::IncorrectArguments, "an illegal space inside an argument");
      return error(ErrorCode::IncorrectArguments, "expected ',' or ')' after an argument");
    }
    return r;
  }

  // After '(' : the arguments up to and including the matching ')'.
  tl::expected<std::vector<Argument>, ParseError> list(int depth) {
    if (depth > k_max_depth) return error(ErrorCode::IncorrectArguments, "arguments nested too deeply");
    std::vector<Argument> args;
    skip_spaces();
    if (peek() == ')') {
      ++i;
      return args;
    }
    for (;;) {
      auto a = argument(depth);
      if (!a) return tl::unexpected(a.error());
      args.push_back(std::move(*a));
      if (end()) return error(ErrorCode::IncorrectArguments, "expected ')' at the end of the arguments");
      if (s[i++] == ')') return args;
    }
  }
};

}  // namespace

std::string Tag::text() const {
  char buffer[8];
  if (event)
    std::snprintf(buffer, sizeof buffer, "E%04u", static_cast<unsigned>(number % 10000));
  else
    std::snprintf(buffer, sizeof buffer, "%05u", static_cast<unsigned>(number % 100000));
  return buffer;
}

bool Argument::is_call(std::string_view name) const { return kind == Kind::Call && text == name; }

std::optional<double> Argument::call_number() const {
  if (kind == Kind::Call && args.size() == 1 && args[0].is_number()) return args[0].number;
  return std::nullopt;
}

tl::expected<std::vector<Argument>, ParseError> parse_arguments(std::string_view text) {
  std::string wrapped(text);
  wrapped += ')';
  Reader r{wrapped};
  auto args = r.list(0);
  if (args && !r.end()) return r.error(ErrorCode::IncorrectArguments, "text after the arguments");
  return args;
}

std::optional<Tag> read_tag(std::string_view line) {
  // Tag: columns 1-5.
  if (line.size() < 5) return std::nullopt;
  Tag t;
  t.event = line[0] == 'E';
  for (std::size_t k = t.event ? 1 : 0; k < 5; ++k)
    if (!is_digit(line[k])) return std::nullopt;
  std::from_chars(line.data() + (t.event ? 1 : 0), line.data() + 5, t.number);
  return t;
}

tl::expected<CommandLine, ParseError> parse_command_line(std::string_view line) {
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.remove_suffix(1);
  auto fail = [](ErrorCode code, std::string message, std::optional<Tag> tag) {
    return tl::unexpected(ParseError{code, std::move(message), tag});
  };
  const std::optional<Tag> tag = read_tag(line);
  for (unsigned char c : line)
    if (c < 0x20 || c > 0x7e) return fail(ErrorCode::IllegalCharacter, "a character outside printable ASCII", tag);
  if (!tag) return fail(ErrorCode::IllegalTag, "a tag is five digits, or E and four digits", std::nullopt);
  if (tag->number == 0)
    return fail(ErrorCode::IllegalTag, tag->event ? "E0000 is reserved for the server" : "tag number 00000", tag);
  if (line.size() < 6 || line[5] != ' ') return fail(ErrorCode::NoSpaceAtPos6, "no space after the tag", tag);

  CommandLine command;
  command.tag = *tag;
  command.text = std::string(line);
  Reader r{line, 6};
  const std::size_t name_begin = r.i;
  while (is_ident(r.peek())) ++r.i;
  command.name = std::string(line.substr(name_begin, r.i - name_begin));
  if (command.name.empty() || !is_alpha(command.name[0]))
    return fail(ErrorCode::IncorrectArguments, "expected a command name after the tag", tag);
  r.skip_spaces();  // `SetProp (..)`: the NIST server accepts a space before the list (SetProp.prg)
  if (r.peek() != '(') return fail(ErrorCode::IncorrectArguments, "expected '(' after the command name", tag);
  ++r.i;
  auto args = r.list(0);
  if (!args) {
    auto e = args.error();
    e.tag = tag;
    return tl::unexpected(e);
  }
  r.skip_spaces();
  if (!r.end()) return fail(ErrorCode::IllegalCommand, "characters after the end of the command", tag);
  command.args = std::move(*args);
  return command;
}

std::string to_string(const Argument& a) {
  switch (a.kind) {
    case Argument::Kind::Number: return a.text;
    case Argument::Kind::String: return '"' + a.text + '"';
    case Argument::Kind::Name: return a.text;
    case Argument::Kind::Empty: return "";
    case Argument::Kind::Call: {
      std::string out = a.text + "(";
      for (std::size_t k = 0; k < a.args.size(); ++k) out += (k ? ", " : "") + to_string(a.args[k]);
      return out + ")";
    }
  }
  return "";
}

}  // namespace metron::machine::ipp
