// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The fuzz input as a file: the loaders under test take paths (as the CLI passes them), so each
// input is written to a private temporary folder and the real entry point reads it from there.
// Relative references inside the input (CALL/EXTERN, "extends", CAD paths) resolve inside it.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

namespace metron::fuzz {

/// A folder made once per process (mkdtemp) and removed with what it holds when the process
/// exits normally (a replay of the corpus, a fuzzing run's end); a crash keeps it for inspection.
struct InputFolder {
  std::string path;
  InputFolder() {
    char pattern[] = "/tmp/metron-fuzz-XXXXXX";
    const char* made = mkdtemp(pattern);
    if (!made) std::abort();
    path = made;
  }
  ~InputFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  InputFolder(const InputFolder&) = delete;
  InputFolder& operator=(const InputFolder&) = delete;
};

/// Writes `data` to `name` inside the process's input folder; returns its path.
inline std::string input_file(const std::uint8_t* data, std::size_t size, const char* name) {
  static const InputFolder dir;
  const std::string path = dir.path + "/" + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

}  // namespace metron::fuzz
