// SPDX-License-Identifier: GPL-3.0-or-later
// The file-access policy of a run (docs/security.md): the one place that decides which files a
// program may read and write, and how large an input file may be.
#pragma once
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <tl/expected.hpp>

namespace metron {

/// The largest input file metron reads (programs, CALL/EXTERN targets, worlds, characterisation
/// files, debugger command files, point files): 64 MiB, far above any real part program (the
/// NIST DCX program is 0.2 MB) and small enough that /dev/zero or a runaway file cannot exhaust
/// memory.
inline constexpr std::uintmax_t max_input_file_bytes = 64u * 1024u * 1024u;

/// Reads a whole regular file of at most `max_bytes` bytes. Refuses directories, devices
/// (/dev/zero), FIFOs and /proc files (their size is not known in advance) and larger files, with
/// a message that names the file and the reason.
tl::expected<std::string, std::string> read_input_file(const std::string& path,
                                                       std::uintmax_t max_bytes = max_input_file_bytes);

/// The checks of read_input_file without the reading, for files a library reads itself (CAD
/// through CGAL or OCCT): empty when `path` is a regular file of at most `max_bytes` bytes,
/// otherwise why not (a device such as /dev/zero would never end).
std::optional<std::string> refuse_input_file(const std::string& path, std::uintmax_t max_bytes = max_input_file_bytes);

/// What a program may touch: it reads files inside its own folder and the include directories
/// given on the command line, and writes only inside the output directory. Paths are compared
/// after resolving symbolic links and `..`, so neither leads out.
class FileAccessPolicy {
 public:
  /// No restriction (library use and unit tests); `metron run`, `debug` and `test` always set one.
  FileAccessPolicy() = default;
  /// Reads inside `read_dirs`, writes inside `write_dir`.
  FileAccessPolicy(const std::vector<std::string>& read_dirs, const std::string& write_dir);

  /// Whether the policy restricts anything.
  bool restricted() const { return m_restricted; }
  /// Empty when `path` may be read; otherwise why not (names the path and the allowed folders).
  std::optional<std::string> refuse_read(const std::string& path) const;
  /// Empty when `path` may be written; otherwise why not.
  std::optional<std::string> refuse_write(const std::string& path) const;
  /// The folders a program may read, resolved.
  const std::vector<std::filesystem::path>& read_dirs() const { return m_read_dirs; }

 private:
  bool m_restricted = false;
  std::vector<std::filesystem::path> m_read_dirs;
  std::filesystem::path m_write_dir;
};

/// Whether `path` names a file inside `dir` (both resolved: symbolic links and `..`).
bool path_is_inside(const std::filesystem::path& path, const std::filesystem::path& dir);

/// `text` with control bytes (other than tab) shown as \xNN and at most `max_bytes` bytes kept
/// (the rest replaced by "..."): diagnostics echo input lines, which must not inject terminal
/// escape sequences or flood the terminal.
std::string printable(std::string_view text, std::size_t max_bytes = 200);

/// `text` as valid UTF-8: every byte that does not start a valid sequence becomes U+FFFD.
std::string valid_utf8(std::string_view text);

}  // namespace metron
