// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>

#include <tl/expected.hpp>

#include "metron/machine/fault.hpp"
#include "metron/stdlib/span.hpp"

namespace metron::runtime {

/// Why a runtime operation failed: a program error (reported like a compile error) or a
/// machine fault (the motion stopped; results obtained before it are kept).
struct RuntimeError {
  enum class Kind { Program, Fault } kind = Kind::Program;
  std::string message;
  Span span;                            ///< the statement that caused it
  std::optional<machine::Fault> fault;  ///< when kind == Fault
  bool bad_geometry = false;            ///< a Program error: a measurement's points fit no feature (BADTST's BADGT)
};

template <class T>
using Result = tl::expected<T, RuntimeError>;

inline tl::unexpected<RuntimeError> program_error(Span span, std::string message) {
  return tl::unexpected(RuntimeError{RuntimeError::Kind::Program, std::move(message), span, {}});
}

}  // namespace metron::runtime
