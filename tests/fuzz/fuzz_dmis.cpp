// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: the DMIS parser and compiler, as `metron check` / `metron compile` drive them
// (Compiler::compile_file on the program file, then the IR printer). Nothing is run.
#include <cstddef>
#include <cstdint>

#include "fuzz_file.hpp"
#include "metron/interpreter/compiler.hpp"
#include "metron/interpreter/ir/instruction.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = metron::fuzz::input_file(data, size, "program.dmi");
  metron::SourceManager sources;
  metron::DiagnosticSink sink;
  metron::interpreter::Compiler compiler(sources, sink);
  const auto unit = compiler.compile_file(path);
  // What `check` prints (every diagnostic with its source line) and `compile --emit-ir` prints.
  std::size_t shown = 0;
  for (const auto& d : sink.items()) shown += metron::format_diagnostic(d, sources).size();
  if (unit && !sink.has_errors()) shown += metron::interpreter::ir::to_string(compiler.module(), sources).size();
  return shown == static_cast<std::size_t>(-1) ? 1 : 0;
}
