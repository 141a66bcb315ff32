// SPDX-License-Identifier: GPL-3.0-or-later
// A test process's scratch folder: `<temp>/<prefix>_<pid>`, made on first use and removed with
// everything in it when the process exits normally (ctest runs each test in a process of its
// own, and the folders were left behind: thousands in /tmp). A crash keeps it for inspection.
// Header only, so the test folders that do not link metron_test_support use it too.
#pragma once
#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>
#include <system_error>

namespace metron::test_support {

inline std::filesystem::path scratch_root(const std::string& prefix) {
  struct Made {
    std::set<std::filesystem::path> folders;
    ~Made() {
      for (const auto& f : folders) {
        std::error_code ignored;
        std::filesystem::remove_all(f, ignored);
      }
    }
  };
  static Made made;
  const std::filesystem::path d = std::filesystem::temp_directory_path() / (prefix + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  made.folders.insert(d);
  return d;
}

}  // namespace metron::test_support
