// SPDX-License-Identifier: GPL-3.0-or-later
// The major words of DMIS 5.3 (ANSI/DMIS 105.2 Part 1, section 6), for telling a mistyped
// statement (`FEAT PLANE`) from a line that is not a statement at all (an operator note).
#include <algorithm>
#include <array>
#include <string_view>

#include "metron/grammar/parser.hpp"

namespace metron::grammar {
namespace {

constexpr std::array<std::string_view, 147> major_words = {
    "ACLRAT", "ALGDEF",     "ASSIGN",   "BADTST",    "BOUND",  "CALIB",     "CALL",      "CASE",   "CLMPID",  "CLMPSN",
    "CLOSE",  "CMPNTGRP",   "CNFRMRUL", "CONST",     "CRGDEF", "CRMODE",    "CROSCL",    "CRSLCT", "CUTCOM",  "CZONE",
    "CZSLCT", "DATDEF",     "DATSET",   "DATTRGDEF", "DECL",   "DECPL",     "DEFALT",    "DELETE", "DEVICE",  "DFTCAS",
    "DISPLY", "DMEHW",      "DMEID",    "DMESW",     "DMESWI", "DMESWV",    "DMIS",      "DMISMD", "DMISMN",  "DO",
    "ELSE",   "EMPTY",      "ENDAS",    "ENDCAS",    "ENDDO",  "ENDFIL",    "ENDGO",     "ENDIF",  "ENDMAC",  "ENDMES",
    "ENDSEL", "ENDSIMREQT", "ENDXTN",   "EQUATE",    "ERROR",  "EVAL",      "EXTENS",    "EXTFIL", "EXTREM",  "FEAT",
    "FEDRAT", "FILDEF",     "FILNAM",   "FINPOS",    "FIXTID", "FIXTSN",    "FLY",       "FROM",   "GEOALG",  "GEOM",
    "GOHOME", "GOTARG",     "GOTO",     "GROUP",     "IF",     "INCLUD",    "ITERAT",    "JUMPTO", "KEYCHAR", "LITDEF",
    "LOCATE", "LOTID",      "MACRO",    "MATDEF",    "MEAS",   "MFGDEV",    "MODE",      "OBTAIN", "OPEN",    "OPERID",
    "OUTPUT", "PAMEAS",     "PARTID",   "PARTRV",    "PARTSN", "PATH",      "PAUSE",     "PLANID", "POP",     "PREVOP",
    "PROCID", "PROMPT",     "PSTHRU",   "PTBUFF",    "PTMEAS", "PUSH",      "QISDEF",    "RAPID",  "READ",    "RECALL",
    "REFMNT", "REPORT",     "RESUME",   "RMEAS",     "ROTAB",  "ROTATE",    "ROTDEF",    "ROTSET", "SAVE",    "SCNMOD",
    "SCNSET", "SELECT",     "SENSOR",   "SIMREQT",   "SNSDEF", "SNSET",     "SNSGRP",    "SNSLCT", "SNSMNT",  "TECOMP",
    "TEXT",   "THLDEF",     "TOL",      "TOOLDF",    "TRANS",  "UNCERTALG", "UNCERTSET", "UNITS",  "VALUE",   "VFORM",
    "VOTDEF", "WINDEF",     "WKPLAN",   "WRIST",     "WRITE",  "XTERN",     "XTRACT"};

}  // namespace

bool is_major_word(std::string_view upper_word) {
  static_assert(std::is_sorted(major_words.begin(), major_words.end()));
  return std::binary_search(major_words.begin(), major_words.end(), upper_word);
}

}  // namespace metron::grammar
