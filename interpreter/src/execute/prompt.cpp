// SPDX-License-Identifier: GPL-3.0-or-later
// V=PROMPT/'text': the operator's answer on a machine that has no operator.
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "metron/interpreter/interpreter.hpp"
#include "metron/runtime/measurement_runtime.hpp"

namespace metron::interpreter {

// The next scripted answer (`metron run --answers FILE`), else the documented default ('' for
// CHAR, 0 for numbers) with a warning (docs/language.md "PROMPT").
tl::expected<Value, std::string> Interpreter::prompt(const ir::Expr& e) {
  std::string question;
  if (!e.args.empty())
    if (auto q = evaluate(e.args.front()); q && q->type == ValueType::String) question = q->text;
  const bool text = e.type == ValueType::String;
  if (m_next_answer < m_prompt_answers.size()) {
    const std::string& answer = m_prompt_answers[m_next_answer++];
    if (text) return Value::string(answer);
    char* end = nullptr;
    const double v = std::strtod(answer.c_str(), &end);
    if (answer.empty() || end == answer.c_str() || *end != '\0')
      return tl::unexpected(fmt::format("the scripted answer '{}' to PROMPT '{}' is not a number", answer, question));
    return e.type == ValueType::Integer ? Value::integer(std::trunc(v)) : Value::real(v);
  }
  m_runtime.warning(e.span, fmt::format("PROMPT '{}': no operator on the virtual CMM, answered {} (script the answers "
                                        "with `metron run --answers FILE`)",
                                        question, text ? "''" : "0"));
  if (text) return Value::string("");
  return e.type == ValueType::Integer ? Value::integer(0) : Value::real(0);
}

}  // namespace metron::interpreter
