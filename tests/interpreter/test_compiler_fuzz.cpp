// SPDX-License-Identifier: GPL-3.0-or-later
// Bad input never crashes the compiler: mutated real programs (fixed seed) compile to errors,
// never to exceptions. A failing input is printed.
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "cli/virtual_cmm_backend.hpp"
#include "metron/interpreter/compiler.hpp"
#include "metron/interpreter/session.hpp"
#include "metron/runtime/outputs.hpp"

namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string mutate(std::string s, std::mt19937& rng) {
  static const std::string alphabet = "0123456789.,/=()[]$'+-*ABCDEFXYZ_ \n";
  std::uniform_int_distribution<int> kind(0, 3);
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int e = 0; e < edits && !s.empty(); ++e) {
    const std::size_t at = rng() % s.size();
    switch (kind(rng)) {
      case 0: s.erase(at, 1 + rng() % 8); break;
      case 1: s.insert(at, 1, alphabet[rng() % alphabet.size()]); break;
      case 2: s[at] = alphabet[rng() % alphabet.size()]; break;
      default: {  // duplicate a line: blocks, labels and definitions repeat
        const std::size_t b = s.rfind('\n', at);
        const std::size_t begin = b == std::string::npos ? 0 : b + 1;
        const std::size_t end = s.find('\n', at);
        const std::string line = s.substr(begin, end == std::string::npos ? std::string::npos : end - begin + 1);
        s.insert(begin, line);
      }
    }
  }
  return s;
}

TEST(CompilerFuzz, MutatedProgramsNeverThrow) {
  std::vector<std::string> seeds;
  for (const char* dir : {"programs/examples", "programs/regression", "programs/bad", "programs/real"})
    for (const auto& e : fs::directory_iterator(fs::path(METRON_SOURCE_DIR) / dir))
      if (e.path().extension() == ".dmi") seeds.push_back(slurp(e.path()));
  ASSERT_FALSE(seeds.empty());
  std::mt19937 rng(20261121);
  for (int i = 0; i < 3000; ++i) {
    const std::string text = mutate(seeds[static_cast<std::size_t>(i) % seeds.size()], rng);
    metron::SourceManager sources;
    metron::DiagnosticSink sink;
    metron::interpreter::Compiler compiler(sources, sink);
    try {
      compiler.compile_text("fuzz.dmi", text);
      for (const auto& d : sink.items()) (void)metron::format_diagnostic(d, sources);
    } catch (const std::exception& ex) {
      FAIL() << "input " << i << " threw " << ex.what() << "\n---\n" << text << "\n---";
    }
  }
}

}  // namespace

namespace {

// Mutated programs that still compile are run on the default world: they may fault or err, never
// throw or crash (run-time decoding, the runtime and the machine on odd values).
TEST(CompilerFuzz, MutatedProgramsThatCompileRunWithoutThrowing) {
  std::vector<std::string> seeds;
  for (const char* dir : {"programs/examples", "programs/regression"})
    for (const auto& e : fs::directory_iterator(fs::path(METRON_SOURCE_DIR) / dir))
      if (e.path().extension() == ".dmi" && e.path().filename().string().rfind("03_", 0) != 0 &&
          e.path().filename().string().rfind("04_", 0) != 0)
        seeds.push_back(slurp(e.path()));
  std::mt19937 rng(7);
  const fs::path dir = metron::test_support::scratch_root("metron_fuzz");
  fs::create_directories(dir);
  int ran = 0;
  for (int i = 0; i < 400 && ran < 60; ++i) {
    const std::string text = mutate(seeds[static_cast<std::size_t>(i) % seeds.size()], rng);
    const fs::path p = dir / "fuzz.dmi";
    std::ofstream(p) << text;
    auto backend = metron::cli::virtual_cmm_backend(std::nullopt, 1);
    ASSERT_TRUE(backend.has_value());
    auto session = metron::interpreter::Session::create(std::move(*backend));
    auto& s = *session;
    s.runtime().set_output_directory(dir.string());
    try {
      if (!s.load(p.string())) continue;
      ++ran;
      (void)s.interpreter().run();
      s.runtime().finish();
      (void)metron::runtime::results_json(s.record()).dump();
    } catch (const std::exception& ex) {
      FAIL() << "input " << i << " threw " << ex.what() << "\n---\n" << text << "\n---";
    }
  }
  EXPECT_GT(ran, 10);
}

}  // namespace
