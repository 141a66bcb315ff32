// SPDX-License-Identifier: GPL-3.0-or-later
// plan_block without a machine: a MEAS block's machine commands against commands derived by hand
// from the DMIS statements (frame transform, SNSET distances, FEDRAT feeds, SEEDS.md 3 blend).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <variant>

#include <Eigen/Geometry>

#include "metron/runtime/block_plan.hpp"

namespace {

using namespace metron;
using namespace metron::runtime;

constexpr double exact = 1e-12;

// D(A): the part frame turned 90 degrees about Z and moved to (100, 200, 0): part x is machine y.
Alignment turned_and_moved() {
  Alignment a;
  a.label = "A";
  a.part_to_machine = Frame::Identity();
  a.part_to_machine.linear() = Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitZ()).toRotationMatrix();
  a.part_to_machine.translation() = Vec3(100, 200, 0);
  return a;
}

BlockPlanContext context_with(const Alignment& alignment) {
  BlockPlanContext c;
  c.alignment = alignment;
  c.probe.approach_mm = 3;
  c.probe.search_mm = 6;
  c.probe.retract_mm = 1.5;
  c.state.measuring_feed_mm_s = 7;
  return c;
}

Span at(std::uint32_t begin) { return Span{1, begin, begin + 1}; }

MeasStep step(MeasStep::Kind kind, const Vec3& point, std::optional<Vec3> normal, std::uint32_t where) {
  MeasStep s;
  s.kind = kind;
  s.point = point;
  s.normal = normal;
  s.span = at(where);
  return s;
}

Geometry plane_z(double z) {
  Geometry g;
  g.type = FeatureType::Plane;
  g.position = Vec3(100, 200, z);
  g.direction = Vec3::UnitZ();
  return g;
}

void expect_vec(const Vec3& actual, const Vec3& expected) {
  EXPECT_NEAR((actual - expected).norm(), 0.0, exact) << actual.transpose() << " vs " << expected.transpose();
}

TEST(PlanBlock, GotoAndPtmeasInTheCurrentFrameBecomeMachineCommands) {
  // GOTO/0,0,20 then PTMEAS/CART,10,0,5,2,0,0 and PTMEAS/CART,0,-4,5,0,0,1 in D(A).
  MeasBlock block;
  block.feature = "F1";
  block.type = FeatureType::Plane;
  block.point_count = 2;
  block.span = at(1);
  block.steps = {step(MeasStep::Kind::GoTo, Vec3(0, 0, 20), std::nullopt, 10),
                 step(MeasStep::Kind::PtMeas, Vec3(10, 0, 5), Vec3(2, 0, 0), 20),
                 step(MeasStep::Kind::PtMeas, Vec3(0, -4, 5), Vec3(0, 0, 1), 30)};
  const auto plan = plan_block(block, plane_z(5), context_with(turned_and_moved()));
  ASSERT_TRUE(plan) << plan.error().message;
  ASSERT_EQ(plan->commands.size(), 3u);
  ASSERT_EQ(plan->spans.size(), 3u);
  ASSERT_EQ(plan->measuring_feed_mm_s.size(), 3u);

  // Part (x, y, z) -> machine (100 - y, 200 + x, z).
  const auto* go = std::get_if<machine::GoTo>(&plan->commands[0].body);
  ASSERT_TRUE(go);
  expect_vec(go->target_mm, Vec3(100, 200, 20));
  EXPECT_EQ(plan->spans[0].begin, 10u);
  EXPECT_EQ(plan->measuring_feed_mm_s[0], 0.0);

  const auto* p1 = std::get_if<machine::PtMeas>(&plan->commands[1].body);
  ASSERT_TRUE(p1);
  expect_vec(p1->nominal_mm, Vec3(100, 210, 5));
  expect_vec(p1->normal, Vec3(0, 1, 0));  // (2,0,0) normalised and turned
  EXPECT_EQ(p1->approach_mm, 3);          // SNSET/APPRCH, SEARCH, RETRCT as given
  EXPECT_EQ(p1->search_mm, 6);
  EXPECT_EQ(p1->retract_mm, 1.5);
  EXPECT_FALSE(p1->speed_mm_s);  // the machine's measuring feed
  EXPECT_FALSE(p1->two_touch);
  EXPECT_FALSE(p1->blend_mm);
  EXPECT_EQ(plan->spans[1].begin, 20u);
  EXPECT_EQ(plan->measuring_feed_mm_s[1], 7.0);

  const auto* p2 = std::get_if<machine::PtMeas>(&plan->commands[2].body);
  ASSERT_TRUE(p2);
  expect_vec(p2->nominal_mm, Vec3(104, 200, 5));
  expect_vec(p2->normal, Vec3(0, 0, 1));
  EXPECT_EQ(plan->spans[2].begin, 30u);
  for (const auto& c : plan->commands) EXPECT_EQ(c.tag, 0u);  // numbered when submitted
}

TEST(PlanBlock, PtmeasWithoutDirectionApproachesFromTheMaterialFreeSide) {
  // A bore (INNER) of diameter 20 about (50, 50, 0), axis z, in the MCS: PTMEAS/CART,60,50,-5
  // without i,j,k approaches from the axis side, -x; on a boss (OUTER) from +x.
  Geometry bore;
  bore.type = FeatureType::Circle;
  bore.side = Side::Inner;
  bore.position = Vec3(50, 50, 0);
  bore.diameter_mm = 20;
  MeasBlock block;
  block.steps = {step(MeasStep::Kind::PtMeas, Vec3(60, 50, -5), std::nullopt, 5)};
  auto plan = plan_block(block, bore, context_with(Alignment{}));
  ASSERT_TRUE(plan);
  expect_vec(std::get<machine::PtMeas>(plan->commands.at(0).body).normal, Vec3(-1, 0, 0));
  bore.side = Side::Outer;
  plan = plan_block(block, bore, context_with(Alignment{}));
  ASSERT_TRUE(plan);
  expect_vec(std::get<machine::PtMeas>(plan->commands.at(0).body).normal, Vec3(1, 0, 0));
}

TEST(PlanBlock, ACharacterisedBlendedCycleAndTheProgramsFeedOverride) {
  // SEEDS.md 3 beyond the seed, blended one touch: blend = tol + F (delay + jitter) + pre-travel
  // + F_q (delay + jitter / 2); approach = max(2, blend) without SNSET/APPRCH.
  MachineCharacterisation ch;
  ch.one_touch = true;
  ch.blend = true;
  ch.nominal_tolerance_mm = 0.1;
  ch.pre_travel_mm = 0.01;
  ch.measuring_feed_mm_s = 8;
  ch.response.delay_s = 0.001;
  ch.response.jitter_s = 0.002;
  ch.response.qualification_feed_mm_s = 5;
  BlockPlanContext context = context_with(Alignment{});
  context.characterisation = &ch;
  MeasBlock block;
  block.steps = {step(MeasStep::Kind::PtMeas, Vec3(0, 0, 0), Vec3(0, 0, 1), 5)};

  auto plan = plan_block(block, plane_z(0), context);
  ASSERT_TRUE(plan);
  auto p = std::get<machine::PtMeas>(plan->commands.at(0).body);
  ASSERT_TRUE(p.speed_mm_s && p.blend_mm);
  EXPECT_EQ(*p.speed_mm_s, 8.0);
  EXPECT_NEAR(*p.blend_mm, 0.1 + 8 * 0.003 + 0.01 + 5 * 0.002, exact);  // 0.144
  EXPECT_EQ(p.approach_mm, 2.0);
  EXPECT_FALSE(p.two_touch);
  EXPECT_EQ(plan->measuring_feed_mm_s.at(0), 8.0);

  // FEDRAT/MESVEL,4 and SNSET/APPRCH,3 override the characterisation's feed and approach.
  context.measuring_feed_mm_s = 4;
  context.probe.approach_explicit = true;
  plan = plan_block(block, plane_z(0), context);
  ASSERT_TRUE(plan);
  p = std::get<machine::PtMeas>(plan->commands.at(0).body);
  EXPECT_EQ(*p.speed_mm_s, 4.0);
  EXPECT_NEAR(*p.blend_mm, 0.1 + 4 * 0.003 + 0.01 + 5 * 0.002, exact);  // 0.132
  EXPECT_EQ(p.approach_mm, 3.0);
  EXPECT_EQ(plan->measuring_feed_mm_s.at(0), 4.0);
}

TEST(PlanBlock, ScanModePtmeasPairIsOneScanWithTheScanSettings) {
  // SCNMOD/ON, SCNSET/DIST,0.2, FEDRAT/SCNVEL,12, SCNSET/LAW,VC1: PTMEAS from (0,0,0) to (20,0,0)
  // on a plane z = 0 is one ScanPath (the buffer holds any length) approaching along +z.
  BlockPlanContext context = context_with(Alignment{});
  context.scan.scan_mode = true;
  context.scan.sample_spacing_mm = 0.2;
  context.scan.feed_mm_s = 12;
  context.scan.law = machine::ScanLaw::Vc1;
  MeasBlock block;
  block.steps = {step(MeasStep::Kind::PtMeas, Vec3(0, 0, 0), Vec3(0, 0, 1), 5),
                 step(MeasStep::Kind::PtMeas, Vec3(20, 0, 0), Vec3(0, 0, 1), 6)};
  const auto plan = plan_block(block, plane_z(0), context);
  ASSERT_TRUE(plan) << plan.error().message;
  ASSERT_EQ(plan->commands.size(), 1u);
  const auto* scan = std::get_if<machine::ScanPath>(&plan->commands[0].body);
  ASSERT_TRUE(scan);
  expect_vec(scan->approach_normal, Vec3(0, 0, 1));
  EXPECT_EQ(scan->law, machine::ScanLaw::Vc1);
  EXPECT_EQ(scan->speed_mm_s, std::optional<double>(12));
  EXPECT_EQ(scan->sample_spacing_mm, 0.2);
  EXPECT_EQ(scan->approach_mm, 3);
  EXPECT_EQ(scan->retract_mm, 1.5);
  EXPECT_EQ(plan->spans[0].begin, 6u);  // the PTMEAS that ends the scan
  EXPECT_EQ(plan->measuring_feed_mm_s[0], 0.0);
}

TEST(PlanBlock, ProgramErrorsNameTheirStatement) {
  BlockPlanContext context = context_with(Alignment{});
  MeasBlock block;
  block.span = at(1);
  // A zero direction.
  block.steps = {step(MeasStep::Kind::PtMeas, Vec3(0, 0, 0), Vec3(0, 0, 0), 7)};
  auto plan = plan_block(block, plane_z(0), context);
  ASSERT_FALSE(plan);
  EXPECT_EQ(plan.error().span.begin, 7u);
  EXPECT_NE(plan.error().message.find("zero vector"), std::string::npos);
  // An undefined path, with and without a path table.
  block.steps = {step(MeasStep::Kind::Scan, Vec3(0, 0, 0), std::nullopt, 8)};
  block.steps[0].path = "P9";
  plan = plan_block(block, plane_z(0), context);
  ASSERT_FALSE(plan);
  EXPECT_EQ(plan.error().message, "path P(P9) is not defined");
  const std::map<std::string, PathDefinition> paths;
  context.paths = &paths;
  plan = plan_block(block, plane_z(0), context);
  ASSERT_FALSE(plan);
  EXPECT_EQ(plan.error().span.begin, 8u);
  // Scan mode: a PTMEAS without its end.
  context.scan.scan_mode = true;
  block.steps = {step(MeasStep::Kind::PtMeas, Vec3(0, 0, 0), Vec3(0, 0, 1), 9)};
  plan = plan_block(block, plane_z(0), context);
  ASSERT_FALSE(plan);
  EXPECT_EQ(plan.error().span.begin, 9u);
  // MODE/MAN without PTMEAS (issue 14): the virtual operator takes the points AUTO would plan
  // at the nominal, so check (which accepts the block) and run agree.
  context.scan.scan_mode = false;
  context.mode = Mode::Man;
  block.steps.clear();
  plan = plan_block(block, plane_z(0), context);
  ASSERT_TRUE(plan) << plan.error().message;
  context.mode = Mode::Auto;
  const auto automatic = plan_block(block, plane_z(0), context);
  ASSERT_TRUE(automatic);
  EXPECT_EQ(plan->commands.size(), automatic->commands.size());
}

}  // namespace
