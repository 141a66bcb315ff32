// SPDX-License-Identifier: GPL-3.0-or-later
// End to end: programs run on worlds whose truth is known; metron must recover it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli/virtual_cmm_backend.hpp"
#include "fixtures.hpp"
#include "metron/interpreter/session.hpp"

namespace {

namespace fs = std::filesystem;
using metron::interpreter::run_program;
using metron::interpreter::RunExit;
using metron::interpreter::RunOptions;
using metron::runtime::FeatureReport;
using metron::runtime::ToleranceResult;

const fs::path source_dir = METRON_SOURCE_DIR;
fs::path out_dir(const std::string& name) { return metron::test_support::out_dir("metron_e2e", name); }

// A file's whole text (a program, an output file); empty when it cannot be read.
std::string file_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

metron::interpreter::RunOutcome run(const fs::path& program, const std::optional<fs::path>& world,
                                    const std::string& out, std::optional<std::uint64_t> seed = std::nullopt,
                                    bool strict = false) {
  RunOptions o;
  o.program = program.string();
  if (world) o.world_path = world->string();
  o.seed = seed;
  o.strict = strict;
  o.out_dir = out_dir(out).string();
  return run_program(o, metron::cli::virtual_cmm_backend);
}

// The last OUTPUT report of a feature / a tolerance result.
const FeatureReport* report(const metron::runtime::RunRecord& r, const std::string& label) {
  const FeatureReport* found = nullptr;
  for (const auto& e : r.events)
    if (const auto* f = std::get_if<FeatureReport>(&e); f && f->label == label) found = f;
  return found;
}
const ToleranceResult* tolerance(const metron::runtime::RunRecord& r, const std::string& label) {
  for (const auto& e : r.events)
    if (const auto* t = std::get_if<ToleranceResult>(&e); t && t->label == label) return t;
  return nullptr;
}

fs::path program(const std::string& name) { return source_dir / "programs" / "examples" / name; }
fs::path world(const std::string& name) { return source_dir / "programs" / "worlds" / name; }

TEST(EndToEnd, FirstCircleOnTheDefaultWorld) {
  const auto o = run(program("01_first_circle.dmi"), std::nullopt, "first");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const auto* f = report(o.record, "BORE1");
  ASSERT_TRUE(f && f->actual);
  // Default world: a perfect block with 0.2 um probe repeatability.
  EXPECT_NEAR(f->actual->diameter_mm, 20.0, 0.001);
  EXPECT_NEAR(f->actual->position.x(), 40.0, 0.001);
  EXPECT_NEAR(f->actual->position.y(), 50.0, 0.001);
  ASSERT_TRUE(fs::exists(o.results_path));
  const auto j = nlohmann::json::parse(std::ifstream(o.results_path));
  EXPECT_EQ(j["status"], "completed");
  ASSERT_FALSE(j["features"].empty());
  EXPECT_EQ(j["features"][0]["points"].size(), 4u);
  EXPECT_TRUE(j["features"][0]["points"][0].contains("approach"));
}

TEST(EndToEnd, PerfectPartIsRecoveredWithinATenthOfAMicrometre) {
  const auto o = run(program("02_block_inspection.dmi"), world("perfect.json"), "perfect");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const double bar = 1e-4;
  const auto* b1 = report(o.record, "BORE1");
  ASSERT_TRUE(b1 && b1->actual);
  EXPECT_NEAR(b1->actual->diameter_mm, 20.0, bar);
  EXPECT_NEAR(b1->actual->position.x(), 40.0, bar);
  EXPECT_NEAR(b1->actual->position.y(), 50.0, bar);
  const auto* b2 = report(o.record, "BORE2");
  ASSERT_TRUE(b2 && b2->actual);
  EXPECT_NEAR(b2->actual->diameter_mm, 12.0, bar);
  const auto* boss = report(o.record, "BOSS1");
  ASSERT_TRUE(boss && boss->actual);
  EXPECT_NEAR(boss->actual->diameter_mm, 24.0, bar);
  const auto* sph = report(o.record, "SPHERE1");
  ASSERT_TRUE(sph && sph->actual);
  EXPECT_NEAR(sph->actual->diameter_mm, 20.0, bar);
  EXPECT_NEAR((sph->actual->position - metron::Vec3(75, 75, 48)).norm(), 0.0, bar);
  const auto* cone = report(o.record, "CSINK");
  ASSERT_TRUE(cone && cone->actual);
  EXPECT_NEAR(cone->actual->apex_angle_deg, 90.0, 1e-3);
  EXPECT_NEAR((cone->actual->position - metron::Vec3(40, 20, 32)).norm(), 0.0, bar);
  const auto* corner = report(o.record, "CORNER");
  ASSERT_TRUE(corner && corner->actual);
  EXPECT_NEAR((corner->actual->position - metron::Vec3(0, 0, 40)).norm(), 0.0, bar);
}

TEST(EndToEnd, HiddenDeviationsAreRecovered) {
  // block_deviations.json hides: BORE1 +0.012 mm oversize and 0.03 mm off in x; the TOP face
  // tilted 0.05 deg; a 3-lobe 5 um form on BOSS1.
  const auto o = run(program("02_block_inspection.dmi"), world("block_deviations.json"), "deviations");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const auto* b1 = report(o.record, "BORE1");
  ASSERT_TRUE(b1 && b1->actual);
  EXPECT_NEAR(b1->actual->diameter_mm - 20.0, 0.012, 0.001);
  EXPECT_NEAR(b1->actual->position.x() - 40.0, 0.030, 0.002);
  // Datum A is tilted 0.05 deg about x, the bore is vertical in the machine: relative to the datum
  // frame its axis leans, and at the reported height (z = 40) it sits (40 - 22.5) tan(0.05 deg) off
  // in y, 22.5 being the mean height of the FRONT face points that fix the y origin.
  const double lean = (40.0 - 22.5) * std::tan(0.05 * std::numbers::pi / 180.0);
  EXPECT_NEAR(std::abs(b1->actual->position.y() - 50.0), lean, 0.002);
  const auto* pos = tolerance(o.record, "POS_BORE1");
  ASSERT_TRUE(pos);
  EXPECT_NEAR(pos->value, 2.0 * std::hypot(0.030, lean), 0.004);  // diametral zone
  EXPECT_FALSE(pos->in_tolerance);                                // zone 0.05
  const auto* d1 = tolerance(o.record, "D_BORE1");
  ASSERT_TRUE(d1);
  EXPECT_TRUE(d1->in_tolerance);  // +0.012 within [-0.010, +0.020]
  const auto* top = report(o.record, "TOP");
  ASSERT_TRUE(top && top->actual);
  const double tilt_deg = std::acos(std::abs(top->actual->direction.normalized().z())) * 180.0 / std::numbers::pi;
  EXPECT_NEAR(tilt_deg, 0.05, 0.003);
  // The bore is vertical in the machine; against the tilted datum A it leans 0.05 deg over 20 mm.
  const auto* perp = tolerance(o.record, "PERP_BORE1");
  ASSERT_TRUE(perp);
  EXPECT_NEAR(perp->value, 20.0 * std::sin(0.05 * std::numbers::pi / 180.0), 0.002);
  const auto* boss = report(o.record, "BOSS1");
  ASSERT_TRUE(boss && boss->fit);
  // 8 points a section see the 3 lobes: peak to valley close to 2 x 5 um.
  EXPECT_GT(boss->fit->form_mm, 0.008) << "the 3-lobe form of 5 um amplitude must show in the cylindricity";
  EXPECT_LT(boss->fit->form_mm, 0.0105);
}

TEST(EndToEnd, FaultStopsTheRunKeepsEarlierResultsAndNamesTheStatement) {
  const fs::path p = out_dir("fault") / "collide.dmi";
  std::ofstream(p) << "DMISMN/'collide', 5.0\nUNITS/MM, ANGDEC\n"
                      "S(P) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4\nSNSLCT/S(P)\n"
                      "D(F) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
                      "F(TOP) = FEAT/PLANE, CART, 80, 50, 40, 0, 0, 1\nGOTO/20, 20, 60\n"
                      "MEAS/PLANE, F(TOP), 3\nPTMEAS/CART, 10, 10, 40, 0, 0, 1\nPTMEAS/CART, 150, 10, 40, 0, 0, 1\n"
                      "PTMEAS/CART, 150, 90, 40, 0, 0, 1\nENDMES\nOUTPUT/FA(TOP)\n"
                      "GOTO/80, 50, 20\n"  // straight down into the block: a collision
                      "OUTPUT/FA(TOP)\nENDFIL\n";
  const auto o = run(p, std::nullopt, "fault");
  EXPECT_EQ(o.exit, RunExit::Faulted);
  const metron::runtime::FaultReport* fault = nullptr;
  for (const auto& e : o.record.events)
    if (const auto* f = std::get_if<metron::runtime::FaultReport>(&e)) fault = f;
  ASSERT_TRUE(fault);
  EXPECT_EQ(fault->kind, "collision");
  EXPECT_EQ(fault->statement.line, 14u);
  EXPECT_EQ(fault->statement_text, "GOTO/80, 50, 20");
  ASSERT_TRUE(report(o.record, "TOP"));  // the output before the fault is kept
  const auto j = nlohmann::json::parse(std::ifstream(o.results_path));
  EXPECT_EQ(j["status"], "faulted");
}

TEST(EndToEnd, NoContactWithinTheSearchDistanceIsAFault) {
  const fs::path p = out_dir("nocontact") / "air.dmi";
  std::ofstream(p) << "DMISMN/'air', 5.0\nUNITS/MM, ANGDEC\nS(P) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4\n"
                      "SNSLCT/S(P)\nF(X) = FEAT/POINT, CART, 100, 100, 100, 0, 0, 1\n"
                      "MEAS/POINT, F(X), 1\nPTMEAS/CART, 100, 100, 100, 0, 0, 1\nENDMES\nENDFIL\n";
  const auto o = run(p, std::nullopt, "nocontact");
  EXPECT_EQ(o.exit, RunExit::Faulted);
  bool found = false;
  for (const auto& e : o.record.events)
    if (const auto* f = std::get_if<metron::runtime::FaultReport>(&e)) {
      found = true;
      EXPECT_EQ(f->kind, "no contact");
      EXPECT_EQ(f->statement.line, 7u);
    }
  EXPECT_TRUE(found);
}

TEST(EndToEnd, SameSeedSameResultsDifferentSeedDifferentNoise) {
  const auto slurp = [](const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    auto j = nlohmann::json::parse(ss.str());
    return j["features"].dump();
  };
  const auto a = run(program("01_first_circle.dmi"), std::nullopt, "seed_a", 7);
  const auto b = run(program("01_first_circle.dmi"), std::nullopt, "seed_b", 7);
  const auto c = run(program("01_first_circle.dmi"), std::nullopt, "seed_c", 8);
  EXPECT_EQ(slurp(a.results_path), slurp(b.results_path));
  EXPECT_NE(slurp(a.results_path), slurp(c.results_path));
}

std::pair<int, std::string> shell(const std::string& command) {
  std::string out;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  char buf[4096];
  while (pipe && std::fgets(buf, sizeof buf, pipe)) out += buf;
  const int status = pipe ? ::pclose(pipe) : -1;
  return {WEXITSTATUS(status), out};
}

// POS to datums A|B|C is evaluated in the frame the datums build, whether or not the program
// aligned to them first. The block is misplaced on the table (block_misplaced.json) and its bore
// is made 0.03 mm off along X in the part frame (block_deviations.json): the hidden truth is a
// 2D position deviation of 0.06 mm (plus what the 0.05 deg tilt of face A adds, under 0.01 mm).
TEST(DatumReferenceFrame, PositionToDatumsDoesNotDependOnTheProgramsAlignment) {
  std::string unaligned = file_text(program("02_block_inspection.dmi"));
  // The same program without its part alignment: everything stays in the fixture's frame, where
  // the misplaced part is 0.3 mm off, and a POS without datums is added to show it.
  for (const std::string line : {"D(DATUMS) = DATSET/DAT(A), ZDIR, ZORIG, DAT(B), YMINUS, YORIG, DAT(C), XORIG\n",
                                 "D(PART) = TRANS/ZORIG, -40\n", "SAVE/DA(PART)\n"}) {
    const auto at = unaligned.find(line);
    ASSERT_NE(at, std::string::npos) << line;
    unaligned.erase(at, line.size());
  }
  const std::string bare_pos = "T(POS_BARE) = TOL/POS, 2D, 0.050, RFS\n";
  unaligned.insert(unaligned.find("T(POS_BORE1)"), bare_pos);
  const std::string output = "OUTPUT/FA(BORE1), TA(D_BORE1), TA(POS_BORE1)";
  unaligned.insert(unaligned.find(output) + output.size(), ", TA(POS_BARE)");
  const fs::path dir = out_dir("drf_program");
  fs::create_directories(dir);
  const fs::path variant = dir / "02_unaligned.dmi";
  std::ofstream(variant) << unaligned;

  const auto aligned_run = run(program("02_block_inspection.dmi"), world("block_misplaced.json"), "drf_aligned", 7);
  const auto unaligned_run = run(variant, world("block_misplaced.json"), "drf_unaligned", 7);
  ASSERT_EQ(aligned_run.exit, RunExit::Completed) << aligned_run.diagnostics;
  ASSERT_EQ(unaligned_run.exit, RunExit::Completed) << unaligned_run.diagnostics;
  const auto* with_alignment = tolerance(aligned_run.record, "POS_BORE1");
  const auto* without_alignment = tolerance(unaligned_run.record, "POS_BORE1");
  const auto* bare = tolerance(unaligned_run.record, "POS_BARE");
  ASSERT_TRUE(with_alignment && without_alignment && bare);
  EXPECT_NEAR(with_alignment->value, 0.06, 0.01);
  EXPECT_NEAR(without_alignment->value, 0.06, 0.01);
  // The two programs probe the bore at points 0.3 mm apart: the same bore to the probe's noise.
  EXPECT_NEAR(without_alignment->value, with_alignment->value, 0.003);
  EXPECT_GT(bare->value, 0.2) << "without datums the misplacement shows";
  std::printf("POS_BORE1 aligned %.4f, unaligned %.4f, without datums %.4f\n", with_alignment->value,
              without_alignment->value, bare->value);
  EXPECT_NE(without_alignment->note.find("datum reference frame A|B|C"), std::string::npos);
}

// LOCATE against the world's hidden pose: example 09 measures the block where the fixture should
// hold it (FIXTURE); block_turned.json put it 1.2, -0.6, 0.3 mm away, tilted 0.05 and -0.03 deg
// and turned 0.8 deg. The best fit of the top face, two circles and the sphere must give that pose
// back, and BORE2, measured after it, its drawing position; in FIXTURE the same bore is where the
// pose puts it (computed here from the world's numbers), nearly 1.3 mm away.
namespace best_fit {

// An example program's text, to run it changed.
std::string example_text(const std::string& name) { return file_text(program(name)); }

std::string example09() { return example_text("09_best_fit_locate.dmi"); }

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

fs::path written(const std::string& name, const std::string& text) {
  const fs::path dir = out_dir("best_fit_programs");
  fs::create_directories(dir);
  std::ofstream(dir / name) << text;
  return dir / name;
}

// The world's pose (machine/src/world.cpp: T, then Rz, Ry, Rx).
metron::Frame world_pose() {
  constexpr double k = std::numbers::pi / 180;
  metron::Frame f = metron::Frame::Identity();
  f.translate(Eigen::Vector3d(301.2, 199.4, 0.3));
  f.rotate(Eigen::AngleAxisd(0.8 * k, Eigen::Vector3d::UnitZ()));
  f.rotate(Eigen::AngleAxisd(-0.03 * k, Eigen::Vector3d::UnitY()));
  f.rotate(Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d::UnitX()));
  return f;
}

// Where the examples' FIXTURE alignment puts the part: (300, 200, 0), not turned.
metron::Frame fixture_frame() {
  metron::Frame f = metron::Frame::Identity();
  f.translate(Eigen::Vector3d(300, 200, 0));
  return f;
}

// The frame an OUTPUT/D(label) line reports: "D(label): origin (x, y, z) mm, X axis (..), Y axis
// (..), Z axis (..) in machine coordinates".
std::optional<metron::Frame> reported_frame(const std::string& texts, const std::string& label) {
  const auto at = texts.find("D(" + label + "): origin (");
  if (at == std::string::npos) return std::nullopt;
  std::vector<double> v;
  const std::size_t line_end = texts.find('\n', at);
  // The numbers are those between the parentheses after the label, comma-separated.
  for (std::size_t open = texts.find('(', at + label.size() + 3); open < line_end; open = texts.find('(', open + 1)) {
    std::stringstream group(texts.substr(open + 1, texts.find(')', open) - open - 1));
    for (std::string number; std::getline(group, number, ',');) v.push_back(std::stod(number));
  }
  if (v.size() != 12) return std::nullopt;
  metron::Frame f = metron::Frame::Identity();
  f.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  for (int k = 0; k < 3; ++k) f.linear().col(k) = Eigen::Vector3d(v[3 + 3 * k], v[4 + 3 * k], v[5 + 3 * k]);
  return f;
}

std::string texts(const metron::runtime::RunRecord& r) {
  std::string all;
  for (const auto& e : r.events)
    if (const auto* t = std::get_if<metron::runtime::TextReport>(&e)) all += t->text + "\n";
  return all;
}

}  // namespace best_fit

TEST(BestFitAlignment, LocateFindsThePoseTheWorldHides) {
  const auto o = run(program("09_best_fit_locate.dmi"), world("block_turned.json"), "locate_turned");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const metron::Frame pose = best_fit::world_pose();
  const std::string origin = fmt::format("D(BEST): origin ({:.4f}, {:.4f}, {:.4f}) mm", pose.translation().x(),
                                         pose.translation().y(), pose.translation().z());
  EXPECT_NE(best_fit::texts(o.record).find(origin), std::string::npos) << best_fit::texts(o.record) << origin;
  EXPECT_NE(o.diagnostics.find("turned 0.0500, -0.0300, 0.8000 deg about FIXTURE's X, Y, Z"), std::string::npos)
      << o.diagnostics;
  const auto* bore = report(o.record, "BORE2");
  ASSERT_TRUE(bore && bore->actual);
  EXPECT_EQ(bore->frame, "BEST");
  EXPECT_LT((bore->actual->position.head<2>() - Eigen::Vector2d(120, 30)).norm(), 1e-3);

  // Without LOCATE the bore is reported in FIXTURE, where the pose puts it.
  const std::string without = best_fit::replaced(
      best_fit::example09(), "D(BEST) = LOCATE/FA(TOP), FA(BORE1), FA(BOSS1), FA(SPHERE1)\nOUTPUT/D(BEST)\n", "");
  const auto unlocated = run(best_fit::written("09_no_locate.dmi", without), world("block_turned.json"), "locate_none");
  ASSERT_EQ(unlocated.exit, RunExit::Completed) << unlocated.diagnostics;
  const auto* fixture_bore = report(unlocated.record, "BORE2");
  ASSERT_TRUE(fixture_bore && fixture_bore->actual);
  const Eigen::Vector3d where = best_fit::fixture_frame().inverse() * pose * Eigen::Vector3d(120, 30, 30);
  EXPECT_LT((fixture_bore->actual->position.head<2>() - where.head<2>()).norm(), 2e-3);
  EXPECT_GT((where.head<2>() - Eigen::Vector2d(120, 30)).norm(), 1.0);
}

// LOCATE/XDIR, YDIR, ZAXIS: the fit moves in the table's plane only; the 0.3 mm lift and the
// tilt stay out of the frame (the top face, reported after it, is 0.3 mm high; with all six
// freedoms it is at its drawing height).
TEST(BestFitAlignment, LocateMovesOnlyAlongAndAboutTheAxesWritten) {
  const std::string six = best_fit::replaced(best_fit::example09(), "OUTPUT/D(BEST)\n", "OUTPUT/FA(TOP)\n");
  const std::string planar = best_fit::replaced(six, "LOCATE/FA(TOP)", "LOCATE/XDIR, YDIR, ZAXIS, FA(TOP)");
  const auto all = run(best_fit::written("09_six.dmi", six), world("block_turned.json"), "locate_six");
  const auto flat = run(best_fit::written("09_planar.dmi", planar), world("block_turned.json"), "locate_planar");
  ASSERT_EQ(all.exit, RunExit::Completed) << all.diagnostics;
  ASSERT_EQ(flat.exit, RunExit::Completed) << flat.diagnostics;
  const auto* top_six = report(all.record, "TOP");
  const auto* top_flat = report(flat.record, "TOP");
  ASSERT_TRUE(top_six && top_six->actual && top_flat && top_flat->actual);
  EXPECT_NEAR(top_six->actual->position.z(), 40.0, 1e-3);
  // The top face's centroid (80, 50, 40) lifted 0.3 mm and tilted: + 50 sin 0.05 deg + 80 sin 0.03 deg.
  constexpr double k = std::numbers::pi / 180;
  EXPECT_NEAR(top_flat->actual->position.z(), 40.3 + 50 * std::sin(0.05 * k) + 80 * std::sin(0.03 * k), 0.005);
  const std::string turned = "mm and turned 0.0000, 0.0000, ";
  const auto at = flat.diagnostics.find(turned);
  ASSERT_NE(at, std::string::npos) << flat.diagnostics;
  EXPECT_NEAR(std::stod(flat.diagnostics.substr(at + turned.size())), 0.8, 0.01);
  EXPECT_NE(flat.diagnostics.find(", 0.0000 mm and turned"), std::string::npos) << flat.diagnostics;
}

// On a part with a deviation the fit spreads it: block_deviations.json's BORE1 is 0.030 off in x,
// BORE2 is not. Fitted in the table's plane (XDIR, YDIR, ZAXIS) the two centres cannot change
// their distance, so the part of the 0.030 along the line joining them, 0.030 x 80 / |(80, -20)|,
// is left split equally: 0.01455 at each, and the residuals' RMS over the six components
// 0.01455 sqrt(2 / 6).
TEST(BestFitAlignment, LocateSpreadsAMisplacedBoreOverThePattern) {
  const std::string text =
      "DMISMN/'locate spread', 5.0\nUNITS/MM, ANGDEC\n"
      "S(PROBE4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(PROBE4)\n"
      "SNSET/APPRCH, 3\nSNSET/RETRCT, 3\nSNSET/SEARCH, 5\nSNSET/CLRSRF, 10\nMODE/AUTO\n"
      "D(FIXTURE) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/40, 50, 80\n"
      "F(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\nMEAS/CIRCLE, F(BORE1), 8\nENDMES\n"
      "F(BORE2) = FEAT/CIRCLE, INNER, CART, 120, 30, 30, 0, 0, 1, 12\nMEAS/CIRCLE, F(BORE2), 8\nENDMES\n"
      "D(PATTERN) = LOCATE/XDIR, YDIR, ZAXIS, FA(BORE1), FA(BORE2)\nENDFIL\n";
  const auto o = run(best_fit::written("spread.dmi", text), world("block_deviations.json"), "locate_spread");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const double split = 0.5 * 0.030 * 80 / std::hypot(80.0, 20.0);
  const auto number_after = [&](const std::string& words) {
    const auto at = o.diagnostics.find(words);
    EXPECT_NE(at, std::string::npos) << o.diagnostics;
    return at == std::string::npos ? -1.0 : std::stod(o.diagnostics.substr(at + words.size()));
  };
  EXPECT_NEAR(number_after("the largest "), split, 5e-4) << o.diagnostics;
  EXPECT_NEAR(number_after("residual RMS "), split * std::sqrt(2.0 / 6.0), 5e-4) << o.diagnostics;
}

// A constructed point is known whole, not only along its vector as a probed surface point is:
// example 02's corner (the intersection of the top, front and left faces, measured in FIXTURE on
// block_turned.json) alone fixes LOCATE's three translations, by where the world's pose puts the
// drawing's (0, 0, 40).
TEST(BestFitAlignment, AConstructedCornerFixesItsWholePosition) {
  const auto o =
      run(best_fit::written("02_corner.dmi",
                            best_fit::replaced(file_text(program("02_block_inspection.dmi")), "OUTPUT/FA(CORNER)\n",
                                               "OUTPUT/FA(CORNER)\nD(BF) = LOCATE/XDIR, YDIR, ZDIR, FA(CORNER)\n")),
          world("block_turned.json"), "locate_corner");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const Eigen::Vector3d corner(0, 0, 40);
  const Eigen::Vector3d moved = best_fit::world_pose() * corner - best_fit::fixture_frame() * corner;
  const std::string said =
      fmt::format("LOCATE D(BF): 1 features fitted; moved {:.4f}, {:.4f}, {:.4f} mm", moved.x(), moved.y(), moved.z());
  EXPECT_NE(o.diagnostics.find(said), std::string::npos) << o.diagnostics << said;
}

// A plane constructed from three probed points (CONST/PLANE,BF) has no points of its own; its
// direction weighs in the fit by how far its sources spread (Feature::construction_spread_mm). With
// two bores it fixes the tilt LOCATE finds: the world's pose (1.2, -0.6, 0.3 mm; 0.05, -0.03, 0.8
// deg), BORE2 at its drawing position. Counted as a position alone, the tilt is not fixed and
// LOCATE is an error.
TEST(BestFitAlignment, AConstructedPlaneFixesTheTilt) {
  const std::string example = best_fit::example09();
  const auto top = example.find("F(TOP) = FEAT/PLANE");
  const auto bore = example.find("F(BORE1) =");
  ASSERT_TRUE(top != std::string::npos && bore != std::string::npos);
  std::string text = example.substr(0, top);
  for (const char* p : {"T1", "T2", "T3"}) {
    const std::string at = std::string(p) == "T1" ? "10, 10" : std::string(p) == "T2" ? "150, 10" : "80, 90";
    text += fmt::format(
        "F({0}) = FEAT/POINT, CART, {1}, 40, 0, 0, 1\nMEAS/POINT, F({0}), 1\n"
        "  PTMEAS/CART, {1}, 40, 0, 0, 1\nENDMES\n",
        p, at);
  }
  text +=
      "GOTO/80, 90, 80\nGOTO/40, 50, 80\nF(TOP) = FEAT/PLANE, CART, 80, 36.6667, 40, 0, 0, 1\n"
      "CONST/PLANE, F(TOP), BF, FA(T1), FA(T2), FA(T3)\n" +
      example.substr(bore);
  text = best_fit::replaced(text, "LOCATE/FA(TOP), FA(BORE1), FA(BOSS1), FA(SPHERE1)",
                            "LOCATE/FA(TOP), FA(BORE1), FA(BOSS1)");
  const auto o = run(best_fit::written("09_constructed_top.dmi", text), world("block_turned.json"), "locate_cplane");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  EXPECT_NE(o.diagnostics.find("moved 1.2000, -0.6000, 0.3000 mm and turned 0.0500, -0.0300, 0.8000 deg"),
            std::string::npos)
      << o.diagnostics;
  const auto* bore2 = report(o.record, "BORE2");
  ASSERT_TRUE(bore2 && bore2->actual);
  EXPECT_LT((bore2->actual->position - Eigen::Vector3d(120, 30, 30)).norm(), 1e-3);
}

// ITERAT against the same hidden pose (example 10): six surface points, three of them on bore walls,
// where a point probed in the wrong place is also off along its vector, so one 3-2-1 fit leaves the
// frame off; fitted again after each new measurement the frame settles on the world's pose and
// BORE2 on its drawing position. Limited to one fit (the one-shot 3-2-1 alignment, the baseline),
// BORE2 is a tenth of a millimetre and more away and a warning says the test was not met; INCR
// (the fit's own motion as the test) settles as ABSL does.
TEST(BestFitAlignment, IteratMeasuresAgainUntilTheAlignmentSettles) {
  const std::string text = file_text(program("10_iterative_alignment.dmi"));
  const std::string iterat = "(REDO), 0.0005, 10, ABSL";
  const auto settled = run(program("10_iterative_alignment.dmi"), world("block_turned.json"), "iterat_settled");
  const auto once = run(best_fit::written("10_once.dmi", best_fit::replaced(text, iterat, "(REDO), 0.0005, 1")),
                        world("block_turned.json"), "iterat_once");
  const auto incr = run(best_fit::written("10_incr.dmi", best_fit::replaced(text, iterat, "(REDO), 0.0005, 10, INCR")),
                        world("block_turned.json"), "iterat_incr");
  for (const auto* o : {&settled, &once, &incr}) ASSERT_EQ(o->exit, RunExit::Completed) << o->diagnostics;

  const metron::Frame pose = best_fit::world_pose();
  const std::string origin = fmt::format("D(ITER): origin ({:.4f}, {:.4f}, {:.4f}) mm", pose.translation().x(),
                                         pose.translation().y(), pose.translation().z());
  EXPECT_NE(best_fit::texts(settled.record).find(origin), std::string::npos) << best_fit::texts(settled.record);
  const auto fits = [](const std::string& d) {
    std::size_t n = 0;
    for (auto at = d.find("note: ITERAT D(ITER)"); at != std::string::npos; at = d.find("note: ITERAT D(ITER)", at + 1))
      ++n;
    return n;
  };
  EXPECT_GT(fits(settled.diagnostics), 2U) << settled.diagnostics;
  EXPECT_EQ(fits(once.diagnostics), 1U);
  EXPECT_GT(fits(incr.diagnostics), 2U);
  // INCR's first test is how far the first fit moves the six points' nominals from where FIXTURE
  // put them. The one-fit run reports that first fit (OUTPUT/D(ITER): origin and axes): the
  // test's number is computed here from it.
  const std::string moves = "this fit moves the features' nominals at most ";
  const auto first = incr.diagnostics.find(moves);
  ASSERT_NE(first, std::string::npos) << incr.diagnostics;
  const auto first_fit = best_fit::reported_frame(best_fit::texts(once.record), "ITER");
  ASSERT_TRUE(first_fit) << best_fit::texts(once.record);
  double first_motion = 0;
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(10, 10, 40), Eigen::Vector3d(150, 10, 40), Eigen::Vector3d(80, 90, 40),
        Eigen::Vector3d(30, 50, 30), Eigen::Vector3d(114, 30, 30), Eigen::Vector3d(40, 40, 30)})
    first_motion = std::max(first_motion, (*first_fit * p - best_fit::fixture_frame() * p).norm());
  EXPECT_NEAR(std::stod(incr.diagnostics.substr(first + moves.size())), first_motion, 2e-3) << incr.diagnostics;
  EXPECT_NE(once.diagnostics.find("warning: ITERAT D(ITER): not within 0.0005 after 1 fits"), std::string::npos)
      << once.diagnostics;

  const auto bore_error = [](const metron::interpreter::RunOutcome& o) {
    const auto* bore = report(o.record, "BORE2");
    EXPECT_TRUE(bore && bore->actual && bore->frame == "ITER");
    return bore && bore->actual ? (bore->actual->position.head<2>() - Eigen::Vector2d(120, 30)).norm() : 1e9;
  };
  EXPECT_LT(bore_error(settled), 1e-3);
  EXPECT_LT(bore_error(incr), 1e-3);
  EXPECT_GT(bore_error(once), 0.1);
  std::printf("BORE2 from its drawing position: settled %.5f mm (%zu fits), one fit %.4f mm\n", bore_error(settled),
              fits(settled.diagnostics), bore_error(once));
}

namespace part_setups {

std::string example11() { return best_fit::example_text("11_two_setups.dmi"); }

// The world's two set-ups (block_two_setups.json): the part frame of each (machine/src/world.cpp:
// T, then Rz; the block's drawing origin is its bottom front left corner, P1's and P2's origin).
metron::Frame setup(const Eigen::Vector3d& at, double turned_deg) {
  metron::Frame f = metron::Frame::Identity();
  f.translate(at);
  f.rotate(Eigen::AngleAxisd(turned_deg * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()));
  return f;
}
const metron::Frame first = setup({300.4, 199.7, 0}, 0.25);
const metron::Frame second = setup({600.8, 449.5, 0}, 180.35);

}  // namespace part_setups

// Example 11: the block measured in two set-ups, the operator turning it round at the PAUSE.
// After EQUATE/DA(P1), DA(P2), BORE2 and SPHERE1 (first set-up) are where the drawing puts them in
// P2, the sphere where the second set-up measures it again, and BORE2 40 mm from BOSS1 (second
// set-up) as drawn. Without EQUATE they stay where the first set-up found them.
TEST(PartSetups, EquateCarriesTheFirstSetupIntoTheSecond) {
  const auto o = run(program("11_two_setups.dmi"), world("block_two_setups.json"), "two_setups");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  EXPECT_NE(o.diagnostics.find("PAUSE: the virtual operator puts the part in its set-up 2"), std::string::npos)
      << o.diagnostics;
  const auto* bore = report(o.record, "BORE2");
  const auto* sphere = report(o.record, "SPHERE1");
  const auto* again = report(o.record, "SPHERE1B");
  ASSERT_TRUE(bore && bore->actual && sphere && sphere->actual && again && again->actual);
  EXPECT_EQ(bore->frame, "P2");
  EXPECT_LT((bore->actual->position.head<2>() - Eigen::Vector2d(120, 30)).norm(), 2e-3);
  EXPECT_LT((bore->nominal.position.head<2>() - Eigen::Vector2d(120, 30)).norm(), 1e-9);  // carried with it
  EXPECT_LT((sphere->actual->position - Eigen::Vector3d(75, 75, 48)).norm(), 3e-3);
  EXPECT_LT((sphere->actual->position - again->actual->position).norm(), 3e-3);
  const auto* distance = tolerance(o.record, "BOSS_TO_BORE");
  ASSERT_TRUE(distance);
  EXPECT_NEAR(distance->actual, 40.0, 3e-3);
  // The careful engineer's way without EQUATE: each set-up reported in its own part frame (BORE2
  // in P1 before the PAUSE, the boss in P2) and the distance taken by hand. EQUATE agrees to
  // rounding: T is the rigid motion between P1 and P2, nothing else.
  const FeatureReport* bore_in_p1 = nullptr;
  for (const auto& e : o.record.events)
    if (const auto* f = std::get_if<FeatureReport>(&e); f && f->label == "BORE2" && !bore_in_p1) bore_in_p1 = f;
  const auto* boss = report(o.record, "BOSS1");
  ASSERT_TRUE(bore_in_p1 && bore_in_p1->actual && boss && boss->actual);
  EXPECT_EQ(bore_in_p1->frame, "P1");
  EXPECT_NEAR(distance->actual, boss->actual->position.y() - bore_in_p1->actual->position.y(), 1e-9);
  EXPECT_LT((bore->actual->position - bore_in_p1->actual->position).norm(), 1e-9);
  // The datum reference frame of the first set-up's A, B, C holds the second's boss.
  const auto* position = tolerance(o.record, "POS_BOSS");
  ASSERT_TRUE(position);
  EXPECT_LT(position->value, 5e-3);

  // The note tells the part's motion between the set-ups: its origin's, and the turn.
  const Eigen::Vector3d shift = part_setups::second.translation() - part_setups::first.translation();
  EXPECT_NE(o.diagnostics.find(fmt::format("5 features and 2 coordinate systems of the earlier set-up moved with the "
                                           "part: its origin by {:.3f}",
                                           shift.x())),
            std::string::npos)
      << o.diagnostics;
  EXPECT_NE(o.diagnostics.find("turned 179.90"), std::string::npos) << o.diagnostics;

  const std::string without = best_fit::replaced(part_setups::example11(), "EQUATE/DA(P1), DA(P2)\n", "");
  const auto apart = run(best_fit::written("11_no_equate.dmi", without), world("block_two_setups.json"), "no_equate");
  ASSERT_EQ(apart.exit, RunExit::Completed) << apart.diagnostics;
  const auto* left_behind = report(apart.record, "BORE2");
  ASSERT_TRUE(left_behind && left_behind->actual);
  const Eigen::Vector3d where = part_setups::second.inverse() * part_setups::first * Eigen::Vector3d(120, 30, 30);
  EXPECT_LT((left_behind->actual->position.head<2>() - where.head<2>()).norm(), 5e-3);
  EXPECT_GT((where.head<2>() - Eigen::Vector2d(120, 30)).norm(), 100.0);
}

// What the second set-up measured is not moved (LEFT2, the face P2's X origin rests on, stays at
// X 0 in P2), P1 is carried with the first set-up (the sphere measured in the second, reported
// in it, is where the drawing puts it), a nominal written in P1 but measured only after EQUATE
// is carried too (BORE1 is found in the second set-up), a corner constructed in the first set-up
// with its sources, a feature's probed points with it, and EQUATE refuses what it cannot tell
// apart (read strictly an error, leniently a warning): a later system of numbers only, and the
// set-ups written the wrong way round.
TEST(PartSetups, EquateMovesOnlyTheEarlierSetup) {
  const std::string written_first = best_fit::replaced(
      part_setups::example11(), "\nPAUSE\n",
      "\nF(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\n"
      "F(EDGE) = FEAT/LINE, UNBND, CART, 0, 0, 40, 1, 0, 0, 0, 0, 1\nCONST/LINE, F(EDGE), INTOF, FA(TOP), FA(FRONT)\n"
      "F(CORNER) = FEAT/POINT, CART, 0, 0, 40, -1, 0, 0\nCONST/POINT, F(CORNER), INTOF, FA(EDGE), FA(LEFT)\nPAUSE\n");
  const std::string text = best_fit::replaced(
      written_first, "OUTPUT/FA(BOSS1), FA(BORE2), TA(BOSS_TO_BORE)\n",
      "MEAS/CIRCLE, F(BORE1), 6\nENDMES\nOUTPUT/FA(LEFT2), FA(LEFT), FA(BORE1), FA(CORNER), FA(SPHERE1)[1,9]\n"
      "RECALL/DA(P1)\nOUTPUT/FA(SPHERE1B)\n");
  const auto o = run(best_fit::written("11_left.dmi", text), world("block_two_setups.json"), "equate_left");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const auto* left2 = report(o.record, "LEFT2");
  const auto* left = report(o.record, "LEFT");
  ASSERT_TRUE(left2 && left2->actual && left && left->actual);
  EXPECT_NEAR(left2->actual->position.x(), 0.0, 2e-3);
  EXPECT_NEAR(left->actual->position.x(), 0.0, 2e-3);
  const auto* bore = report(o.record, "BORE1");
  ASSERT_TRUE(bore && bore->actual);
  EXPECT_LT((bore->actual->position.head<2>() - Eigen::Vector2d(40, 50)).norm(), 2e-3);
  // The sphere's probed points are carried with it: listed in P2, on its drawn surface.
  const auto* carried = report(o.record, "SPHERE1");
  ASSERT_TRUE(carried && carried->points.size() == 9U);
  for (const auto& p : carried->points) EXPECT_NEAR((p.surface_mm - Eigen::Vector3d(75, 75, 48)).norm(), 10.0, 3e-3);
  const auto* corner = report(o.record, "CORNER");  // constructed in the first set-up: carried with its sources
  ASSERT_TRUE(corner && corner->actual);
  EXPECT_LT((corner->actual->position - Eigen::Vector3d(0, 0, 40)).norm(), 3e-3);
  const auto* sphere = report(o.record, "SPHERE1B");
  ASSERT_TRUE(sphere && sphere->actual);
  EXPECT_EQ(sphere->frame, "P1");
  EXPECT_LT((sphere->actual->position - Eigen::Vector3d(75, 75, 48)).norm(), 3e-3);

  // Read strictly, an EQUATE that cannot tell the set-ups apart is an error; leniently a warning,
  // and nothing is carried (BORE2 stays where the first set-up measured it).
  const fs::path numbers_program = best_fit::written(
      "11_numbers.dmi",
      best_fit::replaced(part_setups::example11(), "\nEQUATE/DA(P1), DA(P2)\n", "\nEQUATE/DA(P1), DA(FIX2)\n"));
  const auto numbers = run(numbers_program, world("block_two_setups.json"), "equate_numbers", std::nullopt, true);
  EXPECT_EQ(numbers.exit, RunExit::ProgramError);
  EXPECT_NE(numbers.diagnostics.find("error: EQUATE: DA(FIX2) rests on no measured feature"), std::string::npos)
      << numbers.diagnostics;
  const auto lenient = run(numbers_program, world("block_two_setups.json"), "equate_numbers_lenient");
  EXPECT_EQ(lenient.exit, RunExit::Completed) << lenient.diagnostics;
  EXPECT_NE(lenient.diagnostics.find("warning: EQUATE: DA(FIX2) rests on no measured feature"), std::string::npos)
      << lenient.diagnostics;
  const auto* left_where_measured = report(lenient.record, "BORE2");
  ASSERT_TRUE(left_where_measured && left_where_measured->actual);
  EXPECT_GT((left_where_measured->actual->position.head<2>() - Eigen::Vector2d(120, 30)).norm(), 100.0);
  const auto reversed =
      run(best_fit::written("11_reversed.dmi", best_fit::replaced(part_setups::example11(), "\nEQUATE/DA(P1), DA(P2)\n",
                                                                  "\nEQUATE/DA(P2), DA(P1)\n")),
          world("block_two_setups.json"), "equate_reversed", std::nullopt, true);
  EXPECT_EQ(reversed.exit, RunExit::ProgramError);
  EXPECT_NE(reversed.diagnostics.find("DA(P2) rests on no feature measured before DA(P1)'s first point"),
            std::string::npos)
      << reversed.diagnostics;
}

// A feature measured after the PAUSE but before the second set-up's datums (BOSS1, written in the
// second fixture's frame) is of the second set-up: EQUATE cuts the set-ups at the PAUSE, the moment
// the part could move, and leaves the boss where it was measured; cut at P2's first datum point
// instead, the boss would be carried 300 mm away. (Its POS is not checked: its nominal is the
// fixture frame's, not the part's.) The DMIS output file is told of the EQUATE.
TEST(PartSetups, EquateCutsTheSetupsAtThePause) {
  const std::string boss =
      "F(BOSS1) = FEAT/CIRCLE, OUTER, CART, 120, 70, 50, 0, 0, 1, 24\nMEAS/CIRCLE, F(BOSS1), 6\nENDMES\n";
  std::string text = best_fit::replaced(part_setups::example11(), boss, "");
  text = best_fit::replaced(text, "D(FIX2) = ROTATE/ZAXIS, 180\n", "D(FIX2) = ROTATE/ZAXIS, 180\n" + boss);
  text = best_fit::replaced(text, "UNITS/MM, ANGDEC\n",
                            "UNITS/MM, ANGDEC\nDID(DMO) = DEVICE/STOR, 'setups.dmo'\n"
                            "OPEN/DID(DMO), FDATA, DMIS, OUTPUT, OVERWR\n");
  const auto o = run(best_fit::written("11_boss_first.dmi", text), world("block_two_setups.json"), "equate_pause");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const auto* boss_actual = report(o.record, "BOSS1");
  ASSERT_TRUE(boss_actual && boss_actual->actual);
  EXPECT_EQ(boss_actual->frame, "P2");
  EXPECT_LT((boss_actual->actual->position.head<2>() - Eigen::Vector2d(120, 70)).norm(), 3e-3);
  const auto* distance = tolerance(o.record, "BOSS_TO_BORE");
  ASSERT_TRUE(distance);
  EXPECT_NEAR(distance->actual, 40.0, 3e-3);
  const std::string told = "DA(P1) carried onto DA(P2): 5 features and 2 coordinate systems of the earlier set-up";
  EXPECT_NE(o.diagnostics.find(told), std::string::npos) << o.diagnostics;
  EXPECT_NE(o.diagnostics.find("the earlier set-up is what was measured before the PAUSE between them"),
            std::string::npos)
      << o.diagnostics;
  const std::string dmo = file_text(out_dir("equate_pause") / "setups.dmo");
  EXPECT_NE(dmo.find("\n$$ EQUATE/DA(P1), DA(P2): " + told), std::string::npos) << dmo;
  EXPECT_LT(dmo.find("$$ EQUATE/"), dmo.find("OUTPUT/FA(BORE2), FA(SPHERE1), FA(SPHERE1B)"));
}

// A part in three set-ups (block_three_setups.json: block_two_setups.json's with a third, turned
// 90.3 deg, at the program's second PAUSE): the datum faces measured again in each, P1, P2, P3. EQUATE/DA(P1),DA(P3)
// then EQUATE/DA(P2),DA(P3) carries each set-up by its own motion, as the chain EQUATE/DA(P1),DA(P2)
// then EQUATE/DA(P2),DA(P3) does: BORE2 (set-up 1), BOSS1 (set-up 2) and BORE1 (set-up 3) are where
// the drawing puts them in P3. A set-up is what was measured between the PAUSEs around the earlier
// system's first point: cut at the last PAUSE alone, EQUATE/DA(P1),DA(P3) would carry the boss of
// set-up 2 by set-up 1's motion.
TEST(PartSetups, EquateCarriesEachOfThreeSetupsByItsOwnMotion) {
  const fs::path three = world("block_three_setups.json");
  const std::string ex11 = part_setups::example11();
  const auto begin = ex11.find("D(MACHINE) = DATSET/MCS\n");
  const auto end = ex11.find("D(P2) = TRANS/ZORIG, -40\n");
  ASSERT_TRUE(begin != std::string::npos && end != std::string::npos);
  std::string third = ex11.substr(begin, end - begin) + "D(P3) = TRANS/ZORIG, -40\n";
  third = best_fit::replaced(third, "D(FIX2) = TRANS/XORIG, 600, YORIG, 450, ZORIG, 0\nD(FIX2) = ROTATE/ZAXIS, 180\n",
                             "D(FIX3) = TRANS/XORIG, 250, YORIG, 600, ZORIG, 0\nD(FIX3) = ROTATE/ZAXIS, 90\n");
  for (const std::string name : {"TOP", "FRONT", "LEFT", "A", "B", "C", "S"})
    for (std::size_t at = 0; (at = third.find("(" + name + "2)", at)) != std::string::npos;)
      third.replace(at, name.size() + 3, "(" + name + "3)");
  third = best_fit::replaced(third, "D(MACHINE)", "D(MACHINE3)");
  third = "PAUSE\n" + third +
          "%EQUATE%F(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\nMEAS/CIRCLE, F(BORE1), 6\n"
          "ENDMES\nOUTPUT/FA(BORE2), FA(BOSS1), FA(BORE1)\nENDFIL\n";
  const auto with = [&](const std::string& text, const std::string& equates) {
    return best_fit::replaced(best_fit::replaced(text, "ENDFIL\n", third), "%EQUATE%", equates);
  };
  const std::string chained = with(ex11, "EQUATE/DA(P2), DA(P3)\n");
  const std::string direct = with(best_fit::replaced(ex11, "\nEQUATE/DA(P1), DA(P2)\n", "\n"),
                                  "EQUATE/DA(P1), DA(P3)\nEQUATE/DA(P2), DA(P3)\n");
  for (const auto& [name, text] : {std::pair{"chained", chained}, std::pair{"direct", direct}}) {
    const auto o =
        run(best_fit::written(std::string("three_") + name + ".dmi", text), three, std::string("equate_three_") + name);
    ASSERT_EQ(o.exit, RunExit::Completed) << name << "\n" << o.diagnostics;
    EXPECT_NE(o.diagnostics.find("PAUSE: the virtual operator puts the part in its set-up 3"), std::string::npos)
        << o.diagnostics;
    for (const auto& [label, x, y] :
         {std::tuple{"BORE2", 120.0, 30.0}, {"BOSS1", 120.0, 70.0}, {"BORE1", 40.0, 50.0}}) {
      const auto* f = report(o.record, label);
      ASSERT_TRUE(f && f->actual) << name << " " << label;
      EXPECT_EQ(f->frame, "P3") << name << " " << label;
      EXPECT_LT((f->actual->position.head<2>() - Eigen::Vector2d(x, y)).norm(), 3e-3)
          << name << " " << label << " at " << f->actual->position.transpose();
    }
    if (std::string(name) == "direct") {
      EXPECT_NE(o.diagnostics.find("DA(P2) carried onto DA(P3): 5 features and 2 coordinate systems"),
                std::string::npos)
          << o.diagnostics;
      EXPECT_NE(o.diagnostics.find("the earlier set-up is what was measured after the PAUSE before DA(P2)'s first "
                                   "point and before the PAUSE between them"),
                std::string::npos)
          << o.diagnostics;
    }
  }
}

// WRITE/DID(x) writes one line of values into an output file, kept in --out like every output.
TEST(EndToEnd, WriteWritesLinesIntoAnOutputFile) {
  const fs::path dir = out_dir("write_program");
  fs::create_directories(dir);
  const fs::path program = dir / "write.dmi";
  std::ofstream(program) << "DMISMN/'write', 5.0\nDECL/REAL,X\nX=ASSIGN/2.5\nDID(OUT)=DEVICE/STOR,'values.txt'\n"
                            "OPEN/DID(OUT),DIRECT,OUTPUT\nWRITE/DID(OUT),'X=',X\nWRITE/DID(OUT),'done'\n"
                            "CLOSE/DID(OUT)\nWRITE/DID(OUT),'too late'\nENDFIL\n";
  const auto o = run(program, std::nullopt, "write_out");
  EXPECT_EQ(o.exit, RunExit::ProgramError);
  EXPECT_NE(o.diagnostics.find("write.dmi:9:1: error: WRITE/DID(OUT): the device is not open for OUTPUT"),
            std::string::npos)
      << o.diagnostics;
  EXPECT_EQ(file_text(out_dir("write_out") / "values.txt"), "X=2.5\ndone\n");
}

TEST(Cli, CheckPrintsPositionedDiagnosticsWithACaret) {
  const fs::path bad = source_dir / "programs" / "bad" / "tolerance_wrong_type.dmi";
  const auto [code, out] = shell(std::string(METRON_BINARY) + " check " + bad.string());
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find(bad.string() + ":5:16: error: TOL/DIAM of T(D1) does not apply to a PLANE"), std::string::npos)
      << out;
  EXPECT_NE(out.find("  OUTPUT/FA(P1), TA(D1)\n                 ^"), std::string::npos) << out;
  const auto [ok, good] = shell(std::string(METRON_BINARY) + " check " + program("02_block_inspection.dmi").string());
  EXPECT_EQ(ok, 0) << good;
}

// A program for another machine's coordinates: the virtual CMM stops at its first move with a
// hint; `--dry-run` follows it to its end with every point at its nominal.
TEST(Cli, DryRunFollowsAProgramTheWorldDoesNotHold) {
  const fs::path dir = out_dir("cli_dry");
  const fs::path prog = dir / "far.dmi";
  std::ofstream(prog) << "DMISMN/'far', 5.0\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n"
                         "F(B1) = FEAT/CIRCLE, INNER, CART, -1063, -20, 150, 0, 0, 1, 12\nMEAS/CIRCLE, F(B1), 4\n"
                         "PTMEAS/CART, -1057, -20, 150, -1, 0, 0\nPTMEAS/CART, -1063, -14, 150, 0, -1, 0\n"
                         "PTMEAS/CART, -1069, -20, 150, 1, 0, 0\nPTMEAS/CART, -1063, -26, 150, 0, 1, 0\nENDMES\n"
                         "T(D) = TOL/DIAM, -0.001, 0.001\nOUTPUT/FA(B1), TA(D)\nENDFIL\n";
  const auto [code, out] = shell(std::string(METRON_BINARY) + " run " + prog.string() + " --out " + dir.string());
  EXPECT_EQ(code, 3) << out;
  EXPECT_NE(out.find("hint: if the world does not hold this program's part or machine, `metron run --dry-run`"),
            std::string::npos)
      << out;
  const auto [dry, dry_out] =
      shell(std::string(METRON_BINARY) + " run " + prog.string() + " --dry-run --out " + dir.string());
  EXPECT_EQ(dry, 0) << dry_out;
  EXPECT_NE(dry_out.find("run completed: 1 features, 1 tolerances in, 0 out, 0 faults"), std::string::npos) << dry_out;
  EXPECT_EQ(dry_out.find("hint:"), std::string::npos) << dry_out;
}

TEST(Cli, RunReportsAndWritesTheDmisOutputFile) {
  const fs::path dir = out_dir("cli_run");
  const auto [code, out] = shell(std::string(METRON_BINARY) + " run " + program("02_block_inspection.dmi").string() +
                                 " --out " + dir.string());
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("T(D_BORE1)  DIAM  FA(BORE1)"), std::string::npos) << out;
  const std::string dmo = file_text(dir / "block.dmo");
  EXPECT_NE(dmo.find("FA(BORE1) = FEAT/CYLNDR, INNER, CART"), std::string::npos) << dmo;
  EXPECT_NE(dmo.find("TA(D_BORE1) = TOL/DIAM,"), std::string::npos) << dmo;
}

TEST(Cli, FitReadsNistDataAndRejectsCorruptFiles) {
  const fs::path corrupt = out_dir("fit") / "corrupt.ds";
  std::ofstream(corrupt) << "3\n1 2 3\n4 5\n7 8 9\n";
  const auto [code, out] = shell(std::string(METRON_BINARY) + " fit plane " + corrupt.string());
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find(":3: error:"), std::string::npos) << out;
  const fs::path sphere = fs::path(METRON_SHARED_DATA) / "nist-fitting" / "Sphere" / "sph1.ds";
  if (!fs::exists(sphere)) GTEST_SKIP() << "shared data not present";
  const auto [c2, o2] = shell(std::string(METRON_BINARY) + " fit sphere " + sphere.string() + " --format json");
  EXPECT_EQ(c2, 0) << o2;
  EXPECT_NO_THROW({
    const auto parsed = nlohmann::json::parse(o2);
    EXPECT_TRUE(parsed.contains("diameter_mm"));
  }) << o2;
}

}  // namespace
