// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "metron/stdlib/span.hpp"
#include "metron/stdlib/text_encoding.hpp"

namespace metron {

/// A line/column position (both 1-based) in a named file.
struct Location {
  std::string path;
  std::uint32_t line = 0;
  std::uint32_t column = 0;
};

/// One loaded source file: its path and its text as UTF-8 (the exact bytes unless the file was
/// Windows-1252 / Latin-1, which is decoded: docs/language.md "Encodings").
struct SourceFile {
  std::string path;
  std::string text;
  TextEncoding encoding = TextEncoding::Ascii;  ///< what the bytes were found to be
  std::vector<std::uint32_t> line_starts;       ///< byte offset of each line start
};

/// Owns every source file of a compilation; maps spans to positions and source lines.
class SourceManager {
 public:
  /// Adds a file held in memory; returns its id (>= 1).
  std::uint32_t add(std::string path, std::string text);
  /// Reads a file from disk; returns 0 if it cannot be read.
  std::uint32_t load(const std::string& path);

  [[nodiscard]] const SourceFile& file(std::uint32_t id) const;
  [[nodiscard]] std::size_t size() const { return m_files.size(); }
  [[nodiscard]] Location locate(std::uint32_t file, std::uint32_t offset) const;
  [[nodiscard]] Location locate(Span span) const { return locate(span.file, span.begin); }
  /// The whole physical line containing `offset`, without its newline.
  [[nodiscard]] std::string_view line_text(std::uint32_t file, std::uint32_t offset) const;

 private:
  std::vector<std::unique_ptr<SourceFile>> m_files;
};

}  // namespace metron
