// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: DMIS text through the parser and the compiler (every statement family), and
// the diagnostics formatted as `metron check` prints them.
#include <cstddef>
#include <cstdint>
#include <string>

#include "metron/interpreter/compiler.hpp"
#include "metron/stdlib/diagnostic.hpp"
#include "metron/stdlib/source.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  metron::SourceManager sources;
  metron::DiagnosticSink sink;
  metron::interpreter::Compiler compiler(sources, sink);
  compiler.compile_text("<fuzz>", std::string(reinterpret_cast<const char*>(data), size));
  std::size_t n = 0;
  for (const auto& d : sink.items()) n += metron::format_diagnostic(d, sources).size();
  return n == static_cast<std::size_t>(-1);
}
