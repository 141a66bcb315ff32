// SPDX-License-Identifier: GPL-3.0-or-later
// Part programs of CMM software's own languages, which look like DMIS but are not: told as one
// clear error instead of a syntax error on every line.
#include <algorithm>
#include <array>
#include <cctype>
#include <string>

#include "metron/grammar/parser.hpp"

namespace metron::grammar {
namespace {

struct Signature {
  std::string_view dialect;  ///< the package whose language it is
  std::string_view start;    ///< how a line of that language starts (upper case, blanks removed)
  bool anywhere = false;     ///< true: found anywhere in the line, not only at its start
};

// Statements of these languages that DMIS has no form for. PC-DMIS's own language: its help
// pages' examples (ENDMEAS/, COMMENT/OPER, END_IF/, a FEAT/POINT,RECT). MCOSMOS GEOPAK's ASCII
// programs (.agw): as a public MATLAB generator of contour programs writes them (CNCON, CONTOUR/,
// DRIVE/, ASSIGN/'name'=...).
constexpr std::array<Signature, 17> signatures = {{
    {"PC-DMIS", "ENDMEAS/"},
    {"PC-DMIS", "COMMENT/OPER"},
    {"PC-DMIS", "COMMENT/REPT"},
    {"PC-DMIS", "COMMENT/DOC"},
    {"PC-DMIS", "END_IF/"},
    {"PC-DMIS", "ELSE_IF/"},
    {"PC-DMIS", "LOADPROBE/"},
    {"PC-DMIS", "MODE/DCC"},
    {"PC-DMIS", "MOVE/CLEARP"},
    {"PC-DMIS", "=ALIGNMENT/START", true},
    {"PC-DMIS", "=FEAT/CONTACT/", true},
    {"PC-DMIS", "=FEAT/POINT,RECT", true},
    {"PC-DMIS", "=FEAT/POINT,POLR", true},
    {"MCOSMOS GEOPAK", "CNCON/"},
    {"MCOSMOS GEOPAK", "CONTOUR/"},
    {"MCOSMOS GEOPAK", "DRIVE/"},
    {"MCOSMOS GEOPAK", "ASSIGN/'"},
}};

std::string squeezed_upper(std::string_view line) {
  std::string s;
  for (char c : line)
    if (c != ' ' && c != '\t' && c != '\r') s += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

std::optional<ForeignDialect> recognise_foreign_dialect(std::string_view text) {
  std::optional<ForeignDialect> found;
  std::size_t offset = 0;
  while (offset < text.size()) {
    const std::size_t end = std::min(text.find('\n', offset), text.size());
    const std::string line = squeezed_upper(text.substr(offset, end - offset));
    // A DMIS program starts with DMISMN (a module with DMISMD): one is never a foreign program.
    if (line.rfind("DMISMN/", 0) == 0 || line.rfind("DMISMD/", 0) == 0) return std::nullopt;
    // I++ DME: a client's command stream, `00010 StartSession()` (the NIST conformance files).
    if (!found && line.size() > 6 &&
        std::all_of(line.begin(), line.begin() + 5,
                    [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }) &&
        std::isalpha(static_cast<unsigned char>(line[5])) && line.find('(') != std::string::npos) {
      const std::size_t indent = text.find_first_not_of(" \t", offset);
      const std::string_view raw = text.substr(indent, end - indent);
      const std::size_t method = raw.find_first_not_of(" \t", 5);
      found = ForeignDialect{"I++ DME", std::string(raw.substr(method, raw.find('(') - method)) + "()",
                             static_cast<std::uint32_t>(indent)};
    }
    if (!found && line.rfind("$$", 0) != 0)
      for (const auto& s : signatures)
        if (s.anywhere ? line.find(s.start) != std::string::npos : line.rfind(s.start, 0) == 0) {
          const std::size_t indent = text.find_first_not_of(" \t", offset);
          found = ForeignDialect{std::string(s.dialect), std::string(s.start), static_cast<std::uint32_t>(indent)};
          break;
        }
    offset = end + 1;
  }
  return found;
}

}  // namespace metron::grammar
