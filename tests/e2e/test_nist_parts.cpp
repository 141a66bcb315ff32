// SPDX-License-Identifier: GPL-3.0-or-later
// Real DMIS programs written elsewhere, on worlds built from the parts' STEP models.
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli/virtual_cmm_backend.hpp"
#include "metron/interpreter/session.hpp"

namespace {

namespace fs = std::filesystem;
using metron::interpreter::RunExit;

const fs::path source_dir = METRON_SOURCE_DIR;
const fs::path shared = METRON_SHARED_DATA;

const metron::runtime::FeatureReport* report(const metron::runtime::RunRecord& r, const std::string& label) {
  const metron::runtime::FeatureReport* found = nullptr;
  for (const auto& e : r.events)
    if (const auto* f = std::get_if<metron::runtime::FeatureReport>(&e); f && f->label == label) found = f;
  return found;
}

metron::interpreter::RunOutcome run(const std::string& example, const std::string& world, const std::string& out) {
  metron::interpreter::RunOptions o;
  o.program = (source_dir / "programs" / "examples" / example).string();
  o.world_path = (source_dir / "programs" / "worlds" / world).string();
  o.out_dir = (metron::test_support::scratch_root("metron_nist") / out).string();
  o.include_dirs = {shared.string()};  // the examples call ../../../shared/data/... (docs/security.md)
  return metron::interpreter::run_program(o, metron::cli::virtual_cmm_backend);
}

TEST(NistParts, SimplePartProgramGivesTheNistOutput) {
  if (!fs::exists(shared / "nist-simple-part" / "simple_in.dms")) GTEST_SKIP() << "../shared/data is not present";
  const auto o = run("03_nist_simple_part.dmi", "nist_simple_part.json", "simple");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const auto* c = report(o.record, "A_CIRCLE");
  ASSERT_TRUE(c && c->actual);
  // output.dms of the NIST suite: FA(A_CIRCLE) = FEAT/CIRCLE,INNER,CART,50,50,40,0,0,1,50. Contact
  // is exact on the STEP model's analytic faces; what remains is the default probe's 0.2 um noise.
  EXPECT_NEAR(c->actual->position.x(), 50.0, 0.001);
  EXPECT_NEAR(c->actual->position.y(), 50.0, 0.001);
  EXPECT_NEAR(c->actual->position.z(), 40.0, 1e-9);
  EXPECT_NEAR(c->actual->diameter_mm, 50.0, 0.001);
}

TEST(NistParts, DcxProgramRunsToTheEndWithAlignmentAndBothCylinders) {
  if (!fs::exists(shared / "nist-dcx-part" / "IMTS_M_clean.dmi")) GTEST_SKIP() << "../shared/data is not present";
  const auto o = run("04_nist_dcx_part.dmi", "nist_dcx_part.json", "dcx");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  // The part sits where the program's comments say: the alignment CALN1 recovers the model frame.
  const auto* corner = report(o.record, "CPNT1");
  ASSERT_TRUE(corner && corner->actual);
  const auto* cyl1 = report(o.record, "CYL1");
  ASSERT_TRUE(cyl1 && cyl1->actual);
  EXPECT_EQ(cyl1->frame, "CALN1");
  EXPECT_NEAR(cyl1->actual->diameter_mm, 31.0, 0.001);
  EXPECT_NEAR(cyl1->actual->position.x(), 0.0, 0.001);
  EXPECT_NEAR(cyl1->actual->position.y(), 0.0, 0.001);
  EXPECT_GT(std::abs(cyl1->actual->direction.z()), 0.9999);
  const auto* cyl2 = report(o.record, "CYL2");
  ASSERT_TRUE(cyl2 && cyl2->actual);
  EXPECT_NEAR(cyl2->actual->diameter_mm, 12.5, 0.001);
  EXPECT_NEAR(cyl2->actual->position.x(), 0.0, 0.001);
  EXPECT_NEAR(cyl2->actual->position.y(), 0.0, 0.001);
  EXPECT_GT(std::abs(cyl2->actual->direction.z()), 0.9999);
  // The program opens DID(OUTFILE) as 'C:\imts.dmo': written as imts.dmo in the output directory.
  std::ifstream dmo(fs::path(o.results_path).parent_path() / "imts.dmo");
  std::stringstream ss;
  ss << dmo.rdbuf();
  EXPECT_NE(ss.str().find("FA(CYL2) = FEAT/CYLNDR, INNER, CART"), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("TEXT/OUTFIL,'CYL1 - CYLINDER - '"), std::string::npos) << ss.str();
}

}  // namespace
