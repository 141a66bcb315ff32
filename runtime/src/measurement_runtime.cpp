// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/measurement_runtime.hpp"

#include <algorithm>
#include <filesystem>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "detail/fit_actual.hpp"
#include "metron/machine/compensation/compensated_machine.hpp"
#include "metron/runtime/block_plan.hpp"
#include "metron/runtime/outputs.hpp"
#include "metron/runtime/scan.hpp"
#include "metron/runtime/scan_segmentation.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/fitting/minimum_zone.hpp"

namespace metron::runtime {

MeasurementRuntime::MeasurementRuntime(machine::Machine& machine, const SourceManager& sources, RunRecord& record)
    : m_machine(machine), m_sources(sources), m_record(record) {
  m_alignments["MCS"] = m_alignment;
}

void MeasurementRuntime::warn(Span span, const std::string& message) { record(span, "warning", message); }

void MeasurementRuntime::note(Span span, const std::string& message) { record(span, "note", message); }

void MeasurementRuntime::record(Span span, const char* severity, const std::string& message) {
  if (!span.valid()) {
    m_record.diagnostics.push_back(fmt::format("{}: {}", severity, message));
    return;
  }
  const Location loc = m_sources.locate(span);
  m_record.diagnostics.push_back(fmt::format("{}:{}:{}: {}: {}", loc.path, loc.line, loc.column, severity, message));
}

void MeasurementRuntime::emit(RunEvent event) {
  if (m_on_event) m_on_event(event);
  m_record.events.push_back(std::move(event));
}

Result<void> MeasurementRuntime::define_feature(const std::string& label, const Geometry& nominal, Span span) {
  Feature f;
  f.label = label;
  f.nominal = to_machine(nominal, m_alignment.part_to_machine);
  f.nominal_frame = m_alignment.part_to_machine;
  f.nominal_rests_on_s = m_alignment.rests_on_s;
  f.nominal.direction.normalize();
  if (f.nominal.normal2.norm() > 0) f.nominal.normal2.normalize();
  if (f.nominal.slot_axis.norm() > 0) f.nominal.slot_axis.normalize();
  f.defined_at = span;
  if (!m_features.count(label)) m_feature_order.push_back(label);
  m_features[label] = std::move(f);
  return {};
}

Result<void> MeasurementRuntime::define_reported_actual(const std::string& label, const Geometry& actual_current,
                                                        Span span) {
  if (!m_features.count(label)) {
    if (auto r = define_feature(label, actual_current, span); !r) return r;
  }
  Feature& f = m_features.at(label);
  Geometry actual = to_machine(actual_current, m_alignment.part_to_machine);
  actual.direction.normalize();
  if (actual.normal2.norm() > 0) actual.normal2.normalize();
  if (actual.slot_axis.norm() > 0) actual.slot_axis.normalize();
  f.actual = actual;
  f.source = ActualSource::Measured;
  f.rests_on_s = m_machine.state().time_s;
  f.points.clear();
  f.fit.reset();
  f.measured_at = span;
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

bool MeasurementRuntime::label_exists(const std::string& prefix, const std::string& label) const {
  if (prefix == "F") return m_features.count(label) > 0;
  if (prefix == "FA") {
    const auto it = m_features.find(label);
    return it != m_features.end() && it->second.actual.has_value();
  }
  if (prefix == "D") return m_alignments.count(label) > 0 || label == "MCS";
  if (prefix == "DA") return m_alignments.count(label) > 0 || m_saved.count(label) > 0 || label == "MCS";
  if (prefix == "T") return m_tolerances.count(label) > 0;
  if (prefix == "TA") return last_tolerance_results(label) != nullptr;
  if (prefix == "S") return m_sensors.count(label) > 0;
  if (prefix == "SA") return m_sensors.count(label) > 0;
  if (prefix == "DID") return m_devices.count(label) > 0;
  return false;
}

Result<Geometry> MeasurementRuntime::resolve(const FeatureRef& ref, Span span) const {
  const Feature* f = find_feature(ref.label);
  if (!f)
    return program_error(span, ref.actual
                                   ? fmt::format("FA({}) is not defined yet: it has no actual (one from an earlier run "
                                                 "of the CMM software is not kept)",
                                                 ref.label)
                                   : fmt::format("feature F({}) is not defined", ref.label));
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

Result<void> MeasurementRuntime::select_sensor(const std::string& label, Span span, bool requalify) {
  if (!m_sensors.count(label)) {
    // Not defined by the program: a sensor of the machine's probe library (docs/language.md).
    if (auto r = select_library_sensor(label, span); !r) return r;
  }
  auto r = run_commands({machine::Command{0, machine::SelectTool{label}}}, {span});
  if (!r) return tl::unexpected(r.error());
  m_active_sensor = label;
  const auto& tool = r->front().tool;
  if (tool) m_tools[label] = *tool;
  if (tool && (!tool->qualified || requalify)) {
    m_qualification_feed_mm_s = m_machine.state().measuring_feed_mm_s;
    m_feed_change_warned = false;
    m_scanning_radius_mm.erase(label);  // a scan qualifies it again too
    // Qualify on the reference sphere before the first use: the effective radius absorbs the
    // pre-travel and trigger delays at the measuring feed.
    auto q = run_commands({machine::Command{0, machine::QualifyTool{}}}, {span});
    if (!q) return tl::unexpected(q.error());
    if (!q->empty() && q->front().tool) m_tools[label] = *q->front().tool;
  }
  return {};
}

Result<void> MeasurementRuntime::select_library_sensor(const std::string& label, Span span) {
  // Asked directly, not through run_commands: a name the library does not hold is no fault of
  // the run but a documented default (a warning and a 4 mm tip), so no fault is recorded.
  m_machine.submit(machine::Command{0, machine::SelectTool{label}});
  const auto responses = m_machine.execute();
  if (!responses.empty() && responses.front().status == machine::Response::Status::Done && responses.front().tool) {
    const auto& tool = *responses.front().tool;
    SensorDefinition def;
    def.label = label;
    def.ball_diameter_mm = 2 * tool.nominal_radius_mm;
    m_sensors[label] = def;
    m_tools[label] = tool;
    return {};
  }
  if (!responses.empty() && responses.front().fault &&
      responses.front().fault->kind != machine::FaultKind::UnknownTool) {
    record_fault(*responses.front().fault, span);
    return tl::unexpected(
        RuntimeError{RuntimeError::Kind::Fault, responses.front().fault->message, span, responses.front().fault});
  }
  warn(span, fmt::format("sensor {} is not in the machine's probe library; using a 4 mm default tip", label));
  SensorDefinition def;
  def.label = label;
  return define_sensor(def, span);
}

Result<void> MeasurementRuntime::ensure_tool(Span span) {
  if (!m_active_sensor.empty()) return {};
  warn(span, "no sensor selected before the first measurement; using a 4 mm default probe");
  SensorDefinition def;
  def.label = "METRON_DEFAULT";
  if (auto r = define_sensor(def, span); !r) return r;
  return select_sensor(def.label, span);
}

Result<void> MeasurementRuntime::set_feeds(std::optional<double> positioning, std::optional<double> measuring,
                                           Span span) {
  machine::SetFeeds feeds;
  if (positioning) feeds.positioning_mm_s = *positioning;
  if (measuring) feeds.measuring_mm_s = *measuring;
  if ((positioning && !(*positioning > 0)) || (measuring && !(*measuring > 0)))
    return program_error(span, "a feed rate must be positive");
  // The virtual CMM steps time at dt: FEDRAT/POSVEL,1e-9 made one move last 1e11 simulated
  // seconds and never finish (issue 15); no CMM moves slower than 10 um/s (docs/limits.md).
  constexpr double min_feed_mm_s = 0.01;
  if ((positioning && *positioning < min_feed_mm_s) || (measuring && *measuring < min_feed_mm_s))
    return program_error(
        span, fmt::format("a feed rate of {:g} mm/s is below the minimum of {:g} mm/s (docs/limits.md)",
                          positioning && *positioning < min_feed_mm_s ? *positioning : *measuring, min_feed_mm_s));
  if (!m_default_feeds) {
    const auto before = m_machine.state();
    m_default_feeds = std::make_pair(before.positioning_feed_mm_s, before.measuring_feed_mm_s);
  }
  if (measuring) {
    if (auto ok = check_probing_feed(*measuring, span); !ok) return ok;
    m_measuring_feed_explicit = *measuring;
  }
  auto r = run_commands({machine::Command{0, feeds}}, {span});
  if (!r) return tl::unexpected(r.error());
  return {};
}

Result<void> MeasurementRuntime::characterise_machine(const std::optional<std::string>& path, Span span) {
  if (m_machine.state().nominal) {
    // A dry run's machine has no dynamics to measure (its moves take no ramp, its touches no
    // delay): the run goes on with the default touch, as it would without the statement.
    warn(span,
         "CHARACTERISE in a dry run: the nominal machine has no dynamics to characterise; no file is written "
         "and PTMEAS keep the default touch");
    return {};
  }
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
    if (auto refused = m_policy.refuse_write(p.string()))
      return program_error(span, "CALL/EXTERN,SYS 'CHARACTERISE': " + *refused);
    if (auto ok = save_characterisation(*c, p.string()); !ok)
      return program_error(span, "CALL/EXTERN,SYS 'CHARACTERISE': " + ok.error());
  }
  text("PRINT", format_characterisation(*c));
  m_characterisation = std::move(*c);
  if (m_measuring_feed_explicit) return check_probing_feed(*m_measuring_feed_explicit, span);
  return {};
}

Result<void> MeasurementRuntime::use_characterisation(const std::string& path, Span span) {
  if (auto refused = m_policy.refuse_read(path))
    return program_error(span, "CALL/EXTERN,SYS 'CHARACTERISATION': " + *refused);
  auto c = load_characterisation(path);
  if (!c) return program_error(span, c.error());
  m_characterisation = std::move(*c);
  if (m_measuring_feed_explicit) return check_probing_feed(*m_measuring_feed_explicit, span);
  return {};
}

Result<void> MeasurementRuntime::use_compensation(const std::string& path, Span span) {
  auto* compensated = dynamic_cast<machine::CompensatedMachine*>(&m_machine);
  if (auto refused = m_policy.refuse_read(path))
    return program_error(span, "CALL/EXTERN,SYS 'COMPENSATION': " + *refused);
  if (!compensated) return program_error(span, "this machine backend takes no compensation map");
  auto map = machine::load_error_map(path);
  if (!map) return program_error(span, map.error());
  compensated->set_map(std::move(*map));
  return {};
}

Result<void> MeasurementRuntime::check_probing_feed(double measuring_mm_s, Span span) const {
  if (!m_characterisation || measuring_mm_s <= m_characterisation->max_probe_feed_mm_s) return {};
  return program_error(span,
                       fmt::format("probing feed {:.3f} mm/s exceeds the maximum protected feed {:.3f} mm/s of "
                                   "this machine (its stop distance would exceed {:.0f} % of the probe's "
                                   "{:.3f} mm over-travel; docs/touch-trigger.md)",
                                   measuring_mm_s, m_characterisation->max_probe_feed_mm_s,
                                   100 * m_characterisation->over_travel_margin, m_characterisation->over_travel_mm));
}

Result<void> MeasurementRuntime::restore_default_feed(bool positioning, Span span) {
  if (!m_default_feeds) return {};  // no FEDRAT yet: the machine's own feeds hold
  const double feed = positioning ? m_default_feeds->first : m_default_feeds->second;
  if (!(feed > 0)) return {};  // a backend that does not tell its feeds
  return positioning ? set_feeds(feed, std::nullopt, span) : set_feeds(std::nullopt, feed, span);
}

Result<void> MeasurementRuntime::restore_default_acceleration(Span span) {
  machine::SetFeeds feeds;
  feeds.default_acceleration = true;
  auto r = run_commands({machine::Command{0, feeds}}, {span});
  if (!r) return tl::unexpected(r.error());
  return {};
}

Result<void> MeasurementRuntime::set_acceleration(double acceleration_mm_s2, Span span) {
  if (!(acceleration_mm_s2 > 0)) return program_error(span, "an acceleration must be positive");
  machine::SetFeeds feeds;
  feeds.acceleration_mm_s2 = acceleration_mm_s2;
  auto r = run_commands({machine::Command{0, feeds}}, {span});
  if (!r) return tl::unexpected(r.error());
  return {};
}

Vec3 MeasurementRuntime::position_current() const { return m_alignment.to_part_point(m_machine.state().position_mm); }

Result<void> MeasurementRuntime::go_to(const Vec3& point, Span span) {
  auto r = run_commands({machine::Command{0, machine::GoTo{m_alignment.to_machine_point(point), {}}}}, {span});
  if (!r) return tl::unexpected(r.error());
  return {};
}

Result<void> MeasurementRuntime::go_home(Span span) {
  const auto home = m_program_home ? m_program_home : m_machine.state().home_mm;
  if (!home) {
    warn(span, "GOHOME: this machine does not say where its home is; the probe stays where it is");
    return {};
  }
  auto r = run_commands({machine::Command{0, machine::GoTo{*home, {}}}}, {span});
  if (!r) return tl::unexpected(r.error());
  return {};
}

BlockPlanContext MeasurementRuntime::plan_context() const {
  BlockPlanContext context;
  context.alignment = m_alignment;
  context.probe = m_probe;
  context.scan = m_scan;
  context.mode = m_mode;
  context.paths = &m_paths;
  context.characterisation = characterisation();
  context.touch_baseline = m_touch_baseline;
  context.measuring_feed_mm_s = m_measuring_feed_explicit;
  context.state = m_machine.state();
  return context;
}

// A measurement that faulted keeps every point obtained before the fault; the feature gets no
// actual (not an earlier one).
void MeasurementRuntime::keep_failed_points(Feature& feature, const std::vector<MeasuredPoint>& points, Span span) {
  feature.points = points;
  feature.measured_at = span;
  feature.actual.reset();
  feature.fit.reset();
}

// RPTMEAS (RationalDMIS, in an RMEAS ...,VECBLD block) give points of the surface around the
// feature: they are probed first, and the block's points are then taken relative to that surface,
// each moved by the mean deviation of the reference points along their normals (a hole's depth
// below the top face is kept from the actual face, as a relative measurement means). The reference
// points are not the feature's. A tilt of the surface is not followed: only its offset.
Result<MeasBlock> MeasurementRuntime::relative_to_reference_surface(const MeasBlock& block, const Feature& feature) {
  MeasBlock body = block;
  body.steps.clear();
  MeasBlock probe = block;
  probe.steps.clear();
  probe.plan_missing_points = false;
  for (const auto& step : block.steps) {
    if (step.kind != MeasStep::Kind::Reference) {
      body.steps.push_back(step);
      continue;
    }
    probe.steps.push_back(step);
    probe.steps.back().kind = MeasStep::Kind::PtMeas;
  }
  if (probe.steps.empty()) return body;
  auto plan = plan_block(probe, feature.nominal, plan_context());
  if (!plan) return tl::unexpected(plan.error());
  const auto execution = execute_commands(plan->commands, plan->spans);
  if (execution.error) return tl::unexpected(*execution.error);
  const auto taken = collect_points(*plan, execution, feature.label, block.span);
  Vec3 shift = Vec3::Zero();
  int counted = 0;
  for (const auto& p : taken) {
    if (!p.nominal_mm) continue;
    shift += (p.surface_mm() - *p.nominal_mm).dot(p.nominal_normal) * p.nominal_normal;
    ++counted;
  }
  if (counted > 0) shift /= counted;
  for (auto& step : body.steps)
    if (step.kind == MeasStep::Kind::PtMeas) step.point += shift;
  note(block.span, fmt::format("{} reference point{} (RPTMEAS) probed around F({}): the surface lies {:+.4f} mm from "
                               "its nominal, and the block's points are moved with it",
                               counted, counted == 1 ? "" : "s", feature.label,
                               counted > 0 ? shift.dot(taken.front().nominal_normal) : 0.0));
  return body;
}

Result<void> MeasurementRuntime::measure(const MeasBlock& block) {
  auto it = m_features.find(block.feature);
  if (it == m_features.end())
    return program_error(block.span, fmt::format("feature F({}) is not defined", block.feature));
  Feature& feature = it->second;
  if (auto t = ensure_tool(block.span); !t) return t;
  // A hole the ball cannot enter: a real probe would touch its rim, not its wall. Told for each
  // sensor that takes points in the block (SNSLCT inside it switches sensors).
  std::set<std::string> balls_checked;
  const auto check_ball = [&] {
    const auto tool = m_machine.state().tool;
    if (!tool || feature.nominal.side != Side::Inner || !balls_checked.insert(tool->name).second) return;
    const double ball_mm = 2 * tool->nominal_radius_mm;
    const bool round = feature.nominal.type == FeatureType::Circle || feature.nominal.type == FeatureType::Arc ||
                       feature.nominal.type == FeatureType::Cylinder || feature.nominal.type == FeatureType::Sphere;
    const double opening_mm =
        round ? feature.nominal.diameter_mm
        : feature.nominal.type == FeatureType::ParallelPlanes || feature.nominal.type == FeatureType::ClosedSlot
            ? feature.nominal.width_mm
        : feature.nominal.type == FeatureType::Ellipse ? feature.nominal.minor_diameter_mm
                                                       : 0.0;
    if (opening_mm > 0 && ball_mm >= opening_mm)
      warn(block.span, fmt::format("the ball of {} ({:.3f} mm) is not smaller than F({}) ({:.3f} mm): it cannot reach "
                                   "the wall",
                                   tool->name, ball_mm, feature.label, opening_mm));
  };
  // A SNSLCT inside the block (a feature probed with several sensors) switches the sensor between
  // its points, a FEDRAT, ACLRAT or SNSET changes a setting between them: each run of steps is
  // planned and measured with what was selected and set before it.
  auto relative = relative_to_reference_surface(block, feature);
  if (!relative) return tl::unexpected(relative.error());
  MeasBlock empty_run = block;
  empty_run.steps.clear();
  std::vector<MeasBlock> runs(1, empty_run);
  std::vector<const MeasStep*> selections(1, nullptr);
  for (const auto& step : relative->steps) {
    if (step.kind == MeasStep::Kind::SelectSensor || step.kind == MeasStep::Kind::Setting) {
      runs.push_back(empty_run);
      selections.push_back(&step);
    } else {
      runs.back().steps.push_back(step);
    }
  }
  // Without PTMEAS anywhere, the last sensor measures the planned points (AUTO, a nominal scan).
  const bool any_points = std::any_of(runs.begin(), runs.end(), takes_points);
  for (std::size_t k = 0; k < runs.size(); ++k) runs[k].plan_missing_points = !any_points && k + 1 == runs.size();
  std::vector<MeasuredPoint> points;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (selections[k]) {
      const MeasStep& before = *selections[k];
      if (auto r = before.kind == MeasStep::Kind::Setting ? before.apply(*this)
                                                          : select_sensor(before.path, before.span, before.requalify);
          !r) {
        keep_failed_points(feature, points, block.span);
        return r;
      }
    }
    if (runs[k].steps.empty() && !runs[k].plan_missing_points) continue;
    if (takes_points(runs[k]) || runs[k].plan_missing_points) check_ball();
    auto plan = plan_block(runs[k], feature.nominal, plan_context());
    if (!plan) return tl::unexpected(plan.error());
    const bool scans = std::any_of(plan->commands.begin(), plan->commands.end(), [](const machine::Command& c) {
      return std::holds_alternative<machine::ScanPath>(c.body) ||
             std::holds_alternative<machine::ScanBufferWrite>(c.body);
    });
    if (scans) {
      if (auto r = scanning_radius(block.span); !r) return tl::unexpected(r.error());
    }
    const auto execution = execute_commands(plan->commands, plan->spans);  // a copy: collect_points reads the PtMeas
    const auto taken = collect_points(*plan, execution, feature.label, block.span);
    points.insert(points.end(), taken.begin(), taken.end());
    if (execution.error) {
      keep_failed_points(feature, points, block.span);
      return tl::unexpected(*execution.error);
    }
  }
  feature.points = points;
  feature.measured_at = block.span;
  feature.source = ActualSource::Measured;
  const bool scanned = std::any_of(points.begin(), points.end(), [](const MeasuredPoint& p) { return p.scanned; });
  if (!scanned && block.point_count > 0 && static_cast<int>(points.size()) != block.point_count) {
    warn(block.span, fmt::format("MEAS declared {} points but {} were measured", block.point_count, points.size()));
  }
  auto fitted = fit_actual(feature.nominal, points);
  if (!fitted) {
    feature.actual.reset();
    feature.fit.reset();
    auto e = program_error(block.span, fitted.error());
    e.value().bad_geometry = true;
    return e;
  }
  feature.actual = fitted->first;
  feature.fit = fitted->second;
  feature.rests_on_s = std::numeric_limits<double>::infinity();
  for (const MeasuredPoint& p : points) feature.rests_on_s = std::min(feature.rests_on_s, p.time_s);
  apply_fit_algorithm(*feature.actual, points, feature.label, block.span);
  return {};
}

// GEOALG: MAXINS and MINCIR size and locate a circle, sphere or cylinder as a pin (ring) gauge
// would find it (ISO 14405-1 GX, GN); MINMAX gives the minimum-zone (Chebyshev) reference
// feature (ISO 12181-1 MZCI, ISO 12781-1 MZPL, and their sphere, cylinder and line counterparts):
// centred (or placed) where the zone holding the points is narrowest, a size of the zone's mean
// r_min + r_max. From the compensated surface points; a circle stays in its least-squares plane.
// The form figure stays the least-squares one; form tolerances give the minimum zone anyway.
void MeasurementRuntime::apply_fit_algorithm(Geometry& actual, const std::vector<MeasuredPoint>& points,
                                             const std::string& label, Span span) {
  const FeatureType type = actual.type == FeatureType::Arc ? FeatureType::Circle : actual.type;
  const auto chosen = m_fit_algorithms.find(type);
  if (chosen == m_fit_algorithms.end() || chosen->second == FitAlgorithm::LeastSquares) return;
  const FitAlgorithm algorithm = chosen->second;
  const fitting::Shape shape = fit_shape(type);
  std::vector<Vec3> surface;
  for (const auto& p : points) surface.push_back(p.surface_mm());
  // The least-squares sense of a direction is kept: a reference feature has no sense of its own.
  const auto same_sense = [&](const Vec3& d) { return d.dot(actual.direction) < 0 ? Vec3(-d) : d; };
  const std::optional<Vec3> hint = type == FeatureType::Line     ? std::optional<Vec3>(actual.normal2)
                                   : type == FeatureType::Sphere ? std::nullopt
                                                                 : std::optional<Vec3>(actual.direction);
  // The reference feature's position where the least-squares one was: a circle stays in its
  // plane; a line's or cylinder's position slides onto the new axis, a plane's onto the new plane.
  const auto place_reference = [&](const Vec3& position, const Vec3& direction) {
    const Vec3 d = same_sense(direction.normalized());
    switch (type) {
      case FeatureType::Circle: {
        const Vec3 n = actual.direction.normalized();
        actual.position = position + (actual.position - position).dot(n) * n;
        break;
      }
      case FeatureType::Sphere: actual.position = position; break;
      case FeatureType::Cone:  // its position is its apex
        actual.position = position;
        actual.direction = d;
        break;
      case FeatureType::Plane:
        actual.position -= (actual.position - position).dot(d) * d;
        actual.direction = d;
        break;
      default:  // line, cylinder
        actual.position = position + (actual.position - position).dot(d) * d;
        actual.direction = d;
    }
  };
  if (algorithm == FitAlgorithm::MinimumZone) {
    const auto zone = fitting::minimum_zone(shape, surface, hint);
    if (!zone) {
      warn(span, fmt::format("GEOALG MINMAX: F({}) has no minimum-zone {}; its least-squares fit is kept", label,
                             fitting::to_string(shape)));
      return;
    }
    place_reference(zone->position, zone->direction);
    if (type == FeatureType::Circle || type == FeatureType::Sphere || type == FeatureType::Cylinder)
      actual.diameter_mm = zone->zone_diameter_mm;
    if (type == FeatureType::Cone) actual.apex_angle_deg = zone->apex_angle_deg;
    return;
  }
  const bool inscribed = algorithm == FitAlgorithm::MaximumInscribed;
  const auto extreme = fitting::extreme_feature(shape, surface, inscribed, hint);
  if (!extreme) {
    warn(span, fmt::format("GEOALG {}: the points of F({}) do not surround their {}; its least-squares fit is kept",
                           inscribed ? "MAXINS" : "MINCIR", label, type == FeatureType::Cylinder ? "axis" : "centre"));
    return;
  }
  place_reference(extreme->position, extreme->direction);
  actual.diameter_mm = extreme->diameter_mm;
}

std::vector<MeasuredPoint> MeasurementRuntime::collect_points(const BlockPlan& plan, const Execution& execution,
                                                              const std::string& feature, Span block_span) {
  std::vector<MeasuredPoint> points;
  const auto span_of = [&](std::size_t i) { return i < plan.spans.size() ? plan.spans[i] : block_span; };
  for (const auto& r : execution.responses)
    if (r.hit) {
      const std::size_t i = static_cast<std::size_t>(r.tag - execution.first_tag);
      Vec3 centre = r.hit->centre_mm;
      if (!m_characterisation && !m_feed_change_warned && i < plan.measuring_feed_mm_s.size() &&
          m_qualification_feed_mm_s > 0 &&
          std::abs(plan.measuring_feed_mm_s[i] - m_qualification_feed_mm_s) > 0.01 * m_qualification_feed_mm_s) {
        // The effective radius absorbs the pre-travel and trigger delays at the qualification
        // feed only: at another feed every point moves by the delay times the feed difference.
        m_feed_change_warned = true;
        warn(span_of(i),
             fmt::format("probing at {:.3f} mm/s, but the probe was qualified at {:.3f} mm/s: its effective "
                         "radius holds the trigger delay at that feed only, so points move along their "
                         "normals (set FEDRAT/MESVEL before the sensor's first SNSLCT, which qualifies it, or "
                         "characterise the machine, docs/touch-trigger.md); told once",
                         plan.measuring_feed_mm_s[i], m_qualification_feed_mm_s));
      }
      if (m_characterisation && i < plan.measuring_feed_mm_s.size())
        // The effective radius holds the delay distance at the qualification feed; a hit at
        // another feed is latched farther (or less far) past the surface (SEEDS.md 3).
        centre += m_characterisation->dynamic_correction_mm(plan.measuring_feed_mm_s[i], m_qualification_feed_mm_s) *
                  r.hit->normal;
      points.push_back({centre, r.hit->normal, r.hit->ball_radius_mm, r.hit->time_s, span_of(i), false, std::nullopt,
                        Vec3::UnitZ()});
      const auto* pt = i < plan.commands.size() ? std::get_if<machine::PtMeas>(&plan.commands[i].body) : nullptr;
      if (pt) {
        points.back().nominal_mm = pt->nominal_mm;
        points.back().nominal_normal = pt->normal;
      }
      // Issue 11: a surface beyond the nominal tolerance is touched while still accelerating.
      const auto early = pt && m_characterisation ? m_characterisation->early_contact_mm(*pt, *r.hit) : std::nullopt;
      if (early)
        warn(span_of(i),
             fmt::format(
                 "the surface lies about {:.3f} mm above its nominal, beyond the nominal tolerance of {:.3f} mm: "
                 "the probe touched it before reaching the probing feed and the point may be off "
                 "(raise the tolerance or SNSET/APPRCH)",
                 *early, m_characterisation->nominal_tolerance_mm));
    }
  // Scanned samples: the deflection direction is the surface normal estimate (SEEDS.md 1: eu);
  // compensated with the nominal radius (no pre-travel: the deflection is read, see scan.cpp).
  const auto tool = m_machine.state().tool;
  for (const auto& r : execution.responses)
    for (const auto& line : r.scan_log) m_record.machine_log.push_back(feature + ": " + line);
  for (const auto& r : execution.responses)
    for (const auto& sample : r.scan) {
      const double e = sample.deflection_mm.norm();
      if (!(e > 0)) continue;  // not in contact
      const std::size_t i = static_cast<std::size_t>(r.tag - execution.first_tag);
      const auto qualified = tool ? m_scanning_radius_mm.find(tool->name) : m_scanning_radius_mm.end();
      const double radius_mm = qualified != m_scanning_radius_mm.end() ? qualified->second
                               : tool                                  ? tool->nominal_radius_mm
                                                                       : 0.0;
      points.push_back({sample.centre_mm, sample.deflection_mm / e, radius_mm, sample.time_s, span_of(i), true,
                        std::nullopt, Vec3::UnitZ()});
    }
  return points;
}

// Scanning-probe qualification. A scanning probe reads its deflection, so the touch-trigger
// effective radius (which absorbs pre-travel and trigger delays) does not apply to its samples;
// what does is the ball's true radius and any bias of the deflection reading at the scan's
// reference deflection. Scanning the certified reference sphere's equator measures both: the
// ball centres lie on a circle of radius R + r_scan about the sphere's centre (ISO 10360-4 scans
// a sphere the same way). The centre comes from the touch qualification's points.
Result<double> MeasurementRuntime::scanning_radius(Span span) {
  const auto state = m_machine.state();
  if (!state.tool) return program_error(span, "no sensor selected for the scan: SNSLCT first");
  const machine::ToolInfo tool = *state.tool;
  if (auto it = m_scanning_radius_mm.find(tool.name); it != m_scanning_radius_mm.end()) return it->second;
  if (!tool.qualified || tool.qualification_centres_mm.size() < 4 || !(tool.reference_diameter_mm > 0))
    return tool.nominal_radius_mm;
  fitting::FitOptions sphere_options;
  sphere_options.inner = false;
  const auto sphere = fitting::fit(fitting::Shape::Sphere, tool.qualification_centres_mm, sphere_options);
  if (!sphere) return tool.nominal_radius_mm;
  const double big_r = tool.reference_diameter_mm / 2;
  const Vec3 centre = sphere->position;
  Geometry equator;
  equator.type = FeatureType::Circle;
  equator.side = Side::Outer;
  equator.position = centre;
  equator.direction = Vec3::UnitZ();
  equator.diameter_mm = tool.reference_diameter_mm;
  auto contour = nominal_contour(equator, centre + big_r * Vec3::UnitX(), 0, Vec3::UnitZ(), Vec3::UnitX(),
                                 m_scan.sample_spacing_mm > 0 ? m_scan.sample_spacing_mm : 0.5);
  if (!contour) return program_error(span, "scanning qualification: " + contour.error());
  auto scan = scan_command(*contour, plan_context(), span);
  if (!scan) return tl::unexpected(scan.error());
  // Up, over the sphere beside the start, down to the equator; the scan; back up and to where
  // the probe was, so the block's plan goes on from there.
  const double r = tool.nominal_radius_mm;
  const double safe_z = std::max(centre.z() + big_r + r + 10, state.position_mm.z());
  const Vec3 start_side = centre + (big_r + r + scan->approach_mm + 1) * contour->points.front().normal;
  std::vector<machine::Command> commands;
  const auto go = [&](const Vec3& p) { commands.push_back(machine::Command{0, machine::GoTo{p, std::nullopt}}); };
  go({state.position_mm.x(), state.position_mm.y(), safe_z});
  go({start_side.x(), start_side.y(), safe_z});
  go(start_side);
  // As the machine takes scans: whole, or as measurement commands into its buffers.
  for (machine::Command& c : scan_commands(*scan, state.scan_buffer_segments)) commands.push_back(std::move(c));
  go({start_side.x(), start_side.y(), safe_z});
  go({state.position_mm.x(), state.position_mm.y(), safe_z});
  go(state.position_mm);
  const std::size_t count = commands.size();
  auto responses = run_commands(std::move(commands), std::vector<Span>(count, span));
  if (!responses) return tl::unexpected(responses.error());
  std::vector<Vec3> centres;
  for (const auto& response : *responses)
    for (const auto& sample : response.scan)
      if (sample.deflection_mm.norm() > 0) centres.push_back(sample.centre_mm);
  if (centres.size() < 8)
    return program_error(span, fmt::format("scanning qualification: the scan of the reference sphere gave {} samples "
                                           "in contact",
                                           centres.size()));
  fitting::FitOptions circle_options;
  circle_options.inner = false;
  circle_options.direction_hint = Vec3::UnitZ();
  const auto circle = fitting::fit(fitting::Shape::Circle, centres, circle_options);
  if (!circle) return program_error(span, "scanning qualification: the circle fit failed");
  // The equator of the ball-centre sphere (radius R + r) at the height scanned: the circle found
  // is its section at that height, so the sphere radius is sqrt(rho^2 + dz^2).
  const double dz = circle->position.z() - centre.z();
  const double radius_mm = std::sqrt(std::pow(circle->diameter_mm / 2, 2) + dz * dz) - big_r;
  m_scanning_radius_mm[tool.name] = radius_mm;
  m_record.machine_log.push_back(
      fmt::format("scanning qualification of {}: {} samples on the reference sphere's "
                  "equator, scanning radius {:.4f} mm (nominal {:.4f}, touch effective {:.4f})",
                  tool.name, centres.size(), radius_mm, tool.nominal_radius_mm, tool.effective_radius_mm));
  return radius_mm;
}

Result<const Datum*> MeasurementRuntime::datum(const std::string& label, Span span) const {
  auto it = m_datums.find(label);
  if (it == m_datums.end())
    return program_error(span, fmt::format("datum DAT({}) is not defined: use DATDEF first", label));
  return &it->second;
}

Result<void> MeasurementRuntime::define_datum(const FeatureRef& ref, const std::string& label, Span span) {
  auto g = resolve(ref, span);
  if (!g) return tl::unexpected(g.error());
  const Feature* f = find_feature(ref.label);
  m_datums[label] = Datum{label, ref.label, *g, f->nominal, f->nominal_frame, rests_on_s(ref)};
  return {};
}

void MeasurementRuntime::set_alignment(const std::string& label, const Frame& frame, double rests_on_s,
                                       const Frame& nominal_motion) {
  const Frame placement = nominal_motion * m_alignment.nominal_placement;
  move_nominals(nominal_motion);
  m_alignment = Alignment{label, frame, rests_on_s, placement};
  m_alignments[label] = m_alignment;
}

// A system built on measured features carries the nominals written before it onto the part, as
// its nominal frame (the same statement on the features' nominals) lies to its actual frame; the
// nominals written in it are placed through it as they are written. A feature reported in such a
// system then shows its deviation from where the drawing puts it relative to those features, not
// where the part happened to lie (docs/alignments.md).
// What an earlier set-up measured (before an operator stop, not yet carried into this set-up by
// EQUATE) keeps its nominal with its actual: the part has been moved since.
void MeasurementRuntime::move_nominals(const Frame& motion) {
  if (motion.isApprox(Frame::Identity(), 1e-15)) return;
  const auto group = [&](std::size_t setup) {
    return setup < m_setup_carried_to.size() ? m_setup_carried_to[setup] : setup;
  };
  const auto in_this_setup = [&](double rests_on_s) {
    if (!std::isfinite(rests_on_s)) return true;
    const auto taken = static_cast<std::size_t>(std::count_if(m_operator_stops_s.begin(), m_operator_stops_s.end(),
                                                              [&](double stop) { return stop < rests_on_s; }));
    return group(taken) == group(m_operator_stops_s.size());
  };
  for (auto& [label, f] : m_features) {
    if (f.actual && !in_this_setup(f.rests_on_s)) continue;
    f.nominal = to_machine(f.nominal, motion);
    f.nominal_frame = motion * f.nominal_frame;
  }
  for (auto& [label, d] : m_datums) {
    if (!in_this_setup(d.rests_on_s)) continue;
    d.nominal = to_machine(d.nominal, motion);
    d.nominal_frame = motion * d.nominal_frame;
  }
}

Result<MeasurementRuntime::ResolvedSources> MeasurementRuntime::resolve_sources(const std::vector<FeatureRef>& sources,
                                                                                Span span) const {
  ResolvedSources out;
  for (const FeatureRef& s : sources) {
    auto g = resolve(s, span);
    if (!g) return tl::unexpected(g.error());
    out.geometry.push_back(*g);
    out.rests_on_s = std::min(out.rests_on_s, rests_on_s(s));
  }
  return out;
}

double MeasurementRuntime::rests_on_s(const FeatureRef& ref) const {
  const Feature* f = find_feature(ref.label);
  if (!ref.actual || !f || !f->actual) return std::numeric_limits<double>::infinity();
  return f->rests_on_s;
}

Result<void> MeasurementRuntime::datset(const std::string& label, const DatsetRequest& request, Span span) {
  double rests_on = std::numeric_limits<double>::infinity();
  if (request.mcs) {
    // The machine's own system: the nominals go back to where they were written.
    set_alignment(label, Frame::Identity(), rests_on, m_alignment.nominal_placement.inverse());
    return {};
  }
  // The frame rests on the features written here (not on the alignment it replaces: a DATSET of a
  // new set-up is made while the last set-up's alignment is current). The nominal frame is the
  // same statement on their nominals.
  std::vector<DatsetClause> clauses, nominal_clauses;
  for (const auto& c : request.clauses) {
    if (c.feature) {
      auto g = resolve(*c.feature, span);
      if (!g) return tl::unexpected(g.error());
      auto n = resolve(FeatureRef{c.feature->label, false}, span);
      if (!n) return tl::unexpected(n.error());
      clauses.push_back({*g, c.direction, c.minus, c.origins});
      nominal_clauses.push_back({*n, c.direction, c.minus, c.origins});
      rests_on = std::min(rests_on, rests_on_s(*c.feature));
      continue;
    }
    auto d = datum(c.datum, span);
    if (!d) return tl::unexpected(d.error());
    clauses.push_back({(*d)->geometry, c.direction, c.minus, c.origins});
    nominal_clauses.push_back({(*d)->nominal, c.direction, c.minus, c.origins});
    rests_on = std::min(rests_on, (*d)->rests_on_s);
  }
  auto frame = runtime::datset(m_alignment.part_to_machine, clauses);
  if (!frame) return program_error(span, frame.error());
  const auto nominal_frame = runtime::datset(m_alignment.part_to_machine, nominal_clauses);
  set_alignment(label, *frame, rests_on, nominal_frame ? Frame(*frame * nominal_frame->inverse()) : Frame::Identity());
  return {};
}

Result<void> MeasurementRuntime::set_clearance_surface(const FeatureRef& plane, double offset_mm, Span span) {
  auto g = resolve(plane, span);
  if (!g) return tl::unexpected(g.error());
  if (g->type != FeatureType::Plane)
    return program_error(span, fmt::format("SNSET/CLRSRF: {}({}) is {}; a clearance surface is a plane",
                                           plane.actual ? "FA" : "F", plane.label, dmis_word(g->type)));
  const Vec3 n = g->direction.normalized();
  if (std::abs(n.dot(m_alignment.to_machine_vector(Vec3::UnitZ()))) < 0.5)
    return program_error(span, fmt::format("SNSET/CLRSRF: {}({}) is steeper than 60 degrees to the part's Z axis; "
                                           "AUTO moves rise along Z to a clearance surface",
                                           plane.actual ? "FA" : "F", plane.label));
  m_probe.clearance_plane = ProbeSettings::ClearancePlane{g->position + offset_mm * n, n};
  return {};
}

Result<void> MeasurementRuntime::trans(const std::string& label, const TransRequest& request, Span span) {
  std::optional<double> origin[3], nominal_origin[3];
  // Moved by numbers only, the frame rests on what the current one rests on; moved to features,
  // on those. The nominal frame is moved to the features' nominals.
  double rests_on = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (request.value[k]) origin[k] = nominal_origin[k] = request.value[k];
    if (request.feature[k]) {
      auto g = resolve(*request.feature[k], span);
      if (!g) return tl::unexpected(g.error());
      auto n = resolve(FeatureRef{request.feature[k]->label, false}, span);
      if (!n) return tl::unexpected(n.error());
      origin[k] = m_alignment.to_part_point(g->position)[k];
      nominal_origin[k] = m_alignment.to_part_point(n->position)[k];
      rests_on = std::min(rests_on, rests_on_s(*request.feature[k]));
    }
  }
  if (std::isinf(rests_on)) rests_on = m_alignment.rests_on_s;
  const Frame frame = translate_origin(m_alignment.part_to_machine, origin);
  set_alignment(label, frame, rests_on,
                frame * translate_origin(m_alignment.part_to_machine, nominal_origin).inverse());
  return {};
}

Result<void> MeasurementRuntime::rotate(const std::string& label, const RotateRequest& request, Span span) {
  if (request.angle_deg) {
    set_alignment(label, rotate_about(m_alignment.part_to_machine, request.about, *request.angle_deg),
                  m_alignment.rests_on_s);
    return {};
  }
  if (!request.feature) return program_error(span, "ROTATE needs an angle or a feature");
  auto g = resolve(*request.feature, span);
  if (!g) return tl::unexpected(g.error());
  auto n = resolve(FeatureRef{request.feature->label, false}, span);
  if (!n) return tl::unexpected(n.error());
  // Turning d onto -X is turning -d onto +X.
  const double sign = request.align_negative ? -1.0 : 1.0;
  auto frame = rotate_to(m_alignment.part_to_machine, request.about, sign * g->direction, request.align);
  if (!frame) return program_error(span, frame.error());
  const auto nominal_frame = rotate_to(m_alignment.part_to_machine, request.about, sign * n->direction, request.align);
  const double rests_on = rests_on_s(*request.feature);
  set_alignment(label, *frame, std::isinf(rests_on) ? m_alignment.rests_on_s : rests_on,
                nominal_frame ? Frame(*frame * nominal_frame->inverse()) : Frame::Identity());
  return {};
}

Result<void> MeasurementRuntime::save(const std::string& label, Span span) {
  auto it = m_alignments.find(label);
  if (it == m_alignments.end())
    return program_error(span, fmt::format("coordinate system D({}) is not defined", label));
  m_saved[label] = it->second;
  return {};
}

// DA(label) as RECALL and EQUATE read it: the SAVEd system, else the one defined last.
const Alignment* MeasurementRuntime::find_alignment(const std::string& label) const {
  if (const auto it = m_saved.find(label); it != m_saved.end()) return &it->second;
  if (const auto it = m_alignments.find(label); it != m_alignments.end()) return &it->second;
  return nullptr;
}

Result<void> MeasurementRuntime::recall(const std::string& label, Span span) {
  const Alignment* found = find_alignment(label);
  if (!found) return program_error(span, fmt::format("coordinate system D({}) is not defined or saved", label));
  const Alignment recalled = *found;  // a copy: moving the nominals does not touch the stores
  move_nominals(recalled.nominal_placement * m_alignment.nominal_placement.inverse());
  m_alignment = recalled;
  return {};
}

// OUTPUT/S(x), OUTPUT/SA(x): a sensor's definition or its qualification, as a report line and a
// DMIS comment line ($$) in the output file (metron reads its own output file back).
void MeasurementRuntime::output_sensor(const std::string& label, bool actual, Span span) {
  const auto def = m_sensors.find(label);
  const auto tool = m_tools.find(label);
  if (def == m_sensors.end() || tool == m_tools.end()) {
    warn(span, fmt::format("{}({}) is not defined or selected yet: nothing to output", actual ? "SA" : "S", label));
    return;
  }
  const auto length = [&](double mm) { return length_text(mm, m_report_units) + " " + unit_word(m_report_units); };
  std::string text;
  if (!actual) {
    const Vec3 d = def->second.direction;
    text = fmt::format("S({}): probe tip {} diameter, stylus {} along ({:.4f}, {:.4f}, {:.4f})", label,
                       length(def->second.ball_diameter_mm), length(def->second.length_mm), d.x(), d.y(), d.z());
  } else {
    const machine::ToolInfo& t = tool->second;
    text = fmt::format("SA({}): tip {} nominal diameter, ", label, length(2 * t.nominal_radius_mm));
    text += t.qualified ? fmt::format("{} effective (qualified on the reference sphere, form {})",
                                      length(2 * t.effective_radius_mm), length(t.qualification_form_mm))
                        : std::string("not qualified yet");
    if (const auto sc = m_scanning_radius_mm.find(label); sc != m_scanning_radius_mm.end())
      text += fmt::format("; scanning {} effective", length(2 * sc->second));
  }
  write_device_line("$$ " + text);
  emit(TextReport{text});
}

// OUTPUT/D(x), OUTPUT/DA(x): where the coordinate system stands in the machine's: its origin and
// its axes, as a report line and a DMIS comment line ($$) in the output file.
void MeasurementRuntime::output_coordinate_system(const std::string& label, bool actual, Span span) {
  Frame frame = Frame::Identity();  // D(MCS): the machine's own, unless the program defined one so named
  if (const auto it = m_alignments.find(label); it != m_alignments.end()) {
    frame = it->second.part_to_machine;
  } else if (const auto saved = m_saved.find(label); saved != m_saved.end()) {
    frame = saved->second.part_to_machine;
  } else if (label != "MCS") {
    warn(span, fmt::format("D({}) is not defined yet: nothing to output", label));
    return;
  }
  const Vec3 o = frame.translation();
  const auto axis = [&](int k) {
    const Vec3 a = frame.linear().col(k);
    return fmt::format("({:.6f}, {:.6f}, {:.6f})", a.x(), a.y(), a.z());
  };
  const ReportUnits& u = m_report_units;
  const std::string text =
      fmt::format("{}({}): origin ({}, {}, {}) {}, X axis {}, Y axis {}, Z axis {} in machine coordinates",
                  actual ? "DA" : "D", label, length_text(o.x(), u), length_text(o.y(), u), length_text(o.z(), u),
                  unit_word(u), axis(0), axis(1), axis(2));
  write_device_line("$$ " + text);
  emit(TextReport{text});
}

void MeasurementRuntime::write_device_line(const std::string& line) {
  for (auto& [label, device] : m_devices)
    if (device.open && device.stream && !device.direct) *device.stream << line << "\n";
}

Result<void> MeasurementRuntime::output(const std::vector<OutputItem>& items, Span span) {
  return output_or_evaluate(items, span, true);
}

Result<void> MeasurementRuntime::evaluate(const std::vector<OutputItem>& items, Span span) {
  return output_or_evaluate(items, span, false);
}

Result<void> MeasurementRuntime::output_or_evaluate(const std::vector<OutputItem>& items, Span span, bool report_them) {
  std::vector<const Feature*> features;
  std::vector<std::string> tolerances;
  if (report_them) {
    // The OUTPUT itself, then the result lines it produced (the DMIS output file's layout).
    std::string echo = "OUTPUT/";
    for (std::size_t i = 0; i < items.size(); ++i)
      echo +=
          (i ? ", " : "") +
          (items[i].kind == OutputItem::Kind::Tolerance ? fmt::format("TA({})", items[i].tolerance)
           : items[i].kind == OutputItem::Kind::Sensor
               ? fmt::format("{}({})", items[i].sensor_actual ? "SA" : "S", items[i].sensor)
           : items[i].kind == OutputItem::Kind::CoordinateSystem
               ? fmt::format("{}({})", items[i].coordinate_system_actual ? "DA" : "D", items[i].coordinate_system)
               : fmt::format("{}({}){}", items[i].feature.actual ? "FA" : "F", items[i].feature.label,
                             items[i].points ? fmt::format("[{},{}]", items[i].points->first, items[i].points->second)
                                             : std::string()));
    write_device_line(echo);
  }
  for (const auto& item : items) {
    if (item.kind == OutputItem::Kind::Sensor) {
      if (report_them) output_sensor(item.sensor, item.sensor_actual, span);
      continue;
    }
    if (item.kind == OutputItem::Kind::CoordinateSystem) {
      if (report_them) output_coordinate_system(item.coordinate_system, item.coordinate_system_actual, span);
      continue;
    }
    if (item.kind == OutputItem::Kind::Tolerance) {
      if (!find_tolerance(item.tolerance))
        return program_error(span, fmt::format("tolerance T({}) is not defined", item.tolerance));
      tolerances.push_back(item.tolerance);
      continue;
    }
    const Feature* f = find_feature(item.feature.label);
    if (!f) return program_error(span, fmt::format("feature F({}) is not defined", item.feature.label));
    features.push_back(f);
    if (!report_them) continue;
    FeatureReport report;
    report.label = f->label;
    report.frame = m_alignment.label;
    report.nominal = to_frame(f->nominal, m_alignment.part_to_machine);
    if (item.feature.actual && f->actual) report.actual = to_frame(*f->actual, m_alignment.part_to_machine);
    report.fit = f->fit;
    report.point_count = f->points.size();
    report.source = f->source;
    report.units = m_report_units;
    if (item.feature.actual && !f->actual) warn(span, fmt::format("OUTPUT of FA({}) before it was measured", f->label));
    if (item.points) {
      const int count = static_cast<int>(f->points.size());
      const auto [first, last] = *item.points;
      const int from = std::max(first, 1), to = std::min(last, count);  // what the feature has of the range
      if (first < 1 || last < first || last > count)
        warn(span,
             fmt::format(
                 "FA({})[{},{}] asks for points {} to {}; it has {}: {}", f->label, first, last, first, last, count,
                 from > to ? std::string("none is listed") : fmt::format("points {} to {} are listed", from, to)));
      const bool residuals = f->fit && f->fit->residuals_mm.size() == f->points.size();
      for (int i = from; i <= to; ++i) {
        const MeasuredPoint& p = f->points[static_cast<std::size_t>(i - 1)];
        ListedPoint listed;
        listed.index = i;
        listed.surface_mm = m_alignment.to_part_point(p.surface_mm());
        listed.approach = m_alignment.to_part_vector(p.normal);
        if (residuals) listed.residual_mm = f->fit->residuals_mm[static_cast<std::size_t>(i - 1)];
        report.points.push_back(listed);
      }
    }
    write_device_line(dmis_feature_line(report));
    emit(report);
  }
  for (const auto& t : tolerances) {
    std::vector<ToleranceResult> results;
    if (features.empty()) {
      // OUTPUT/TA(t) alone: what the last EVAL of it found (DMIS EVAL ... OUTPUT).
      auto kept = m_evaluated.find(t);
      if (kept == m_evaluated.end())
        return program_error(span, fmt::format("T({}) is output without a feature and was not evaluated before "
                                               "(EVAL/FA(x),TA({}) or OUTPUT/FA(x),TA({}))",
                                               t, t, t));
      results = kept->second;
    } else {
      auto evaluated = evaluate_tolerance(t, features, span);
      if (!evaluated && (m_strict || evaluated.error().kind != RuntimeError::Kind::Program))
        return tl::unexpected(evaluated.error());
      if (!evaluated) {
        warn(span, fmt::format("T({}) is not evaluated: {}; it is left out of this {} (--strict makes it an error)", t,
                               evaluated.error().message, report_them ? "OUTPUT" : "EVAL"));
        m_last_results.erase(t);
        m_evaluated.erase(t);
        continue;
      }
      results = std::move(*evaluated);
    }
    m_last_results[t] = results;
    if (!report_them) {
      m_evaluated[t] = std::move(results);
      continue;
    }
    for (auto& result : results) result.units = m_report_units;
    for (std::size_t i = 0; i < results.size(); ++i) {
      if (results[i].kind == ToleranceKind::Compos && results[i].tier == "PATERN" && i + 1 < results.size())
        write_device_line(dmis_composite_line(results[i], results[i + 1]));
      else if (results[i].kind != ToleranceKind::Compos)
        write_device_line(dmis_tolerance_line(results[i]));
      emit(results[i]);
    }
  }
  return {};
}

const std::vector<ToleranceResult>* MeasurementRuntime::last_tolerance_results(const std::string& label) const {
  auto it = m_last_results.find(label);
  return it == m_last_results.end() ? nullptr : &it->second;
}

Result<std::vector<ToleranceResult>> MeasurementRuntime::evaluate_tolerance(const std::string& t,
                                                                            const std::vector<const Feature*>& features,
                                                                            Span span) {
  const ToleranceSpec& spec = m_tolerances.at(t);
  ToleranceContext context;
  context.alignment = &m_alignment;
  context.units = m_report_units;
  context.working_plane = m_working_plane;
  for (const auto& d : spec.datums) {
    auto dd = datum(d, span);
    if (!dd) return tl::unexpected(dd.error());
    context.datums.push_back(*dd);
  }
  if (spec.kind == ToleranceKind::Compos) {
    // The pattern is every output feature together: two results, the PATERN and FEATUR tiers.
    for (const auto& d : spec.feature_datums) {
      auto dd = datum(d, span);
      if (!dd) return tl::unexpected(dd.error());
      context.feature_datums.push_back(*dd);
    }
    auto tiers = runtime::evaluate_composite(spec, features, context);
    if (!tiers) return program_error(span, tiers.error());
    return std::move(*tiers);
  }
  // DISTWRT and ANGWRT name their reference feature in the TOL statement itself: each output
  // feature is evaluated against it.
  std::vector<std::vector<const Feature*>> evaluations;
  std::optional<Feature> datum_reference;
  if (spec.reference_feature.empty() && (spec.kind == ToleranceKind::DistWrt || spec.kind == ToleranceKind::AngWrt) &&
      !spec.datums.empty()) {
    // TOL/DISTWRT,...,DAT(A),...: the distance is taken to the datum as DATDEF fixed it (its feature
    // measured again since does not move the datum, as for the datum reference frames above).
    auto d = datum(spec.datums.front(), span);
    if (!d) return tl::unexpected(d.error());
    const Feature* feature = find_feature((*d)->feature);
    if (!feature) return program_error(span, fmt::format("feature F({}) is not defined", (*d)->feature));
    datum_reference = *feature;
    datum_reference->actual = (*d)->geometry;
    datum_reference->points.clear();
  }
  if (!spec.reference_feature.empty() || datum_reference) {
    const Feature* reference = datum_reference ? &*datum_reference : find_feature(spec.reference_feature);
    if (!reference) return program_error(span, fmt::format("feature F({}) is not defined", spec.reference_feature));
    for (const Feature* f : features) evaluations.push_back({f, reference});
  } else if (spec.kind != ToleranceKind::DistB && spec.kind != ToleranceKind::Anglb) {
    // A tolerance of one feature (CORTOL, DIAM, FLAT, POS, PERP ...) output with several applies
    // to each: OUTPUT/FA(C1),FA(C2),TA(DIA).
    for (const Feature* f : features) evaluations.push_back({f});
  } else {
    evaluations.push_back(features);
  }
  std::vector<ToleranceResult> results;
  for (const auto& operands : evaluations) {
    auto result = runtime::evaluate_tolerance(spec, operands, context);
    if (!result) return program_error(span, result.error());
    results.push_back(std::move(*result));
  }
  return results;
}

namespace {
/// A program's path (often a Windows path on another machine) reduced to its base name: DMIS
/// output files are written into the run's output directory, never elsewhere (docs/security.md).
std::string device_file_name(const std::string& label, const std::string& path) {
  std::string name = path;
  const auto cut = name.find_last_of("/\\:");
  if (cut != std::string::npos) name = name.substr(cut + 1);
  if (name.empty() || name == "." || name == "..") name = label + ".dmo";
  return name;
}
}  // namespace

Result<void> MeasurementRuntime::define_device(const std::string& label, const std::string& path, Span span) {
  const std::string name = device_file_name(label, path);
  if (name == "results.json")
    return program_error(span, fmt::format("DEVICE DID({}): the file name 'results.json' is reserved for the run's "
                                           "results; choose another name",
                                           label));
  for (const auto& [other, device] : m_devices)
    if (other != label && device_file_name(other, device.path) == name)
      return program_error(span, fmt::format("DEVICE DID({}): '{}' would write the same output file {} as DID({}) "
                                             "('{}'); output files keep only their base name, so give them distinct "
                                             "names",
                                             label, path, name, other, device.path));
  if (auto it = m_devices.find(label); it != m_devices.end() && it->second.open) commit_device(it->second);
  m_devices[label] = Device{path, false, nullptr, {}};
  return {};
}

bool MeasurementRuntime::commit_device(Device& device) {
  if (!device.stream) return true;
  if (!device.direct) *device.stream << "ENDFIL\n";  // a DMIS output file ends as a program does
  device.stream->flush();
  const bool written = static_cast<bool>(*device.stream);
  device.stream->close();
  device.stream.reset();
  std::error_code ec;
  if (!written) {
    m_output_errors.push_back(
        fmt::format("cannot write the output file {}: a write failed (disk full?); the "
                    "earlier file, if any, is kept",
                    device.path));
    std::filesystem::remove(device.temp_path, ec);
    return false;
  }
  std::filesystem::rename(device.temp_path, device.path, ec);
  if (ec) {
    m_output_errors.push_back(fmt::format("cannot write the output file {}: {}", device.path, ec.message()));
    std::filesystem::remove(device.temp_path, ec);
    return false;
  }
  return true;
}

Result<void> MeasurementRuntime::open_device(const std::string& label, Span span, bool direct) {
  auto it = m_devices.find(label);
  if (it == m_devices.end()) return program_error(span, fmt::format("device DID({}) is not defined", label));
  if (it->second.open) commit_device(it->second);
  const std::string name = device_file_name(label, it->second.path);
  const std::string full = (std::filesystem::path(m_output_dir) / name).string();
  if (auto refused = m_policy.refuse_write(full)) return program_error(span, "OPEN/DID(" + label + "): " + *refused);
  // Written to a temporary file and renamed when closed: a failed run never leaves a truncated
  // file nor destroys the previous one.
  const std::string temp = (std::filesystem::path(m_output_dir) / ("." + name + ".partial")).string();
  auto stream = std::make_shared<std::ofstream>(temp, std::ios::binary | std::ios::trunc);
  if (!*stream) return program_error(span, fmt::format("cannot open output file {}", full));
  it->second.stream = stream;
  it->second.open = true;
  it->second.direct = direct;
  if (!direct) {
    // A DMIS output file starts with its name and units (as NIST's output.dms): a reader knows
    // what the numbers after it are in.
    const std::string stem = std::filesystem::path(name).stem().string();
    *stream << "FILNAM/'" << stem << "'\nUNITS/" << m_report_units.length << ", "
            << (m_report_units.radians ? "ANGRAD" : "ANGDEC") << "\n";
  }
  it->second.path = full;
  it->second.temp_path = temp;
  return {};
}

Result<void> MeasurementRuntime::close_device(const std::string& label, Span span) {
  auto it = m_devices.find(label);
  if (it == m_devices.end()) return program_error(span, fmt::format("device DID({}) is not defined", label));
  it->second.open = false;
  if (!commit_device(it->second)) return program_error(span, m_output_errors.back());
  return {};
}

Result<void> MeasurementRuntime::write_device(const std::string& label, const std::string& line, Span span) {
  auto it = m_devices.find(label);
  if (it == m_devices.end()) return program_error(span, fmt::format("device DID({}) is not defined", label));
  if (!it->second.open || !it->second.stream)
    return program_error(
        span,
        fmt::format("WRITE/DID({}): the device is not open for OUTPUT (OPEN/DID({}),DIRECT,OUTPUT)", label, label));
  *it->second.stream << line << "\n";
  return {};
}

Result<std::string> MeasurementRuntime::read_input_device(const std::string& label, Span span) {
  auto it = m_devices.find(label);
  if (it == m_devices.end()) return program_error(span, fmt::format("device DID({}) is not defined", label));
  namespace fs = std::filesystem;
  const fs::path written(it->second.path);
  std::vector<fs::path> candidates;
  if (written.is_absolute() || m_policy.read_dirs().empty()) {
    candidates.push_back(written);
  } else {
    for (const auto& dir : m_policy.read_dirs()) candidates.push_back(dir / written);
  }
  std::error_code ec;
  const auto found =
      std::find_if(candidates.begin(), candidates.end(), [&](const fs::path& p) { return fs::exists(p, ec); });
  if (found == candidates.end())
    return program_error(span, fmt::format("OPEN/DID({}),INPUT: the file '{}' is not there (looked in {})", label,
                                           it->second.path, candidates.front().parent_path().string()));
  if (auto refused = m_policy.refuse_read(found->string()))
    return program_error(span, fmt::format("OPEN/DID({}),INPUT: {}", label, *refused));
  auto text = read_input_file(found->string());
  if (!text) return program_error(span, fmt::format("OPEN/DID({}),INPUT: {}", label, text.error()));
  return *text;
}

void MeasurementRuntime::text(const std::string& kind, const std::string& text) {
  if (kind == "OUTFIL") write_device_line("TEXT/OUTFIL,'" + text + "'");
  emit(TextReport{text});
}

void MeasurementRuntime::finish() {
  m_record.features.clear();
  for (const auto& label : m_feature_order) m_record.features.push_back(m_features.at(label));
  m_record.simulated_time_s = m_machine.state().time_s;
  for (auto& [label, device] : m_devices) {
    device.open = false;
    commit_device(device);
  }
}

}  // namespace metron::runtime
