// SPDX-License-Identifier: GPL-3.0-or-later
// PEGTL's static grammar analysis: no rule can loop forever without consuming input.
#include <gtest/gtest.h>

#include <tao/pegtl/contrib/analyze.hpp>

#include "../../grammar/src/detail/rules.hpp"

namespace tao::pegtl {
// The label-prefix check looks at the parser state and consumes nothing.
template <typename Name>
struct analyze_traits<Name, metron::grammar::rules::if_label_prefix> : analyze_opt_traits<> {};
}  // namespace tao::pegtl

TEST(GrammarAnalyze, NoInfiniteLoops) { EXPECT_EQ(tao::pegtl::analyze<metron::grammar::rules::line>(1), 0u); }
