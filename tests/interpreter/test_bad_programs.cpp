// SPDX-License-Identifier: GPL-3.0-or-later
// Every program in programs/bad must produce exactly the diagnostic its `$$ expect:` lines name.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "metron/interpreter/compiler.hpp"

namespace {

std::vector<std::string> expectations(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::vector<std::string> out;
  std::string line;
  const std::string tag = "$$ expect: ";
  while (std::getline(in, line))
    if (line.rfind(tag, 0) == 0) out.push_back(line.substr(tag.size()));
  return out;
}

std::string position_line(const metron::Diagnostic& d, const metron::SourceManager& sources) {
  const auto loc = sources.locate(d.span);
  return std::to_string(loc.line) + ":" + std::to_string(loc.column) + ": " +
         (d.severity == metron::Severity::Error ? "error" : "warning") + ": " + d.message;
}

TEST(BadPrograms, EachGivesItsExactDiagnostic) {
  const std::filesystem::path dir = std::filesystem::path(METRON_SOURCE_DIR) / "programs" / "bad";
  std::size_t programs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".dmi") continue;
    const auto expected = expectations(entry.path());
    ASSERT_FALSE(expected.empty()) << entry.path() << " has no $$ expect: line";
    metron::SourceManager sources;
    metron::DiagnosticSink sink;
    metron::interpreter::Compiler compiler(sources, sink);
    compiler.compile_file(entry.path().string());
    std::set<std::string> got;
    for (const auto& d : sink.items()) got.insert(position_line(d, sources));
    EXPECT_TRUE(sink.has_errors()) << entry.path();
    for (const auto& e : expected) {
      std::string all;
      for (const auto& g : got) all += "  " + g + "\n";
      EXPECT_TRUE(got.count(e)) << entry.path().filename() << ": expected\n  " << e << "\ngot\n" << all;
    }
    ++programs;
  }
  EXPECT_GE(programs, 25u);
}

TEST(BadPrograms, FirstErrorIsTheExpectedOne) {
  // The expected error is the first error reported: no cascade hides it.
  const std::filesystem::path dir = std::filesystem::path(METRON_SOURCE_DIR) / "programs" / "bad";
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".dmi") continue;
    metron::SourceManager sources;
    metron::DiagnosticSink sink;
    metron::interpreter::Compiler compiler(sources, sink);
    compiler.compile_file(entry.path().string());
    for (const auto& d : sink.items())
      if (d.severity == metron::Severity::Error) {
        EXPECT_EQ(position_line(d, sources), expectations(entry.path()).front()) << entry.path().filename();
        break;
      }
  }
}

}  // namespace
