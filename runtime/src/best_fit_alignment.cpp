// SPDX-License-Identifier: GPL-3.0-or-later
// LOCATE and ITERAT: best-fit alignments of features' actuals onto their nominals (docs/alignments.md).
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "metron/runtime/measurement_runtime.hpp"
#include "metron/stdlib/fitting/best_fit_frame.hpp"

namespace metron::runtime {
namespace {

using fitting::FrameMatch;

// How far a feature's measured surface points spread about their centroid (RMS, mm): the lever
// a direction's mismatch acts through. A constructed feature without points of its own: its
// sources' (Feature::construction_spread_mm); a stated actual: 0.
double spread_mm(const Feature& f) {
  if (f.points.size() < 2) return f.construction_spread_mm;
  Vec3 centroid = Vec3::Zero();
  for (const auto& p : f.points) centroid += p.surface_mm();
  centroid /= static_cast<double>(f.points.size());
  double squares = 0;
  for (const auto& p : f.points) squares += (p.surface_mm() - centroid).squaredNorm();
  return std::sqrt(squares / static_cast<double>(f.points.size()));
}

// What a feature says about where the part is (fitting::FrameMatch). The nominal is taken as the
// program wrote it: in the alignment in force at its FEAT.
std::vector<FrameMatch> matches_of(const Feature& f, const std::string& name) {
  const Frame written = f.nominal_frame.inverse();
  const Geometry& nominal = f.nominal;
  const Geometry& actual = *f.actual;
  FrameMatch m;
  m.name = name;
  m.nominal_position = written * nominal.position;
  m.nominal_direction = (written.linear() * nominal.direction).normalized();
  m.actual_position = actual.position;
  m.actual_direction = actual.direction.normalized();
  switch (nominal.type) {
    case FeatureType::Point:
      // A probed surface point: only its height along its vector was measured (the other two
      // coordinates are where the probe was sent). A constructed point (a corner) is known whole.
      m.kind = f.source == ActualSource::Constructed ? FrameMatch::Kind::Point : FrameMatch::Kind::Plane;
      break;
    case FeatureType::Sphere:
    case FeatureType::Torus: m.kind = FrameMatch::Kind::Point; break;
    case FeatureType::Circle:
    case FeatureType::Arc:
    case FeatureType::Ellipse:
    case FeatureType::ClosedSlot:  // their height along the axis is where they were probed
      m.kind = FrameMatch::Kind::Axis;
      break;
    case FeatureType::Line:
    case FeatureType::Cylinder:
    case FeatureType::Cone:
      m.kind = FrameMatch::Kind::Axis;
      m.extent_mm = spread_mm(f);
      break;
    case FeatureType::Plane:
    case FeatureType::ParallelPlanes:
      m.kind = FrameMatch::Kind::Plane;
      m.extent_mm = spread_mm(f);
      break;
    case FeatureType::GenericSurface:
    case FeatureType::GenericCurve: {
      // Each probed point against its own nominal, along the nominal's normal.
      std::vector<FrameMatch> points;
      for (std::size_t i = 0; i < f.points.size(); ++i) {
        const MeasuredPoint& p = f.points[i];
        if (!p.nominal_mm) continue;
        FrameMatch q;
        q.kind = FrameMatch::Kind::Plane;
        q.name = fmt::format("{}[{}]", name, i + 1);
        q.nominal_position = written * *p.nominal_mm;
        q.nominal_direction = (written.linear() * p.nominal_normal).normalized();
        q.actual_position = p.surface_mm();
        q.actual_direction = p.nominal_normal;
        points.push_back(q);
      }
      return points;
    }
  }
  return {m};
}

}  // namespace

Result<std::vector<FrameMatch>> MeasurementRuntime::best_fit_matches(const std::string& statement,
                                                                     const LocateRequest& request, Span span) const {
  std::vector<FrameMatch> matches;
  auto add = [&](const std::string& feature, const std::string& name) -> Result<void> {
    const Feature* f = find_feature(feature);
    if (!f) return program_error(span, fmt::format("{}: feature F({}) is not defined", statement, feature));
    if (!f->actual)
      return program_error(span,
                           fmt::format("{}: {} has no actual yet: measure or construct it first", statement, name));
    const auto m = matches_of(*f, name);
    if (m.empty())
      return program_error(span, fmt::format("{}: {} has no probed point with a nominal to fit", statement, name));
    matches.insert(matches.end(), m.begin(), m.end());
    return {};
  };
  for (const auto& ref : request.features)
    if (auto r = add(ref.label, fmt::format("FA({})", ref.label)); !r) return tl::unexpected(r.error());
  for (const auto& d : request.datums) {
    auto datum_of = datum(d, span);
    if (!datum_of) return tl::unexpected(datum_of.error());
    if (auto r = add((*datum_of)->feature, fmt::format("DAT({})", d)); !r) return tl::unexpected(r.error());
  }
  return matches;
}

// A best fit rests on the features it fits (Alignment::rests_on_s).
double MeasurementRuntime::best_fit_rests_on_s(const LocateRequest& request) const {
  double rests_on = std::numeric_limits<double>::infinity();
  for (const FeatureRef& f : request.features) rests_on = std::min(rests_on, rests_on_s(f));
  for (const std::string& d : request.datums)
    if (const auto it = m_datums.find(d); it != m_datums.end()) rests_on = std::min(rests_on, it->second.rests_on_s);
  return rests_on;
}

Result<void> MeasurementRuntime::locate(const std::string& label, const LocateRequest& request, Span span) {
  const std::string statement = fmt::format("LOCATE D({})", label);
  const auto matches = best_fit_matches(statement, request, span);
  if (!matches) return tl::unexpected(matches.error());
  fitting::FrameFreedoms freedoms;
  freedoms.along = request.along;
  freedoms.about = request.about;
  const auto fit = fitting::best_fit_frame(*matches, m_alignment.part_to_machine, freedoms);
  if (!fit) return program_error(span, fmt::format("{}: {}", statement, fit.error()));

  // The note: the motion from the current alignment, the fit's RMS and its worst feature.
  const std::size_t worst = static_cast<std::size_t>(
      std::max_element(fit->residual_mm.begin(), fit->residual_mm.end()) - fit->residual_mm.begin());
  const ReportUnits& u = m_report_units;
  const auto length = [&](double mm) { return without_negative_zero(length_text(mm, u)); };
  const auto angle = [&](double deg) { return without_negative_zero(fmt::format("{:.4f}", deg)); };
  const Vec3& t = fit->translation_mm;
  const Vec3& r = fit->rotation_deg;
  note(span, fmt::format("{}: {} features fitted; moved {}, {}, {} {} and turned {}, {}, {} deg about {}'s X, Y, Z; "
                         "residual RMS {} {}, the largest {} {} at {}",
                         statement, request.features.size() + request.datums.size(), length(t.x()), length(t.y()),
                         length(t.z()), unit_word(u), angle(r.x()), angle(r.y()), angle(r.z()), m_alignment.label,
                         length(fit->rms_mm), unit_word(u), length(fit->residual_mm[worst]), unit_word(u),
                         (*matches)[worst].name));
  set_alignment(label, fit->part_to_machine, best_fit_rests_on_s(request));
  return {};
}

Result<double> MeasurementRuntime::iterate(const std::string& label, const LocateRequest& request, bool incremental,
                                           Span span) {
  const std::string statement = fmt::format("ITERAT D({})", label);
  const auto matches = best_fit_matches(statement, request, span);
  if (!matches) return tl::unexpected(matches.error());
  const Frame before = m_alignment.part_to_machine;
  const auto fit = fitting::best_fit_frame(*matches, before, {});
  if (!fit) return program_error(span, fmt::format("{}: {}", statement, fit.error()));
  double criterion = 0;
  if (incremental) {
    for (const auto& m : *matches)
      criterion = std::max(criterion, (fit->part_to_machine * m.nominal_position - before * m.nominal_position).norm());
  } else {
    for (const double d : fitting::frame_residuals_mm(*matches, before)) criterion = std::max(criterion, d);
  }
  const ReportUnits& u = m_report_units;
  const std::string test = incremental ? fmt::format("this fit moves the features' nominals at most {} {}",
                                                     length_text(criterion, u), unit_word(u))
                                       : fmt::format("the features were at most {} {} from their nominals in {}",
                                                     length_text(criterion, u), unit_word(u), m_alignment.label);
  note(span,
       fmt::format("{}: {}; the fit's residual RMS {} {}", statement, test, length_text(fit->rms_mm, u), unit_word(u)));
  set_alignment(label, fit->part_to_machine, best_fit_rests_on_s(request));
  return criterion;
}

}  // namespace metron::runtime
