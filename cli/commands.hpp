// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <optional>
#include <string>

namespace metron::cli {

struct RunArgs {
  std::string program;
  std::optional<std::string> world;
  std::optional<std::uint64_t> seed;
  std::string out_dir = ".";
  bool quiet = false;
};

struct FitArgs {
  std::string type;
  std::string file;
  std::string format = "text";
};

int run(const RunArgs& args);
int check(const std::string& program);
int compile(const std::string& program, bool emit_ir);
int fit(const FitArgs& args);

}  // namespace metron::cli
