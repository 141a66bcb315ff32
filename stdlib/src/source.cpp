// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/source.hpp"

#include "metron/stdlib/text_encoding.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace metron {

std::uint32_t SourceManager::add(std::string path, std::string text) {
  auto f = std::make_unique<SourceFile>();
  f->path = std::move(path);
  // Shop software writes Latin-1 / Windows-1252 as well as UTF-8: read every file as UTF-8.
  f->text = to_utf8(std::move(text), &f->encoding);
  f->line_starts.push_back(0);
  for (std::uint32_t i = 0; i < f->text.size(); ++i)
    if (f->text[i] == '\n') f->line_starts.push_back(i + 1);
  m_files.push_back(std::move(f));
  return static_cast<std::uint32_t>(m_files.size());
}

std::uint32_t SourceManager::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return 0;
  std::ostringstream ss;
  ss << in.rdbuf();
  return add(path, ss.str());
}

const SourceFile& SourceManager::file(std::uint32_t id) const {
  if (id == 0 || id > m_files.size()) throw std::out_of_range("metron: bad source file id");
  return *m_files[id - 1];
}

Location SourceManager::locate(std::uint32_t id, std::uint32_t offset) const {
  if (id == 0 || id > m_files.size()) return {};
  const SourceFile& f = *m_files[id - 1];
  auto it = std::upper_bound(f.line_starts.begin(), f.line_starts.end(), offset);
  const auto line = static_cast<std::uint32_t>(it - f.line_starts.begin());
  return {f.path, line, offset - f.line_starts[line - 1] + 1};
}

std::string_view SourceManager::line_text(std::uint32_t id, std::uint32_t offset) const {
  if (id == 0 || id > m_files.size()) return {};
  const SourceFile& f = *m_files[id - 1];
  auto it = std::upper_bound(f.line_starts.begin(), f.line_starts.end(), offset);
  const std::uint32_t begin = *(it - 1);
  std::uint32_t end = begin;
  while (end < f.text.size() && f.text[end] != '\n') ++end;
  if (end > begin && f.text[end - 1] == '\r') --end;
  return std::string_view(f.text).substr(begin, end - begin);
}

}  // namespace metron
