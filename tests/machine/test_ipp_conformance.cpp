// SPDX-License-Identifier: GPL-3.0-or-later
// Conformance against the NIST I++ DME test suite (shared/data/ippdme-conformance): every .prg
// is replayed against a Session on the default virtual CMM and compared, command by command,
// with its .res: the response structure (& # ! %), the data items (names and arity, not values:
// the .res files were recorded on other machines), the error numbers. The table printed here is
// the one in docs/ipp-dme.md. The parser's own error numbers (parserCmdErrors.txt) are checked
// separately.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "metron/machine/ipp/command_line.hpp"
#include "metron/machine/ipp/response_line.hpp"
#include "metron/machine/ipp/session.hpp"
#include "metron/machine/virtual_cmm.hpp"

using namespace metron;
using namespace metron::machine;
using namespace metron::machine::ipp;
namespace fs = std::filesystem;

namespace {

const fs::path k_dir = fs::path(METRON_SHARED_DATA) / "ippdme-conformance";

/// The lines of a .prg or .res file: `\\` separators, `:` end marks and blank lines dropped.
std::vector<std::string> records(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> out;
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (line.empty() || line == "\\\\" || line == ":") continue;
    out.push_back(line);
  }
  return out;
}

/// A data body's shape: top-level items sorted; calls by name and arity, numbers as N, strings
/// kept at the top level (tool and property names), as S inside calls.
std::string signature(const std::string& body) {
  auto args = parse_arguments(body);
  if (!args) return "?" + body;
  std::vector<std::string> items;
  bool all_numbers = true;
  for (const auto& a : *args) {
    all_numbers = all_numbers && a.is_number();
    switch (a.kind) {
      case Argument::Kind::Number: items.push_back("N"); break;
      case Argument::Kind::String: items.push_back('"' + a.text + '"'); break;
      case Argument::Kind::Name: items.push_back(a.text); break;
      case Argument::Kind::Empty: items.push_back(""); break;
      case Argument::Kind::Call: items.push_back(a.text + "/" + std::to_string(a.args.size())); break;
    }
  }
  if (all_numbers && !items.empty()) return "numbers";  // scan data: the count depends on the path
  std::sort(items.begin(), items.end());
  std::string s;
  for (const auto& i : items) s += i + ";";
  return s;
}

struct Step {
  std::string command;
  std::vector<std::string> expected;  ///< shapes of the response lines for this tag
  std::vector<std::string> actual;
};

/// One comparable description per response line: "&", "%", "# <signature>", "! <number>".
std::string shape(const ResponseLine& r) {
  switch (r.kind) {
    case ResponseLine::Kind::Ack: return "&";
    case ResponseLine::Kind::Complete: return "%";
    case ResponseLine::Kind::Data: return "# " + signature(r.body);
    case ResponseLine::Kind::Error: return "! " + std::to_string(r.error_number);
  }
  return "?";
}

/// Groups response lines by the command they answer (the first unanswered command with the
/// line's tag); daemon reports (an E tag that is not the command's own) and E0000 are dropped.
std::map<std::size_t, std::vector<std::string>> group(const std::vector<std::string>& commands,
                                                      const std::vector<std::string>& lines) {
  std::map<std::size_t, std::vector<std::string>> by_command;
  std::size_t next = 0;  // responses arrive in command order
  for (const auto& l : lines) {
    auto r = parse_response_line(l);
    if (!r || (r->tag.event && r->tag.number == 0)) continue;
    const std::string tag = r->tag.text();
    std::size_t k = next;
    while (k < commands.size() && commands[k].substr(0, 5) != tag) ++k;
    if (k == commands.size()) continue;  // a daemon's report under an earlier command's tag
    if (r->tag.event && r->kind == ResponseLine::Kind::Data && k != next) continue;
    by_command[k].push_back(shape(*r));
    if (r->kind == ResponseLine::Kind::Complete) next = std::max(next, k + 1);
  }
  return by_command;
}

struct FileResult {
  std::string name;
  std::size_t commands = 0, matched = 0;
  std::vector<std::string> differences;
};

World default_world_for_tests() { return machine::default_world(); }

/// The DCX stream is in the part's frame: the two lines the NIST CSYmover utility would add
/// place PartCsy where programs/worlds/nist_dcx_part.json puts the part.
const std::vector<std::string> k_dcx_csy{"00990 SetCsyTransformation(PartCsy, 355, 91, -80, 0, 180, 0)",
                                         "00991 SetCoordSystem(PartCsy)"};

FileResult replay(const std::string& name) {
  FileResult result{name, 0, 0, {}};
  const auto commands = records(k_dir / (name + ".prg"));
  const auto expected_lines = records(k_dir / (name + ".res"));
  const bool dcx = name == "DCXpart";
  World world = default_world_for_tests();
  if (dcx) world = *load_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/nist_dcx_part.json");
  VirtualCmm cmm(world, 1);
  SessionOptions options;
  options.home_mm = world.machine.home_mm;
  Session session(cmm, options);
  std::vector<std::string> actual_lines;
  for (std::size_t k = 0; k < commands.size(); ++k) {
    for (auto& l : session.handle(commands[k]).lines) actual_lines.push_back(std::move(l));
    if (dcx && k == 0)
      for (const auto& c : k_dcx_csy) session.handle(c);
  }
  const auto expected = group(commands, expected_lines);
  const auto actual = group(commands, actual_lines);
  result.commands = commands.size();
  for (std::size_t k = 0; k < commands.size(); ++k) {
    const auto e = expected.count(k) ? expected.at(k) : std::vector<std::string>{};
    const auto a = actual.count(k) ? actual.at(k) : std::vector<std::string>{};
    auto sorted = [](std::vector<std::string> v) {
      std::sort(v.begin(), v.end());
      return v;
    };
    if (e.empty() || sorted(e) == sorted(a)) {
      ++result.matched;  // no expected answer recorded: nothing to compare against
      continue;
    }
    std::string want, got;
    for (const auto& s : e) want += (want.empty() ? "" : " ") + s;
    for (const auto& s : a) got += (got.empty() ? "" : " ") + s;
    result.differences.push_back(commands[k] + "  expected [" + want + "] got [" + got + "]");
  }
  return result;
}

std::vector<std::string> conformance_files() {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(k_dir)) {
    if (e.path().extension() != ".prg") continue;
    const std::string stem = e.path().stem().string();
    if (fs::exists(k_dir / (stem + ".res"))) names.push_back(stem);
  }
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

TEST(IppConformance, NistFilesReplay) {
  ASSERT_TRUE(fs::exists(k_dir)) << k_dir;
  std::size_t commands = 0, matched = 0, files_full = 0;
  std::ostringstream table, details;
  table << "| file | commands | matched | differences |\n|---|---:|---:|---|\n";
  std::map<std::string, FileResult> results;
  for (const auto& name : conformance_files()) {
    const auto r = replay(name);
    results[name] = r;
    commands += r.commands;
    matched += r.matched;
    files_full += r.matched == r.commands;
    std::string first = r.differences.empty() ? "" : r.differences.front();
    for (char& c : first)
      if (c == '|') c = '/';
    table << "| " << name << " | " << r.commands << " | " << r.matched << " | " << first
          << (r.differences.size() > 1 ? " (+" + std::to_string(r.differences.size() - 1) + " more)" : "") << " |\n";
    for (const auto& d : r.differences) details << name << ": " << d << "\n";
  }
  table << "| **total** (" << results.size() << " files, " << files_full << " fully matched) | " << commands << " | "
        << matched << " | |\n";
  std::cout << table.str() << "\nall differences:\n" << details.str();
  if (const char* out = std::getenv("METRON_IPP_CONFORMANCE_TABLE"))
    std::ofstream(out) << table.str() << "\n" << details.str();
  RecordProperty("commands", static_cast<int>(commands));
  RecordProperty("matched", static_cast<int>(matched));
  // Regression floor (950 of 1213 measured 2026-11-30, 918 before the ScanIn... commands' argument
  // checks; most differences are the class-3 error state, docs/ipp-dme.md); the files below match
  // completely.
  EXPECT_GE(matched, 945u) << matched << " of " << commands;
  for (const char* f : {"StartSession",  "EndSession",     "ClearAllErrors",  "GetDMEVersion",   "IsHomed",
                        "Home",          "GetErrStatusE",  "GetXtdErrStatus", "EnableUser",      "DisableUser",
                        "IsUserEnabled", "GetCoordSystem", "SetCoordSystem",  "StopDaemon",      "AbortE",
                        "ChangeTool",    "FindTool",       "SetTool",         "ScanUnknownHint", "Error",
                        "Get",           "OnMoveReportE",  "OnPtMeasReport",  "numbersErrorCmd"})
    EXPECT_EQ(results[f].matched, results[f].commands)
        << f << ": " << (results[f].differences.empty() ? "" : results[f].differences[0]);
}

// parserCmdErrors.txt: what the NIST command parser answers for each malformed command. Each is
// sent to a fresh session (started, homed, Probe1) and its error number compared.
TEST(IppConformance, NistParserErrorNumbers) {
  std::ifstream in(k_dir / "parserCmdErrors.txt");
  std::vector<std::vector<std::string>> blocks(1);
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty())
      blocks.emplace_back();
    else
      blocks.back().push_back(line);
  }
  const World world = machine::default_world();
  int cases = 0, same = 0;
  std::ostringstream diffs;
  for (const auto& b : blocks) {
    if (b.size() < 3 || b.back().size() != 4 || b[0].find('(') == std::string::npos) continue;
    const int want = std::stoi(b.back());
    VirtualCmm cmm(world, 1);
    SessionOptions options;
    options.home_mm = world.machine.home_mm;
    Session s(cmm, options);
    for (const char* setup : {"00001 StartSession()", "00002 Home()", "00003 ChangeTool(\"Probe1\")"}) s.handle(setup);
    int got = 0;
    for (const auto& l : s.handle(b[0]).lines)
      if (auto r = parse_response_line(l); r && r->kind == ResponseLine::Kind::Error) got = r->error_number;
    ++cases;
    if (got == want)
      ++same;
    else
      diffs << b[0] << "  (" << b[1] << ")  NIST " << want << ", metron " << got << "\n";
  }
  std::cout << "parserCmdErrors: " << same << " of " << cases << " error numbers as NIST's parser\n" << diffs.str();
  if (const char* out = std::getenv("METRON_IPP_PARSER_TABLE"))
    std::ofstream(out) << same << " of " << cases << "\n" << diffs.str();
  RecordProperty("parser_cases", cases);
  RecordProperty("parser_same", same);
  EXPECT_GT(cases, 150);
  EXPECT_GE(same, 215) << same << " of "
                       << cases;  // 219 measured 2026-11-30 (188 before the ScanIn... and hint commands)
}

namespace {

/// The X, Y, Z of a PtMeas report body.
std::optional<Vec3> report_xyz(const std::string& body) {
  auto args = parse_arguments(body);
  if (!args) return std::nullopt;
  Vec3 p = Vec3::Constant(NAN);
  for (const auto& a : *args)
    for (int i = 0; i < 3; ++i)
      if (a.is_call(std::string(1, "XYZ"[i])) && a.call_number()) p[i] = *a.call_number();
  return p.allFinite() ? std::optional<Vec3>(p) : std::nullopt;
}

struct DcxPoint {
  std::string tag;
  Vec3 nominal, normal, recorded, replayed;
};

}  // namespace

// The DCX part's recorded stream (nist-dcx-part/DCXpart.prg) replayed against the DCX world
// (programs/worlds/nist_dcx_part.json). The stream is in the part's frame (origin at the bottom
// of the centre hole); as the NIST CSYmover utility would, two lines after StartSession place
// PartCsy where the world puts the part: machine = Rz(180) p + (355, 91, -80).
// X, Y, Z in PtMeas are ball centres (the stream's nominals are the CAD surface + ER along IJK).
TEST(IppConformance, DcxPartReplay) {
  const fs::path dir = fs::path(METRON_SHARED_DATA) / "nist-dcx-part";
  auto world = load_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/nist_dcx_part.json");
  ASSERT_TRUE(world) << world.error().message;
  VirtualCmm cmm(*world, 1);
  SessionOptions options;
  options.home_mm = world->machine.home_mm;
  Session session(cmm, options);
  auto commands = records(dir / "DCXpart.prg");
  commands.insert(commands.begin() + 1, k_dcx_csy.begin(), k_dcx_csy.end());
  std::map<std::string, std::string> replayed, recorded;
  std::vector<std::string> faults;  // tags answered with an error; a client clears and goes on
  for (const auto& c : commands) {
    bool failed = false;
    for (const auto& l : session.handle(c).lines) {
      auto r = parse_response_line(l);
      ASSERT_TRUE(r) << l;
      if (r->kind == ResponseLine::Kind::Error) {
        faults.push_back(r->tag.text());
        failed = true;
        std::cout << "fault: " << c << "\n    -> " << l << "\n";
      }
      if (r->kind == ResponseLine::Kind::Data && !r->tag.event) replayed[r->tag.text()] = r->body;
    }
    if (failed) session.handle("09990 ClearAllErrors()");
  }
  for (const auto& l : records(dir / "DCXpart.res"))
    if (auto r = parse_response_line(l); r && r->kind == ResponseLine::Kind::Data && !r->tag.event)
      recorded[r->tag.text()] = r->body;
  std::vector<DcxPoint> points;
  for (const auto& c : commands) {
    auto parsed = parse_command_line(c);
    if (!parsed || parsed->name != "PtMeas") continue;
    DcxPoint p;
    p.tag = parsed->tag.text();
    for (const auto& a : parsed->args) {
      for (int i = 0; i < 3; ++i)
        if (a.is_call(std::string(1, "XYZ"[i]))) p.nominal[i] = *a.call_number();
      if (a.is_call("IJK")) p.normal = Vec3(a.args[0].number, a.args[1].number, a.args[2].number).normalized();
    }
    const auto rec = report_xyz(recorded[p.tag]);
    const auto rep = report_xyz(replayed[p.tag]);
    ASSERT_TRUE(rec) << p.tag;
    if (!rep) continue;  // a fault (checked below)
    p.recorded = *rec;
    p.replayed = *rep;
    points.push_back(p);
  }
  // Two commands fault, both rightly: 00221 asks for IJK(1,0,0) at the +X side of the small
  // hole (the normal points into the material, the approach start lies in the wall; the recorded
  // answer says IJK(-1,0,0): the stream was edited); 00287 moves at 4 mm retract height past a
  // feature of the exact CAD part that the real part, standing 0.6 mm lower, cleared.
  EXPECT_EQ(faults, (std::vector<std::string>{"00221", "00287"}));
  ASSERT_EQ(points.size(), 54u);
  // Replayed against the CAD truth: each latched centre lies on the nominal (CAD surface + ER).
  // Recorded against replayed: the real part stood elsewhere; per face group the offset along
  // the normal is common, and what remains is the real part's form and the real probe's noise.
  std::ostringstream table;
  table << "| points | replayed - nominal, along IJK, max [mm] | recorded - replayed along IJK, mean [mm] | spread "
           "about the mean (max) [mm] |\n|---|---:|---:|---:|\n";
  double worst_truth = 0;
  // Feature groups: consecutive points with the same normal (planes), or the 8 of a hole.
  std::vector<std::pair<std::size_t, std::size_t>> groups;
  for (std::size_t k = 0; k < points.size();) {
    const bool hole = std::abs(points[k].nominal.x()) < 16 && std::abs(points[k].nominal.y()) < 16;
    std::size_t e = k + 1;
    while (e < points.size() &&
           (hole ? std::abs(points[e].nominal.x()) < 16 && std::abs(points[e].nominal.y()) < 16 &&
                       std::abs(points[e].nominal.head<2>().norm() - points[k].nominal.head<2>().norm()) < 1
                 : points[e].normal.dot(points[k].normal) > 0.99))
      ++e;
    groups.emplace_back(k, e);
    k = e;
  }
  for (const auto& [g, e] : groups) {
    const double n = static_cast<double>(e - g);
    double max_truth = 0, mean = 0, spread = 0;
    for (std::size_t k = g; k < e; ++k) {
      max_truth = std::max(max_truth, std::abs((points[k].replayed - points[k].nominal).dot(points[k].normal)));
      mean += (points[k].recorded - points[k].replayed).dot(points[k].normal) / n;
    }
    for (std::size_t k = g; k < e; ++k)
      spread = std::max(spread, std::abs((points[k].recorded - points[k].replayed).dot(points[k].normal) - mean));
    worst_truth = std::max(worst_truth, max_truth);
    table << "| " << points[g].tag << ".." << points[e - 1].tag << " (" << e - g << ") | "
          << format_number(max_truth, 4) << " | " << format_number(mean, 4) << " | " << format_number(spread, 4)
          << " |\n";
  }
  std::cout << table.str();
  if (const char* out = std::getenv("METRON_IPP_DCX_TABLE")) std::ofstream(out) << table.str();
  // Stated tolerance: after each feature's common offset (the real part's placement and size),
  // the recorded and replayed points agree within 0.3 mm along the normal.
  for (const auto& [g, e] : groups) {
    double mean = 0;
    for (std::size_t k = g; k < e; ++k)
      mean += (points[k].recorded - points[k].replayed).dot(points[k].normal) / static_cast<double>(e - g);
    for (std::size_t k = g; k < e; ++k)
      EXPECT_LT(std::abs((points[k].recorded - points[k].replayed).dot(points[k].normal) - mean), 0.3) << points[k].tag;
  }
  // The world's probe: 10 um pre-travel, 0.2 um repeatability, 4 ms delay at 4 mm/s.
  EXPECT_LT(worst_truth, 0.05);
}
