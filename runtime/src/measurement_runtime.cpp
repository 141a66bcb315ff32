// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/measurement_runtime.hpp"

#include <cmath>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>

#include "detail/fit_actual.hpp"
#include "metron/runtime/measurement_plan.hpp"
#include "metron/runtime/outputs.hpp"
#include "metron/runtime/scan_segmentation.hpp"
#include "metron/stdlib/fitting/fit.hpp"

namespace metron::runtime {
namespace {

fitting::Shape fit_shape(FeatureType type) {
  switch (type) {
    case FeatureType::Point: return fitting::Shape::Point;
    case FeatureType::Line: return fitting::Shape::Line;
    case FeatureType::Plane: return fitting::Shape::Plane;
    case FeatureType::Circle:
    case FeatureType::Arc: return fitting::Shape::Circle;
    case FeatureType::Sphere: return fitting::Shape::Sphere;
    case FeatureType::Cylinder: return fitting::Shape::Cylinder;
    case FeatureType::Cone: return fitting::Shape::Cone;
  }
  return fitting::Shape::Point;
}

Vec3 oriented(const Vec3& d, const Vec3& like) { return d.dot(like) < 0 ? Vec3(-d) : d; }

}  // namespace

// Fits the actual of a feature from ball centres with probe compensation (stdlib fitting).
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_actual(const Geometry& nominal,
    const std::vector<MeasuredPoint>& points) {
  if (points.empty()) return tl::unexpected(std::string("no points were measured"));
  std::vector<Vec3> centres;
  fitting::Compensation comp;
  comp.ball_radius_mm = points.front().ball_radius_mm;
  for (const auto& p : points) {
    centres.push_back(p.centre_mm);
    comp.approach.push_back(p.normal);
  }
  fitting::FitOptions options;
  options.compensation = comp;
  options.inner = nominal.side != Side::Outer;
  // A line's DMIS i2,j2,k2 is the normal of the plane the line lies in (the working plane).
  options.direction_hint = nominal.type == FeatureType::Line ? nominal.normal2 : nominal.direction;
  options.circle_in_plane_of_hint = nominal.type == FeatureType::Circle || nominal.type == FeatureType::Arc;
  options.start_from_hint = true;  // a measured feature is fitted from its nominal
  auto fit = fitting::fit(fit_shape(nominal.type), centres, options);
  if (!fit)
    return tl::unexpected(fmt::format("cannot fit a {} to {} point{}: {}", dmis_word(nominal.type), points.size(),
                                      points.size() == 1 ? "" : "s", fitting::to_string(fit.error())));
  Geometry g = nominal;
  const Vec3 axis = fit->direction.norm() > 0 ? oriented(fit->direction.normalized(), nominal.direction) : nominal.direction;
  switch (nominal.type) {
    case FeatureType::Point:
      g.position = fit->position;
      break;
    case FeatureType::Line:
      g.position = fit->position;
      g.direction = axis;
      break;
    case FeatureType::Plane:
      g.position = fit->position;
      g.direction = axis;
      break;
    case FeatureType::Circle:
    case FeatureType::Arc:
    case FeatureType::Sphere:
      g.position = fit->position;
      if (nominal.type != FeatureType::Sphere) g.direction = axis;
      g.diameter_mm = fit->diameter_mm;
      break;
    case FeatureType::Cylinder: {
      // Report the axis point at the nominal position's height so positions compare like for like.
      g.direction = axis;
      g.position = fit->position + (nominal.position - fit->position).dot(axis) * axis;
      g.diameter_mm = fit->diameter_mm;
      break;
    }
    case FeatureType::Cone: {
      // Apex from the compensated surface points: rho = (t - t_apex) tan(half angle).
      const Vec3 dir = fit->direction.normalized();
      const double half = fit->apex_angle_deg * std::numbers::pi / 360.0;
      double sum = 0;
      for (std::size_t i = 0; i < points.size(); ++i) {
        const Vec3 q = points[i].surface_mm() - fit->position;
        const double t = q.dot(dir);
        const double rho = (q - t * dir).norm();
        sum += t - rho / std::tan(half);
      }
      g.position = fit->position + (sum / static_cast<double>(points.size())) * dir;
      g.direction = dir;
      g.apex_angle_deg = fit->apex_angle_deg;
      break;
    }
  }
  if (nominal.type == FeatureType::Cylinder || nominal.type == FeatureType::Cone) {
    double lo = 1e300, hi = -1e300;
    for (const auto& p : points) {
      const double t = (p.surface_mm() - g.position).dot(g.direction);
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
    if (nominal.length_mm <= 0) g.length_mm = hi - lo;
  }
  FitFigures figures{fit->residuals_mm, fit->rms_mm, fit->form_mm};
  return std::make_pair(g, figures);
}

MeasurementRuntime::MeasurementRuntime(machine::Machine& machine, const SourceManager& sources, RunRecord& record)
    : m_machine(machine), m_sources(sources), m_record(record) {
  m_alignments["MCS"] = m_alignment;
}

void MeasurementRuntime::warn(Span span, const std::string& message) {
  if (!span.valid()) {
    m_record.diagnostics.push_back("warning: " + message);
    return;
  }
  const Location loc = m_sources.locate(span);
  m_record.diagnostics.push_back(fmt::format("{}:{}:{}: warning: {}", loc.path, loc.line, loc.column, message));
}

void MeasurementRuntime::emit(RunEvent event) {
  if (m_on_event) m_on_event(event);
  m_record.events.push_back(std::move(event));
}

Result<void> MeasurementRuntime::define_feature(const std::string& label, const Geometry& nominal, Span span) {
  Feature f;
  f.label = label;
  f.nominal = to_machine(nominal, m_alignment.part_to_machine);
  f.nominal.direction.normalize();
  if (f.nominal.normal2.norm() > 0) f.nominal.normal2.normalize();
  f.defined_at = span;
  if (!m_features.count(label)) m_feature_order.push_back(label);
  m_features[label] = std::move(f);
  return {};
}

Result<void> MeasurementRuntime::define_tolerance(ToleranceSpec spec) {
  m_tolerances[spec.label] = std::move(spec);
  return {};
}

const Feature* MeasurementRuntime::find_feature(const std::string& label) const {
  auto it = m_features.find(label);
  return it == m_features.end() ? nullptr : &it->second;
}

const ToleranceSpec* MeasurementRuntime::find_tolerance(const std::string& label) const {
  auto it = m_tolerances.find(label);
  return it == m_tolerances.end() ? nullptr : &it->second;
}

Result<Geometry> MeasurementRuntime::resolve(const FeatureRef& ref, Span span) const {
  const Feature* f = find_feature(ref.label);
  if (!f) return program_error(span, fmt::format("feature {} is not defined", ref.label));
  if (!ref.actual) return f->nominal;
  if (!f->actual)
    return program_error(span, fmt::format("FA({}) has no actual: measure or construct it first", ref.label));
  return *f->actual;
}

Result<Geometry> MeasurementRuntime::feature_geometry(const FeatureRef& ref, Span span) const {
  auto g = resolve(ref, span);
  if (!g) return g;
  return to_frame(*g, m_alignment.part_to_machine);
}

MeasurementRuntime::Execution MeasurementRuntime::execute_commands(std::vector<machine::Command> commands,
                                                                    const std::vector<Span>& spans) {
  const std::uint64_t first = m_next_tag;
  for (auto& c : commands) {
    c.tag = m_next_tag++;
    m_machine.submit(std::move(c));
  }
  Execution out;
  out.responses = m_machine.execute();
  for (const auto& r : out.responses) {
    if (r.status == machine::Response::Status::Fault && r.fault && r.fault->kind != machine::FaultKind::Aborted) {
      const std::size_t i = static_cast<std::size_t>(r.tag - first);
      const Span span = i < spans.size() ? spans[i] : Span{};
      record_fault(*r.fault, span);
      out.error = RuntimeError{RuntimeError::Kind::Fault, r.fault->message, span, r.fault};
      break;
    }
  }
  out.first_tag = first;
  return out;
}

Result<std::vector<machine::Response>> MeasurementRuntime::run_commands(std::vector<machine::Command> commands,
                                                                        const std::vector<Span>& spans) {
  auto e = execute_commands(std::move(commands), spans);
  if (e.error) return tl::unexpected(*e.error);
  return e.responses;
}

void MeasurementRuntime::record_fault(const machine::Fault& fault, Span span) {
  FaultReport report;
  report.kind = machine::to_string(fault.kind);
  report.message = fault.message;
  if (span.valid()) {
    const Location loc = m_sources.locate(span);
    report.statement = {loc.path, loc.line, loc.column};
    report.statement_text = std::string(m_sources.line_text(span.file, span.begin));
  }
  report.position_mm = fault.position_mm;
  report.time_s = fault.time_s;
  m_record.status = RunStatus::Faulted;
  emit(report);
}

Result<void> MeasurementRuntime::define_sensor(const SensorDefinition& sensor, Span span) {
  if (!(sensor.ball_diameter_mm > 0))
    return program_error(span, fmt::format("sensor {} needs a positive tip diameter", sensor.label));
  m_sensors[sensor.label] = sensor;
  machine::DefineTool define{sensor.label, sensor.ball_diameter_mm,
                             m_alignment.to_machine_vector(sensor.direction).normalized(), sensor.length_mm};
  auto r = run_commands({machine::Command{0, define}}, {span});
  if (!r) return tl::unexpected(r.error());
  if (!r->empty() && r->front().tool) m_tools[sensor.label] = *r->front().tool;
  return {};
}

Result<void> MeasurementRuntime::select_sensor(const std::string& label, Span span) {
  if (!m_sensors.count(label)) return program_error(span, fmt::format("sensor S({}) is not defined", label));
  auto r = run_commands({machine::Command{0, machine::SelectTool{label}}}, {span});
  if (!r) return tl::unexpected(r.error());
  m_active_sensor = label;
  const auto& tool = r->front().tool;
  if (tool && !tool->qualified) m_qualification_feed_mm_s = m_machine.state().measuring_feed_mm_s;
  if (tool && !tool->qualified) {
    // Qualify on the reference sphere before the first use: the effective radius absorbs the
    // pre-travel and trigger delays at the measuring feed.
    auto q = run_commands({machine::Command{0, machine::QualifyTool{}}}, {span});
    if (!q) return tl::unexpected(q.error());
  }
  return {};
}

Result<void> MeasurementRuntime::ensure_tool(Span span) {
  if (!m_active_sensor.empty()) return {};
  warn(span, "no sensor selected before the first measurement; using a 4 mm default probe");
  SensorDefinition def;
  def.label = "METRON_DEFAULT";
  if (auto r = define_sensor(def, span); !r) return r;
  return select_sensor(def.label, span);
}

Result<void> MeasurementRuntime::set_feeds(std::optional<double> positioning, std::optional<double> measuring, Span span) {
  machine::SetFeeds feeds;
  if (positioning) feeds.positioning_mm_s = *positioning;
  if (measuring) feeds.measuring_mm_s = *measuring;
  if ((positioning && !(*positioning > 0)) || (measuring && !(*measuring > 0)))
    return program_error(span, "a feed rate must be positive");
  if (measuring) {
    if (auto ok = check_probing_feed(*measuring, span); !ok) return ok;
    m_measuring_feed_explicit = *measuring;
  }
  auto r = run_commands({machine::Command{0, feeds}}, {span});
  if (!r) return tl::unexpected(r.error());
  return {};
}

Result<void> MeasurementRuntime::characterise_machine(const std::optional<std::string>& path, Span span) {
  auto c = characterise(m_machine, CharacterisationSettings{});
  // The characterisation used its own tool: give the program's active one back.
  if (!m_active_sensor.empty()) {
    if (auto r = run_commands({machine::Command{0, machine::SelectTool{m_active_sensor}}}, {span}); !r)
      return tl::unexpected(r.error());
  }
  if (!c) return program_error(span, "characterisation failed: " + c.error());
  if (path) {
    std::filesystem::path p(*path);
    if (p.is_relative()) p = std::filesystem::path(m_output_dir) / p;
    if (auto ok = save_characterisation(*c, p.string()); !ok) return program_error(span, ok.error());
  }
  text("PRINT", format_characterisation(*c));
  m_characterisation = std::move(*c);
  if (m_measuring_feed_explicit) return check_probing_feed(*m_measuring_feed_explicit, span);
  return {};
}

Result<void> MeasurementRuntime::use_characterisation(const std::string& path, Span span) {
  auto c = load_characterisation(path);
  if (!c) return program_error(span, c.error());
  m_characterisation = std::move(*c);
  if (m_measuring_feed_explicit) return check_probing_feed(*m_measuring_feed_explicit, span);
  return {};
}

Result<void> MeasurementRuntime::check_probing_feed(double measuring_mm_s, Span span) const {
  if (!m_characterisation || measuring_mm_s <= m_characterisation->max_probe_feed_mm_s) return {};
  return program_error(span, fmt::format("probing feed {:.3f} mm/s exceeds the maximum protected feed {:.3f} mm/s of "
                                         "this machine (its stop distance would exceed {:.0f} % of the probe's "
                                         "{:.3f} mm over-travel; docs/touch-trigger.md)",
                                         measuring_mm_s, m_characterisation->max_probe_feed_mm_s,
                                         100 * m_characterisation->over_travel_margin,
                                         m_characterisation->over_travel_mm));
}

Result<void> MeasurementRuntime::set_acceleration(double acceleration_mm_s2, Span span) {
  if (!(acceleration_mm_s2 > 0)) return program_error(span, "an acceleration must be positive");
  machine::SetFeeds feeds;
  feeds.acceleration_mm_s2 = acceleration_mm_s2;
  auto r = run_commands({machine::Command{0, feeds}}, {span});
  if (!r) return tl::unexpected(r.error());
  return {};
}

Vec3 MeasurementRuntime::position_current() const {
  return m_alignment.to_part_point(m_machine.state().position_mm);
}

Result<void> MeasurementRuntime::go_to(const Vec3& point, Span span) {
  auto r = run_commands({machine::Command{0, machine::GoTo{m_alignment.to_machine_point(point), {}}}}, {span});
  if (!r) return tl::unexpected(r.error());
  return {};
}

Result<void> MeasurementRuntime::measure(const MeasBlock& block) {
  auto it = m_features.find(block.feature);
  if (it == m_features.end()) return program_error(block.span, fmt::format("feature F({}) is not defined", block.feature));
  Feature& feature = it->second;
  if (auto t = ensure_tool(block.span); !t) return t;

  std::vector<machine::Command> commands;
  std::vector<Span> spans;
  const bool has_points = std::any_of(block.steps.begin(), block.steps.end(),
                                      [](const MeasStep& s) { return s.kind != MeasStep::Kind::GoTo; });
  // A scan longer than the machine's command buffer goes as measurement commands (SEEDS.md 2),
  // queued in order: the machine takes each one when a buffer is free.
  const auto push_scan = [&](machine::ScanPath scan, Span span) {
    for (machine::Command& c : scan_commands(scan, m_machine.state().scan_buffer_segments)) {
      commands.push_back(std::move(c));
      spans.push_back(span);
    }
  };
  const auto ptmeas = [&](const Vec3& nominal, const Vec3& normal, Span span) {
    machine::PtMeas p;
    p.nominal_mm = nominal;
    p.normal = normal.normalized();
    p.approach_mm = m_probe.approach_mm;
    p.search_mm = m_probe.search_mm;
    p.retract_mm = m_probe.retract_mm;
    if (m_characterisation) {
      // SEEDS.md 3: the characterised cycle; SNSET/APPRCH and FEDRAT/MESVEL override.
      const TouchPlan plan = m_characterisation->plan(
          p.normal, m_measuring_feed_explicit,
          m_probe.approach_explicit ? std::optional<double>(m_probe.approach_mm) : std::nullopt);
      p.approach_mm = plan.approach_mm;
      p.speed_mm_s = plan.feed_mm_s;
      if (plan.two_touch) p.two_touch = machine::PtMeas::TwoTouch{plan.first_feed_mm_s, plan.backoff_mm};
      p.blend_mm = plan.blend_mm;
    }
    commands.push_back({0, p});
    spans.push_back(span);
  };
  std::optional<MeasStep> scan_start;  // SCNMOD/ON: a PTMEAS pair is the start and end of a scan
  if (has_points || block.steps.size() > 0) {
    for (const auto& step : block.steps) {
      const Vec3 p = m_alignment.to_machine_point(step.point);
      if (step.kind == MeasStep::Kind::GoTo) {
        commands.push_back({0, machine::GoTo{p, {}}});
        spans.push_back(step.span);
      } else if (step.kind == MeasStep::Kind::Scan) {
        auto path = m_paths.find(step.path);
        if (path == m_paths.end()) return program_error(step.span, fmt::format("path P({}) is not defined", step.path));
        auto scan = scan_command(path_contour(path->second, 0.05), step.span);
        if (!scan) return tl::unexpected(scan.error());
        push_scan(std::move(*scan), step.span);
      } else {
        const Vec3 n = step.normal ? m_alignment.to_machine_vector(*step.normal) : nominal_normal_at(feature.nominal, p);
        if (n.norm() < 1e-12) return program_error(step.span, "the PTMEAS direction i,j,k is a zero vector");
        if (!m_scan.scan_mode) {
          ptmeas(p, n, step.span);
        } else if (!scan_start) {
          scan_start = step;
        } else {
          auto contour = nominal_contour_between(feature.nominal, m_alignment.to_machine_point(scan_start->point), p,
                                                 n.normalized(), 0.05);
          if (!contour) return program_error(step.span, contour.error());
          auto scan = scan_command(*contour, step.span);
          if (!scan) return tl::unexpected(scan.error());
          push_scan(std::move(*scan), step.span);
          scan_start.reset();
        }
      }
    }
  }
  if (scan_start)
    return program_error(scan_start->span, "in scan mode (SCNMOD/ON) PTMEAS come in pairs, the start and end of a scan: this one has no end");
  if (!has_points && m_scan.scan_mode && m_mode != Mode::Man) {
    // SCNMOD/ON: scan the nominal feature instead of touching points.
    const Vec3 up = m_alignment.to_machine_vector(Vec3::UnitZ());
    // Arc angles count from the part's X axis (its Y when the arc's axis is X), as in PATH/ARC.
    const bool along_x = std::abs(m_alignment.to_part_vector(feature.nominal.direction).normalized().x()) >= 0.99;
    const Vec3 reference = m_alignment.to_machine_vector(along_x ? Vec3::UnitY() : Vec3::UnitX());
    auto contour = nominal_contour(feature.nominal, m_machine.state().position_mm, m_probe.depth_mm, up, reference, 0.05);
    if (!contour) return program_error(block.span, contour.error());
    auto scan = scan_command(*contour, block.span);
    if (!scan) return tl::unexpected(scan.error());
    push_scan(std::move(*scan), block.span);
  } else if (!has_points) {
    if (m_mode == Mode::Man)
      return program_error(block.span, "MEAS in MODE/MAN needs PTMEAS statements: metron cannot take manual points itself");
    const Vec3 up = m_alignment.to_machine_vector(Vec3::UnitZ());
    const auto state = m_machine.state();
    const double ball = state.tool ? state.tool->effective_radius_mm : 0.0;
    const auto plan = plan_auto_points(feature.nominal, block.point_count, m_probe, ball, up, state.position_mm);
    if (plan.empty()) return program_error(block.span, "cannot plan automatic points for this feature");
    for (const auto& s : plan) {
      if (s.kind == PlannedStep::Kind::GoTo) {
        commands.push_back({0, machine::GoTo{s.point, {}}});
        spans.push_back(block.span);
      } else {
        ptmeas(s.point, s.normal, block.span);
      }
    }
  }

  std::vector<MeasuredPoint> points;
  std::vector<double> commands_feed;  // the measuring feed of each command (PtMeas)
  for (const auto& c : commands)
    if (const auto* p = std::get_if<machine::PtMeas>(&c.body)) commands_feed.push_back(p->speed_mm_s.value_or(m_machine.state().measuring_feed_mm_s));
    else commands_feed.push_back(0);
  const auto execution = execute_commands(std::move(commands), spans);
  for (const auto& r : execution.responses)
    if (r.hit) {
      const std::size_t i = static_cast<std::size_t>(r.tag - execution.first_tag);
      Vec3 centre = r.hit->centre_mm;
      if (m_characterisation && i < commands_feed.size())
        // The effective radius holds the delay distance at the qualification feed; a hit at
        // another feed is latched farther (or less far) past the surface (SEEDS.md 3).
        centre += m_characterisation->dynamic_correction_mm(commands_feed[i], m_qualification_feed_mm_s) * r.hit->normal;
      points.push_back({centre, r.hit->normal, r.hit->ball_radius_mm, r.hit->time_s,
                        i < spans.size() ? spans[i] : block.span, false});
    }
  // Scanned samples: the deflection direction is the surface normal estimate (SEEDS.md 1: eu);
  // compensated with the nominal radius (no pre-travel: the deflection is read, see scan.cpp).
  const auto tool = m_machine.state().tool;
  for (const auto& r : execution.responses)
    for (const auto& line : r.scan_log) m_record.machine_log.push_back(feature.label + ": " + line);
  for (const auto& r : execution.responses)
    for (const auto& sample : r.scan) {
      const double e = sample.deflection_mm.norm();
      if (!(e > 0)) continue;  // not in contact
      const std::size_t i = static_cast<std::size_t>(r.tag - execution.first_tag);
      points.push_back({sample.centre_mm, sample.deflection_mm / e, tool ? tool->nominal_radius_mm : 0.0,
                        sample.time_s, i < spans.size() ? spans[i] : block.span, true});
    }
  if (execution.error) {
    // Keep every point obtained before the fault; the feature gets no actual.
    feature.points = points;
    feature.measured_at = block.span;
    return tl::unexpected(*execution.error);
  }
  feature.points = points;
  feature.measured_at = block.span;
  feature.source = ActualSource::Measured;
  const bool scanned = std::any_of(points.begin(), points.end(), [](const MeasuredPoint& p) { return p.scanned; });
  if (!scanned && block.point_count > 0 && static_cast<int>(points.size()) != block.point_count) {
    warn(block.span, fmt::format("MEAS declared {} points but {} were measured", block.point_count, points.size()));
  }
  auto fitted = fit_actual(feature.nominal, points);
  if (!fitted) return program_error(block.span, fitted.error());
  feature.actual = fitted->first;
  feature.fit = fitted->second;
  return {};
}

Result<const Datum*> MeasurementRuntime::datum(const std::string& label, Span span) const {
  auto it = m_datums.find(label);
  if (it == m_datums.end()) return program_error(span, fmt::format("datum DAT({}) is not defined: use DATDEF first", label));
  return &it->second;
}

Result<void> MeasurementRuntime::define_datum(const FeatureRef& ref, const std::string& label, Span span) {
  auto g = resolve(ref, span);
  if (!g) return tl::unexpected(g.error());
  m_datums[label] = Datum{label, ref.label, *g};
  return {};
}

void MeasurementRuntime::set_alignment(const std::string& label, const Frame& frame) {
  m_alignment = Alignment{label, frame};
  m_alignments[label] = m_alignment;
}

Result<void> MeasurementRuntime::datset(const std::string& label, const DatsetRequest& request, Span span) {
  if (request.mcs) {
    set_alignment(label, Frame::Identity());
    return {};
  }
  std::vector<DatsetClause> clauses;
  for (const auto& c : request.clauses) {
    auto d = datum(c.datum, span);
    if (!d) return tl::unexpected(d.error());
    clauses.push_back({(*d)->geometry, c.direction, c.minus, c.origins});
  }
  auto frame = runtime::datset(m_alignment.part_to_machine, clauses);
  if (!frame) return program_error(span, frame.error());
  set_alignment(label, *frame);
  return {};
}

Result<void> MeasurementRuntime::trans(const std::string& label, const TransRequest& request, Span span) {
  std::optional<double> origin[3];
  for (int k = 0; k < 3; ++k) {
    if (request.value[k]) origin[k] = request.value[k];
    if (request.feature[k]) {
      auto g = resolve(*request.feature[k], span);
      if (!g) return tl::unexpected(g.error());
      origin[k] = m_alignment.to_part_point(g->position)[k];
    }
  }
  set_alignment(label, translate_origin(m_alignment.part_to_machine, origin));
  return {};
}

Result<void> MeasurementRuntime::rotate(const std::string& label, const RotateRequest& request, Span span) {
  if (request.angle_deg) {
    set_alignment(label, rotate_about(m_alignment.part_to_machine, request.about, *request.angle_deg));
    return {};
  }
  if (!request.feature) return program_error(span, "ROTATE needs an angle or a feature");
  auto g = resolve(*request.feature, span);
  if (!g) return tl::unexpected(g.error());
  auto frame = rotate_to(m_alignment.part_to_machine, request.about, g->direction, request.align);
  if (!frame) return program_error(span, frame.error());
  set_alignment(label, *frame);
  return {};
}

Result<void> MeasurementRuntime::save(const std::string& label, Span span) {
  auto it = m_alignments.find(label);
  if (it == m_alignments.end()) return program_error(span, fmt::format("coordinate system D({}) is not defined", label));
  m_saved[label] = it->second;
  return {};
}

Result<void> MeasurementRuntime::recall(const std::string& label, Span span) {
  auto it = m_saved.find(label);
  if (it == m_saved.end()) it = m_alignments.find(label);
  if (it == m_alignments.end() || (it == m_saved.end() && !m_alignments.count(label)))
    return program_error(span, fmt::format("coordinate system D({}) is not defined or saved", label));
  m_alignment = it->second;
  return {};
}

void MeasurementRuntime::write_device_line(const std::string& line) {
  for (auto& [label, device] : m_devices)
    if (device.open && device.stream) *device.stream << line << "\n";
}

Result<void> MeasurementRuntime::output(const std::vector<OutputItem>& items, Span span) {
  std::vector<const Feature*> features;
  std::vector<std::string> tolerances;
  for (const auto& item : items) {
    if (item.kind == OutputItem::Kind::Tolerance) {
      if (!find_tolerance(item.tolerance)) return program_error(span, fmt::format("tolerance T({}) is not defined", item.tolerance));
      tolerances.push_back(item.tolerance);
      continue;
    }
    const Feature* f = find_feature(item.feature.label);
    if (!f) return program_error(span, fmt::format("feature F({}) is not defined", item.feature.label));
    features.push_back(f);
    FeatureReport report;
    report.label = f->label;
    report.frame = m_alignment.label;
    report.nominal = to_frame(f->nominal, m_alignment.part_to_machine);
    if (item.feature.actual && f->actual) report.actual = to_frame(*f->actual, m_alignment.part_to_machine);
    report.fit = f->fit;
    report.point_count = f->points.size();
    report.source = f->source;
    if (item.feature.actual && !f->actual)
      warn(span, fmt::format("OUTPUT of FA({}) before it was measured", f->label));
    write_device_line(dmis_feature_line(report));
    emit(report);
  }
  for (const auto& t : tolerances) {
    const ToleranceSpec& spec = m_tolerances.at(t);
    ToleranceContext context;
    context.alignment = &m_alignment;
    for (const auto& d : spec.datums) {
      auto dd = datum(d, span);
      if (!dd) return tl::unexpected(dd.error());
      context.datums.push_back(*dd);
    }
    auto result = evaluate_tolerance(spec, features, context);
    if (!result) return program_error(span, result.error());
    write_device_line(dmis_tolerance_line(*result));
    emit(*result);
  }
  return {};
}

Result<void> MeasurementRuntime::define_device(const std::string& label, const std::string& path, Span) {
  m_devices[label] = Device{path, false, nullptr};
  return {};
}

Result<void> MeasurementRuntime::open_device(const std::string& label, Span span) {
  auto it = m_devices.find(label);
  if (it == m_devices.end()) return program_error(span, fmt::format("device DID({}) is not defined", label));
  // A program's path (often a Windows path on another machine) is reduced to its base name and
  // written into the run's output directory.
  std::string name = it->second.path;
  const auto cut = name.find_last_of("/\\:");
  if (cut != std::string::npos) name = name.substr(cut + 1);
  if (name.empty()) name = label + ".dmo";
  const std::string full = (std::filesystem::path(m_output_dir) / name).string();
  auto stream = std::make_shared<std::ofstream>(full);
  if (!*stream) return program_error(span, fmt::format("cannot open output file {}", full));
  it->second.stream = stream;
  it->second.open = true;
  it->second.path = full;
  return {};
}

Result<void> MeasurementRuntime::close_device(const std::string& label, Span span) {
  auto it = m_devices.find(label);
  if (it == m_devices.end()) return program_error(span, fmt::format("device DID({}) is not defined", label));
  if (it->second.stream) it->second.stream->flush();
  it->second.open = false;
  it->second.stream.reset();
  return {};
}

void MeasurementRuntime::text(const std::string& kind, const std::string& text) {
  if (kind == "OUTFIL") write_device_line("TEXT/OUTFIL,'" + text + "'");
  emit(TextReport{text});
}

void MeasurementRuntime::finish() {
  m_record.features.clear();
  for (const auto& label : m_feature_order) m_record.features.push_back(m_features.at(label));
  m_record.simulated_time_s = m_machine.state().time_s;
  for (auto& [label, device] : m_devices)
    if (device.stream) device.stream->flush();
}

}  // namespace metron::runtime
