// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Runs a command line for the end-to-end tests of the `metron` binary. Header-only, in
// metron_test_support.
#include <sys/wait.h>

#include <cstdio>
#include <string>
#include <utility>

namespace metron::test_support {

/// Runs `command` through the shell with stderr joined to stdout; returns its exit status (-1 when
/// it could not be started) and everything it printed.
inline std::pair<int, std::string> shell(const std::string& command) {
  std::string out;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return {-1, out};
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe)) out += buffer;
  const int status = ::pclose(pipe);
  return {WEXITSTATUS(status), out};
}

}  // namespace metron::test_support
