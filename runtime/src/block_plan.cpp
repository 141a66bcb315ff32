// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/block_plan.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "metron/runtime/measurement_plan.hpp"
#include "metron/runtime/scan_segmentation.hpp"

namespace metron::runtime {
namespace {

// Sampling step of the design contours that scans follow (mm).
constexpr double contour_step_mm = 0.05;

// Appends commands to a plan with their spans and feeds (one of each a command).
class PlanBuilder {
 public:
  explicit PlanBuilder(const BlockPlanContext& context) : m_context(context), m_at(context.state.position_mm) {}

  void go_to(const Vec3& point, Span span) {
    m_at = point;
    // Built in place: GCC 12 at -O3 warns (falsely) of an uninitialised variant when a
    // temporary Command is moved into the vector here.
    m_plan.commands.emplace_back().body = machine::GoTo{point, {}};
    annotate(span, 0);
  }

  Result<void> ptmeas(const Vec3& nominal, const Vec3& normal, Span span) {
    const ProbeSettings& probe = m_context.probe;
    machine::PtMeas p;
    p.nominal_mm = nominal;
    p.normal = normal.normalized();
    p.approach_mm = probe.approach_mm;
    p.search_mm = probe.search_mm;
    p.retract_mm = probe.retract_mm;
    const MachineCharacterisation* c = m_context.characterisation;
    if (m_context.touch_baseline) {
      // The conventional cycle at the same measuring feed as the characterised one would use.
      const TouchBaseline& b = *m_context.touch_baseline;
      if (const auto feed = m_context.measuring_feed_mm_s ? m_context.measuring_feed_mm_s
                            : c                           ? std::optional(c->measuring_feed_mm_s)
                                                          : std::nullopt)
        p.speed_mm_s = *feed;
      if (b.two_touch) {
        const auto first = b.first_feed_mm_s ? b.first_feed_mm_s : c ? std::optional(c->first_feed_mm_s) : std::nullopt;
        if (!first)
          return program_error(span,
                               "the two-touch baseline needs a first-touch feed (two-touch:B:F) or a characterisation");
        p.two_touch = machine::PtMeas::TwoTouch{*first, b.backoff_mm};
      }
    } else if (c) {
      // SEEDS.md 3: the characterised cycle; SNSET/APPRCH and FEDRAT/MESVEL override.
      const TouchPlan plan =
          c->plan(p.normal, m_context.measuring_feed_mm_s,
                  probe.approach_explicit ? std::optional<double>(probe.approach_mm) : std::nullopt, resting(p));
      apply_touch_plan(plan, p);
    }
    m_plan.commands.push_back({0, p});
    annotate(span, p.speed_mm_s.value_or(m_context.state.measuring_feed_mm_s));
    // Where the retract ends (the latched centre is near nominal + effective radius).
    m_at =
        m_context.state.tool
            ? std::optional<Vec3>(p.nominal_mm + (m_context.state.tool->effective_radius_mm + p.retract_mm) * p.normal)
            : std::nullopt;
    return {};
  }

  // A scan longer than the machine's command buffer goes as measurement commands (SEEDS.md 2),
  // queued in order: the machine takes each one when a buffer is free.
  Result<void> scan(const geometry::Contour& contour, Span span) {
    auto scan = scan_command(contour, m_context, span);
    if (!scan) return tl::unexpected(scan.error());
    m_at.reset();
    for (machine::Command& c : scan_commands(*scan, m_context.state.scan_buffer_segments)) {
      m_plan.commands.push_back(std::move(c));
      annotate(span, 0);
    }
    return {};
  }

  BlockPlan take() { return std::move(m_plan); }

 private:
  // The span and measuring feed of the command just appended.
  void annotate(Span span, double feed_mm_s) {
    m_plan.spans.push_back(span);
    m_plan.measuring_feed_mm_s.push_back(feed_mm_s);
  }

  // The head at rest on the touch's approach line (issue 11): the characterised plan may start
  // the touch there instead of moving closer first.
  std::optional<RestingHead> resting(const machine::PtMeas& p) const {
    if (!m_at || !m_context.state.tool) return std::nullopt;
    const Vec3 d = *m_at - (p.nominal_mm + m_context.state.tool->effective_radius_mm * p.normal);
    const double along = d.dot(p.normal);
    if (!(along > 0) || (d - along * p.normal).norm() > 1e-6) return std::nullopt;
    return RestingHead{along, m_context.state.positioning_feed_mm_s > 0 ? m_context.state.positioning_feed_mm_s : 50.0};
  }

  const BlockPlanContext& m_context;
  BlockPlan m_plan;
  std::optional<Vec3> m_at;  // where the head will rest before the next command, when known
};

// The block's own GOTO, PTMEAS and PAMEAS steps.
Result<void> plan_steps(const MeasBlock& block, const Geometry& nominal, const BlockPlanContext& context,
                        PlanBuilder& plan) {
  const Alignment& alignment = context.alignment;
  std::optional<MeasStep> scan_start;  // SCNMOD/ON: a PTMEAS pair is the start and end of a scan
  for (const auto& step : block.steps) {
    const Vec3 p = alignment.to_machine_point(step.point);
    if (step.kind == MeasStep::Kind::GoTo) {
      plan.go_to(p, step.span);
    } else if (step.kind == MeasStep::Kind::Scan) {
      const PathDefinition* path = nullptr;
      if (context.paths)
        if (auto it = context.paths->find(step.path); it != context.paths->end()) path = &it->second;
      if (!path) return program_error(step.span, fmt::format("path P({}) is not defined", step.path));
      if (auto ok = plan.scan(path_contour(*path, contour_step_mm), step.span); !ok) return ok;
    } else {
      const Vec3 n = step.normal ? alignment.to_machine_vector(*step.normal) : nominal_normal_at(nominal, p);
      if (n.norm() < 1e-12) return program_error(step.span, "the PTMEAS direction i,j,k is a zero vector");
      if (!context.scan.scan_mode) {
        if (auto ok = plan.ptmeas(p, n, step.span); !ok) return ok;
      } else if (!scan_start) {
        scan_start = step;
      } else {
        auto contour = nominal_contour_between(nominal, alignment.to_machine_point(scan_start->point), p,
                                               n.normalized(), contour_step_mm);
        if (!contour) return program_error(step.span, contour.error());
        if (auto ok = plan.scan(*contour, step.span); !ok) return ok;
        scan_start.reset();
      }
    }
  }
  if (scan_start)
    return program_error(
        scan_start->span,
        "in scan mode (SCNMOD/ON) PTMEAS come in pairs, the start and end of a scan: this one has no end");
  return {};
}

// Arc angles count from the arc's own reference direction when its FEAT gave one, else from the
// part's X axis (its Y when the arc's axis is X), as in PATH/ARC.
Vec3 arc_reference(const Alignment& alignment, const Geometry& nominal) {
  if (nominal.arc_reference.norm() > 0) return nominal.arc_reference;
  const bool along_x = std::abs(alignment.to_part_vector(nominal.direction).normalized().x()) >= 0.99;
  return alignment.to_machine_vector(along_x ? Vec3::UnitY() : Vec3::UnitX());
}

// SCNMOD/ON without points: a scan of the nominal feature instead of touching points.
Result<void> plan_nominal_scan(const MeasBlock& block, const Geometry& nominal, const BlockPlanContext& context,
                               PlanBuilder& plan) {
  const Alignment& alignment = context.alignment;
  const Vec3 up = alignment.to_machine_vector(Vec3::UnitZ());
  auto contour = nominal_contour(nominal, context.state.position_mm, context.probe.depth_mm, up,
                                 arc_reference(alignment, nominal), contour_step_mm);
  if (!contour) return program_error(block.span, contour.error());
  return plan.scan(*contour, block.span);
}

// No steps: the automatic points of measurement_plan.hpp. In MODE/MAN the virtual CMM's operator
// takes the same points, at the nominal (docs/language.md "MODE/MAN"), so check and run agree.
Result<void> plan_auto(const MeasBlock& block, const Geometry& nominal, const BlockPlanContext& context,
                       PlanBuilder& plan) {
  const Vec3 up = context.alignment.to_machine_vector(Vec3::UnitZ());
  const double ball = context.state.tool ? context.state.tool->effective_radius_mm : 0.0;
  const auto steps = plan_auto_points(nominal, block.point_count, context.probe, ball, up, context.state.position_mm,
                                      arc_reference(context.alignment, nominal));
  if (steps.empty()) return program_error(block.span, "cannot plan automatic points for this feature");
  for (const auto& s : steps) {
    if (s.kind == PlannedStep::Kind::GoTo)
      plan.go_to(s.point, block.span);
    else if (auto ok = plan.ptmeas(s.point, s.normal, block.span); !ok)
      return ok;
  }
  return {};
}

}  // namespace

bool takes_points(const MeasBlock& block) {
  return std::any_of(block.steps.begin(), block.steps.end(),
                     [](const MeasStep& s) { return s.kind != MeasStep::Kind::GoTo; });
}

Result<BlockPlan> plan_block(const MeasBlock& block, const Geometry& nominal, const BlockPlanContext& context) {
  PlanBuilder plan(context);
  if (auto ok = plan_steps(block, nominal, context, plan); !ok) return tl::unexpected(ok.error());
  const bool has_points = takes_points(block);
  if (!has_points && !block.plan_missing_points) return plan.take();
  if (!has_points && context.scan.scan_mode && context.mode != Mode::Man) {
    if (auto ok = plan_nominal_scan(block, nominal, context, plan); !ok) return tl::unexpected(ok.error());
  } else if (!has_points) {
    if (auto ok = plan_auto(block, nominal, context, plan); !ok) return tl::unexpected(ok.error());
  }
  return plan.take();
}

Result<machine::ScanPath> scan_command(const geometry::Contour& contour, const BlockPlanContext& context, Span span) {
  const machine::MachineState& state = context.state;
  const ScanSettings& settings = context.scan;
  geometry::ScanPathOptions o;
  // The nominal ball radius: a scanning probe reads its deflection, so the touch-trigger
  // effective radius (which absorbs pre-travel and trigger delays) does not apply.
  o.ball_radius_mm = state.tool ? state.tool->nominal_radius_mm : 2.0;
  o.reference_deflection_mm = settings.reference_deflection_mm;
  o.chord_tolerance_mm = settings.chord_tolerance_mm;
  o.centripetal_accel_mm_s2 = settings.centripetal_accel_mm_s2;
  // The segment speeds are capped by the scan feed; without FEDRAT/SCNVEL by the measuring feed.
  o.feed_mm_s =
      settings.feed_mm_s ? *settings.feed_mm_s : (state.measuring_feed_mm_s > 0 ? state.measuring_feed_mm_s : 10.0);
  auto plan = geometry::make_scan_path(contour, o);
  if (!plan) return program_error(span, "cannot make a scan path: " + plan.error().message);
  machine::ScanPath scan;
  scan.path = std::move(plan->path);
  scan.approach_normal = contour.points.front().normal;
  scan.law = settings.law;
  scan.speed_mm_s = settings.feed_mm_s;
  scan.reference_deflection_mm = settings.reference_deflection_mm;
  scan.sample_spacing_mm = settings.sample_spacing_mm;
  scan.approach_mm = context.probe.approach_mm;
  scan.retract_mm = context.probe.retract_mm;
  return scan;
}

}  // namespace metron::runtime
