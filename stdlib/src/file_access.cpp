// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/file_access.hpp"

#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace metron {
namespace fs = std::filesystem;

std::optional<std::string> refuse_input_file(const std::string& path, std::uintmax_t max_bytes) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) return fmt::format("cannot read {}: no such file", path);
  if (fs::is_directory(st)) return fmt::format("cannot read {}: it is a directory", path);
  if (!fs::is_regular_file(st)) return fmt::format("cannot read {}: not a regular file", path);
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) return fmt::format("cannot read {}: {}", path, ec.message());
  if (size > max_bytes)
    return fmt::format("cannot read {}: {} bytes exceeds the limit of {} bytes for an input file", path, size,
                       max_bytes);
  return std::nullopt;
}

tl::expected<std::string, std::string> read_input_file(const std::string& path, std::uintmax_t max_bytes) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  // A pipe (`metron check /dev/stdin`) is read up to the cap: it ends when its writer closes it,
  // and one that never ends (`yes |`) stops at the cap.
  if (fs::is_fifo(st)) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return tl::unexpected(fmt::format("cannot read {}: permission denied or unreadable", path));
    std::string text;
    char chunk[65536];
    while (in.read(chunk, sizeof chunk) || in.gcount() > 0) {
      text.append(chunk, static_cast<std::size_t>(in.gcount()));
      if (text.size() > max_bytes)
        return tl::unexpected(
            fmt::format("cannot read {}: more than the limit of {} bytes for an input file", path, max_bytes));
    }
    return text;
  }
  // Missing files, folders, devices and sockets (no size to check, may never end: /dev/zero), and
  // files above the cap.
  if (auto refused = refuse_input_file(path, max_bytes)) return tl::unexpected(*refused);
  const std::uintmax_t size = fs::file_size(path, ec);
  std::ifstream in(path, std::ios::binary);
  if (!in) return tl::unexpected(fmt::format("cannot read {}: permission denied or unreadable", path));
  std::string text;
  text.resize(static_cast<std::size_t>(size));
  in.read(text.data(), static_cast<std::streamsize>(size));
  text.resize(static_cast<std::size_t>(in.gcount()));
  // A file that grew while read (or a /proc-like file reporting size 0) is still capped.
  if (in && in.peek() != std::char_traits<char>::eof())
    return tl::unexpected(fmt::format("cannot read {}: the file grew past {} bytes while read", path, size));
  return text;
}

namespace {
fs::path resolved(const fs::path& p) {
  std::error_code ec;
  fs::path abs = fs::absolute(p, ec);
  if (ec) abs = p;
  fs::path r = fs::weakly_canonical(abs, ec);
  return ec ? abs.lexically_normal() : r;
}

std::string folder_list(const std::vector<fs::path>& dirs) {
  std::string s;
  for (const auto& d : dirs) s += (s.empty() ? "" : ", ") + d.string();
  return s;
}
}  // namespace

bool path_is_inside(const fs::path& path, const fs::path& dir) {
  const fs::path p = resolved(path), d = resolved(dir);
  auto pi = p.begin();
  for (auto di = d.begin(); di != d.end(); ++di, ++pi) {
    if (di->empty()) continue;  // a trailing separator
    if (pi == p.end() || *pi != *di) return false;
  }
  return true;
}

FileAccessPolicy::FileAccessPolicy(const std::vector<std::string>& read_dirs, const std::string& write_dir)
    : m_restricted(true), m_write_dir(resolved(write_dir.empty() ? "." : write_dir)) {
  for (const auto& d : read_dirs) m_read_dirs.push_back(resolved(d.empty() ? "." : d));
}

std::optional<std::string> FileAccessPolicy::refuse_read(const std::string& path) const {
  if (!m_restricted) return std::nullopt;
  for (const auto& d : m_read_dirs)
    if (path_is_inside(path, d)) return std::nullopt;
  return fmt::format(
      "reading {} is not allowed: a program reads only inside its own folder and the --include "
      "folders ({}); docs/security.md",
      resolved(path).string(), folder_list(m_read_dirs));
}

std::optional<std::string> FileAccessPolicy::refuse_write(const std::string& path) const {
  if (!m_restricted) return std::nullopt;
  if (path_is_inside(path, m_write_dir) && resolved(path) != m_write_dir) return std::nullopt;
  return fmt::format(
      "writing {} is not allowed: a program writes only inside the output folder {} (--out); "
      "docs/security.md",
      resolved(path).string(), m_write_dir.string());
}

std::string printable(std::string_view text, std::size_t max_bytes) {
  std::string out;
  const std::size_t n = std::min(text.size(), max_bytes);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if ((c < 0x20 && c != '\t') || c == 0x7f)
      out += fmt::format("\\x{:02x}", c);
    else
      out += static_cast<char>(c);
  }
  if (text.size() > max_bytes) out += "...";
  return valid_utf8(out);
}

std::string valid_utf8(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
    bool ok = len > 0 && i + len <= s.size();
    for (std::size_t k = 1; ok && k < len; ++k) ok = (static_cast<unsigned char>(s[i + k]) & 0xc0) == 0x80;
    if (ok && len >= 2) {
      // Overlong forms, surrogates and code points above U+10FFFF are not valid UTF-8 (RFC 3629 §3).
      std::uint32_t cp = c & (0xff >> (len + 1));
      for (std::size_t k = 1; k < len; ++k) cp = (cp << 6) | (static_cast<unsigned char>(s[i + k]) & 0x3f);
      const std::uint32_t min_cp = len == 2 ? 0x80 : len == 3 ? 0x800 : 0x10000;
      ok = cp >= min_cp && cp <= 0x10ffff && !(cp >= 0xd800 && cp <= 0xdfff);
    }
    if (ok) {
      out.append(s.substr(i, len));
      i += len;
    } else {
      out += "\xef\xbf\xbd";
      ++i;
    }
  }
  return out;
}

}  // namespace metron
