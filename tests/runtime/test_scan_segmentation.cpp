// SPDX-License-Identifier: GPL-3.0-or-later
// Host side of segmented scanning (SEEDS.md 2 steps 1-2): the averaging rule and the streaming
// of commands into the controller's buffers.
#include <gtest/gtest.h>

#include <numeric>

#include "metron/runtime/scan_segmentation.hpp"
#include "sample_paths.hpp"
#include "stream_commands.hpp"

namespace {

using namespace metron;
using metron::runtime::command_sizes;

TEST(ScanSegmentation, SeedExamples) {
  // P = 8, 8n + m (the seed's example buffer is P = 4, SEEDS.md 2 step 1; 8 makes P/4 = 2 a
  // threshold with both sides reachable). The seed's own P = 4 cases:
  EXPECT_EQ(command_sizes(13, 4), (std::vector<std::size_t>{4, 4, 4, 1}));            // m = 1 >= P/4 = 1: no averaging
  EXPECT_EQ(command_sizes(12, 4), (std::vector<std::size_t>{4, 4, 4}));               // m = 0
  EXPECT_EQ(command_sizes(32, 8), (std::vector<std::size_t>{8, 8, 8, 8}));            // m = 0
  EXPECT_EQ(command_sizes(33, 8), (std::vector<std::size_t>{8, 8, 8, 5, 4}));         // m = 1 < 2: (8+1)/2, odd
  EXPECT_EQ(command_sizes(34, 8), (std::vector<std::size_t>{8, 8, 8, 8, 2}));         // m = 2 = P/4: no averaging
  EXPECT_EQ(command_sizes(1003, 1000), (std::vector<std::size_t>{502, 501}));         // m = 3, n = 1
  EXPECT_EQ(command_sizes(2100, 1000), (std::vector<std::size_t>{1000, 550, 550}));   // m = 100 < 250
  EXPECT_EQ(command_sizes(2300, 1000), (std::vector<std::size_t>{1000, 1000, 300}));  // m = 300 >= 250
  EXPECT_EQ(command_sizes(7, 8), (std::vector<std::size_t>{7}));                      // shorter than a buffer
  EXPECT_TRUE(command_sizes(0, 8).empty());
}

// Brute force over M and P: the rule as stated, checked independently of the implementation.
TEST(ScanSegmentation, AveragingRuleHoldsForAllSizes) {
  for (std::size_t P = 1; P <= 24; ++P) {
    for (std::size_t M = 1; M <= 200; ++M) {
      const auto sizes = command_sizes(M, P);
      ASSERT_EQ(std::accumulate(sizes.begin(), sizes.end(), std::size_t{0}), M) << M << "/" << P;
      for (std::size_t s : sizes) ASSERT_TRUE(s >= 1 && s <= P) << M << "/" << P;
      const std::size_t n = M / P, m = M % P;
      if (n == 0) {
        ASSERT_EQ(sizes.size(), 1u);
        continue;
      }
      if (m == 0) {
        ASSERT_EQ(sizes.size(), n);
      } else if (4 * m < P) {
        ASSERT_EQ(sizes.size(), n + 1) << M << "/" << P;
        const std::size_t a = sizes[n - 1], b = sizes[n];
        ASSERT_EQ(a + b, P + m);
        ASSERT_TRUE(a == b || a == b + 1) << "the earlier command takes the odd segment";
      } else {
        ASSERT_EQ(sizes.size(), n + 1);
        ASSERT_EQ(sizes.back(), m);
      }
      for (std::size_t i = 0; i + 2 < sizes.size(); ++i) ASSERT_EQ(sizes[i], P);
    }
  }
}

TEST(ScanSegmentation, CommandsCoverThePathInOrder) {
  const geometry::PccPath path = test_support::freeform_contour(103, 1.0);
  const auto cmds = runtime::split_commands(path, 20);
  ASSERT_EQ(cmds.size(), 6u);  // 103 = 5*20 + 3, 3 < 5: 20 20 20 20 | 12 11
  std::size_t next = 0;
  for (std::size_t i = 0; i < cmds.size(); ++i) {
    EXPECT_EQ(cmds[i].index, i);
    EXPECT_EQ(cmds[i].first_segment, next);
    EXPECT_EQ(cmds[i].last, i + 1 == cmds.size());
    for (std::size_t k = 0; k < cmds[i].segments.size(); ++k)
      EXPECT_EQ(cmds[i].segments[k].k, path.segments[next + k].k);
    next += cmds[i].segments.size();
  }
  EXPECT_EQ(cmds[4].segments.size(), 12u);
  EXPECT_EQ(cmds[5].segments.size(), 11u);
  EXPECT_EQ(next, path.segments.size());
}

TEST(ScanSegmentation, HostStreamsIntoFreedBuffers) {
  const geometry::PccPath path = test_support::freeform_contour(130, 1.0);
  machine::segmented::ControllerConfig cfg;
  cfg.buffer_segments = 20;
  cfg.planning_s_per_segment = 1e-3;
  machine::segmented::SegmentedController ctl(cfg);
  const auto cmds = runtime::split_commands(path, 20);
  const auto stats = test_support::stream_commands(cmds, ctl, 100.0);
  ASSERT_TRUE(stats.has_value()) << stats.error().message;
  EXPECT_TRUE(ctl.finished());
  EXPECT_EQ(stats->plan_kinds.size(), cmds.size());
  EXPECT_EQ(stats->stops, 0u);
  EXPECT_NEAR(ctl.path_state().s_mm, path.length(), 1e-6);
  // A run that cannot finish in the allowed time is reported, not hung.
  machine::segmented::SegmentedController slow(cfg);
  const auto cut = test_support::stream_commands(cmds, slow, 0.5);
  ASSERT_FALSE(cut.has_value());
  EXPECT_EQ(cut.error().kind, machine::FaultKind::Aborted);
}

}  // namespace
