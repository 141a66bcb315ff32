// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/virtual_cmm.hpp"

#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <numbers>

#include <fmt/format.h>

#include "metron/machine/axis_dynamics.hpp"
#include "metron/machine/contact.hpp"
#include "metron/machine/motion_profile.hpp"
#include "metron/machine/rng.hpp"
#include "metron/machine/scanning/scan_controller.hpp"
#include "metron/machine/segmented/probe_scan_driver.hpp"
#include "metron/machine/world_solid.hpp"
#include "metron/stdlib/fitting/fit.hpp"

namespace metron::machine {
namespace {

constexpr double inf = std::numeric_limits<double>::infinity();

std::string xyz(const Vec3& p) { return fmt::format("({:.4f}, {:.4f}, {:.4f})", p.x(), p.y(), p.z()); }

tl::unexpected<Fault> fault(FaultKind kind, std::string message, const Vec3& position, double time_s) {
  return tl::unexpected(Fault{kind, std::move(message), position, time_s});
}

// The simulated world: everything here is hidden from the controller, which only receives what
// a sensor would report (ARCHITECTURE.md rule 1).
class Simulation {
 public:
  Simulation(const World& world, std::uint64_t seed)
      : m_world(world), m_solid(make_world_solid(world)), m_rng(seed) {}

  // A stylus is screwed on: its true radius differs from the nominal by the world's error.
  void mount_stylus(double nominal_radius_mm) {
    m_ball_radius_mm = nominal_radius_mm + m_world.probe.ball_radius_error_mm;
    m_free_radius_mm = -1;
  }

  // The probe's trigger used as a collision switch on a move from a to b: the fraction of the
  // move at which the ball first touches, if it does.
  [[nodiscard]] std::optional<double> sweep(const Vec3& a, const Vec3& b) {
    // A segment inside a ball of space known to be free cannot touch (the ball is convex); this
    // saves the distance queries of most cycles of a long move, without changing any result.
    if ((a - m_free_centre).norm() < m_free_radius_mm && (b - m_free_centre).norm() < m_free_radius_mm)
      return std::nullopt;
    const double gap = m_solid->signed_distance(a) - m_ball_radius_mm;
    if (gap > 0) {
      m_free_centre = a;
      m_free_radius_mm = 0.999 * gap / std::max(1.0, m_solid->lipschitz());
      if ((b - a).norm() < m_free_radius_mm) return std::nullopt;
    }
    return first_ball_contact(*m_solid, a, b, m_ball_radius_mm);
  }
  [[nodiscard]] std::string feature_at(const Vec3& p) const { return m_solid->feature_at(p); }

  // A probing move starts: the machine moves from `a` along unit `u` following `profile`.
  void begin_probe(const MotionProfile* profile, const Vec3& a, const Vec3& u) {
    m_profile = profile;
    m_probe_start = a;
    m_probe_dir = u;
    m_contact_s = inf;
    m_signal_s = inf;
  }

  // The machine moved over profile time [t0, t1]. Returns when the trigger signal reaches the
  // controller's skip input, once that is no later than t1.
  std::optional<double> probe_step(double t0, double t1) {
    if (m_contact_s == inf) {
      const double s0 = m_profile->at(t0).position_mm, s1 = m_profile->at(t1).position_mm;
      const auto f = sweep(m_probe_start + s0 * m_probe_dir, m_probe_start + s1 * m_probe_dir);
      if (!f) return std::nullopt;
      m_contact_s = s0 + *f * (s1 - s0);
      // SEEDS.md 3: after contact the stylus bends until the sensing threshold (pre-travel, for
      // the direction in which the surface pushes: the negated true normal); the threshold's
      // scatter is the probe's repeatability. Then the interface filter and the transmission.
      const Vec3 n = m_solid->normal(m_probe_start + m_contact_s * m_probe_dir);
      const double noise = m_world.probe.repeatability_mm * m_rng.normal();
      const double trigger_s = m_contact_s + std::max(0.0, m_world.probe.pre_travel.at(-n) + noise);
      if (trigger_s <= m_profile->end_position_mm())
        m_signal_s = m_profile->time_at(trigger_s) + m_world.probe.filter_delay_s + m_world.probe.transmission_delay_s;
    }
    if (m_signal_s <= t1) return m_signal_s;
    return std::nullopt;
  }
  [[nodiscard]] bool touched() const { return m_contact_s != inf; }

  // The probe's over-travel: how far past the contact the machine stopped, when that exceeds
  // the limit (the probe's breakaway switch).
  [[nodiscard]] std::optional<double> over_travel(double stop_s) const {
    if (m_contact_s == inf || stop_s - m_contact_s <= m_world.probe.over_travel_mm) return std::nullopt;
    return stop_s - m_contact_s;
  }

  // Asynchrony of a scanned skip input relative to the motion: a fresh phase per trigger.
  double scan_phase() { return m_rng.uniform(); }

  [[nodiscard]] const World& world() const { return m_world; }

 private:
  World m_world;
  std::unique_ptr<Solid> m_solid;
  Rng m_rng;
  double m_ball_radius_mm = 0;
  Vec3 m_free_centre = Vec3::Zero();
  double m_free_radius_mm = -1;  // none
  const MotionProfile* m_profile = nullptr;
  Vec3 m_probe_start = Vec3::Zero();
  Vec3 m_probe_dir = Vec3::UnitZ();
  double m_contact_s = inf;
  double m_signal_s = inf;
};

struct Tool {
  ToolInfo info;
  DefineTool definition;
};

}  // namespace

// The controller: knows its own configuration (MachineSpec), the tools it was told about and
// what the reference sphere is said to be; talks to the world only through Simulation's sensors.
struct VirtualCmm::Impl {
  Simulation sim;
  MachineSpec spec;
  Vec3 sphere_centre_mm;            // the reference sphere as the controller was told it is
  double sphere_diameter_mm;
  std::deque<Command> queue;
  std::map<std::string, Tool> tools;
  std::string active;
  std::int64_t cycle = 0;
  Vec3 position;
  double positioning_feed, measuring_feed, acceleration;
  std::optional<double> acceleration_cap;  // a programmed acceleration (caps per-axis rates)
  std::optional<Hit> last_hit;
  std::size_t executed = 0;
  std::function<void(const TraceSample&)> trace;
  std::unique_ptr<Solid> scan_solid;  // the world as the scanning probe touches it (simulation side)
  // A segmented scan in progress (SEEDS.md 2): between its measurement commands the machine
  // answers nothing else.
  struct SegmentedScan {
    std::unique_ptr<segmented::ProbeScanDriver> probe;
    std::unique_ptr<segmented::SegmentedController> controller;
    std::size_t reported = 0;       // samples already answered
    std::size_t next_segment = 0;   // first segment of the next command in the whole path
  };
  std::unique_ptr<SegmentedScan> segmented_scan;

  Impl(const World& world, std::uint64_t seed)
      : sim(world, seed),
        spec(world.machine),
        sphere_centre_mm(world.reference_sphere.nominal_centre_mm),
        sphere_diameter_mm(world.reference_sphere.certified_diameter_mm),
        position(world.machine.home_mm),
        positioning_feed(world.machine.positioning_feed_mm_s),
        measuring_feed(world.machine.measuring_feed_mm_s),
        acceleration(world.machine.max_acceleration_mm_s2) {}

  [[nodiscard]] double now() const { return static_cast<double>(cycle) * spec.dt_s; }
  [[nodiscard]] std::int64_t cycles_for(double t_s) const {
    return static_cast<std::int64_t>(std::ceil(t_s / spec.dt_s - 1e-9));
  }
  [[nodiscard]] MotionLimits limits(const Vec3& u, double feed) const {
    return path_limits(spec, u, feed, acceleration, acceleration_cap);
  }
  // Braking from `speed` along u: the axes decelerate as they accelerate (a constant-time axis
  // stops from any speed in its time).
  [[nodiscard]] MotionLimits braking_limits(const Vec3& u, double speed) const {
    if (!spec.axes) return {spec.max_speed_mm_s, spec.max_acceleration_mm_s2, spec.max_jerk_mm_s3};
    MotionLimits l = path_limits(spec, u, speed, spec.max_acceleration_mm_s2);
    l.speed_mm_s = spec.max_speed_mm_s;
    return l;
  }
  [[nodiscard]] Tool* active_tool() {
    const auto it = tools.find(active);
    return it == tools.end() ? nullptr : &it->second;
  }
  void emit(double t_abs, const Vec3& p, double speed) const {
    if (trace) trace({t_abs, p, speed});
  }

  tl::expected<void, Fault> check_travel(const Vec3& p, const char* what) const {
    static const char* axis = "xyz";
    for (int i = 0; i < 3; ++i) {
      const AxisTravel& t = spec.travel[i];
      if (p[i] < t.min_mm - 1e-9 || p[i] > t.max_mm + 1e-9)
        return fault(FaultKind::AxisLimit,
                     fmt::format("{} {} outside the {} travel [{}, {}]", what, xyz(p), axis[i], t.min_mm, t.max_mm),
                     position, now());
    }
    return {};
  }

  // A positioning move: straight, rest to rest, the ball checked against the world every cycle.
  tl::expected<void, Fault> move_to(const Vec3& target, double feed) {
    if (auto ok = check_travel(target, "target"); !ok) return ok;
    const Vec3 a = position;
    const double len = (target - a).norm();
    if (len < 1e-12) {
      position = target;
      return {};
    }
    const Vec3 u = (target - a) / len;
    const MotionProfile profile = MotionProfile::rest_to_rest(len, limits(u, feed));
    const double t_end = profile.duration_s();
    const std::int64_t n = cycles_for(t_end), c0 = cycle;
    double s_prev = 0;
    for (std::int64_t k = 1; k <= n; ++k) {
      const double t = std::min(static_cast<double>(k) * spec.dt_s, t_end);
      const MotionState st = profile.at(t);
      if (const auto f = sim.sweep(a + s_prev * u, a + st.position_mm * u)) {
        const double s_contact = s_prev + *f * (st.position_mm - s_prev);
        const double t_contact = profile.time_at(s_contact);
        position = a + s_contact * u;
        cycle = c0 + cycles_for(t_contact);
        const std::string feature = sim.feature_at(position);
        return fault(FaultKind::Collision,
                     fmt::format("collision{} at {} on a move to {}", feature.empty() ? "" : " with " + feature,
                                 xyz(position), xyz(target)),
                     position, static_cast<double>(c0) * spec.dt_s + t_contact);
      }
      s_prev = st.position_mm;
      emit(static_cast<double>(c0 + k) * spec.dt_s, a + s_prev * u, st.speed_mm_s);
    }
    cycle = c0 + n;
    position = target;
    return {};
  }

  struct Touch {
    Vec3 latched_mm;                 // ball centre latched when the controller acted on the trigger
    double latch_time_s = 0;         // absolute
  };

  // One probing move from rest at `start` along unit u over `len` at `feed` until the trigger:
  // the controller latches the axes when it acts on the trigger (SEEDS.md 3, C->D), brakes, and
  // the probe's over-travel switch is checked.
  tl::expected<Touch, Fault> touch(const Vec3& start, const Vec3& u, double len, double feed, double search_mm,
                                   std::optional<double> reach_mm = std::nullopt) {
    const MotionProfile profile =
        reach_mm ? MotionProfile::reach_feed(*reach_mm, len, std::min(feed, spec.max_speed_mm_s), limits(u, positioning_feed))
                 : MotionProfile::rest_to_rest(len, limits(u, feed));
    const double t_end = profile.duration_s();
    const std::int64_t n_cycles = cycles_for(t_end), c0 = cycle;
    const double t0_abs = now();
    sim.begin_probe(&profile, start, u);
    std::optional<double> signal;
    for (std::int64_t k = 1; k <= n_cycles && !signal; ++k) {
      const double t0 = static_cast<double>(k - 1) * spec.dt_s, t1 = std::min(static_cast<double>(k) * spec.dt_s, t_end);
      signal = sim.probe_step(t0, t1);
      const MotionState st = profile.at(t1);
      if (!signal) emit(t0_abs + t1, start + st.position_mm * u, st.speed_mm_s);
    }
    if (!signal) {
      cycle = c0 + n_cycles;
      position = start + len * u;
      return fault(FaultKind::NoContact,
                   fmt::format("no {} within {:.3f} mm past the nominal point (probed {:.3f} mm from the approach point)",
                               sim.touched() ? "trigger" : "contact", search_mm, len),
                   position, now());
    }

    // SEEDS.md 3, C->D: the controller's response. Latched: fixed latency; scanned: the next
    // tick of a scan clock whose phase is random relative to the motion (the jitter).
    double latch = *signal + spec.skip.latency_s;
    if (spec.skip.kind == SkipInput::Kind::Scanned) {
      const double period = spec.skip.period_s;
      const double phase = sim.scan_phase() * period;
      latch = phase + std::ceil((*signal - phase) / period) * period;
    }
    const Vec3 latched = start + profile.at(latch).position_mm * u;

    // The interpolator acts at its next cycle: a jerk-limited stop from the current state.
    const double brake = static_cast<double>(cycles_for(latch)) * spec.dt_s;
    double stop_s = len, stop_t = t_end;
    if (brake < t_end) {
      const MotionState at_brake = profile.at(brake);
      const MotionProfile stop = MotionProfile::stop(at_brake, braking_limits(u, at_brake.speed_mm_s));
      stop_s = std::min(stop.end_position_mm(), len);
      stop_t = brake + stop.duration_s();
      for (std::int64_t k = cycles_for(*signal); static_cast<double>(k) * spec.dt_s < stop_t; ++k) {
        const double t = static_cast<double>(k) * spec.dt_s;
        const MotionState st = t < brake ? profile.at(t) : stop.at(t - brake);
        emit(t0_abs + t, start + st.position_mm * u, st.speed_mm_s);
      }
    }
    cycle = c0 + cycles_for(stop_t);
    position = start + stop_s * u;
    if (const auto past = sim.over_travel(stop_s))
      return fault(FaultKind::OverTravel,
                   fmt::format("probe over-travel: stopped {:.3f} mm past contact, limit {:.3f} mm", *past,
                               sim.world().probe.over_travel_mm),
                   position, now());
    return Touch{latched, t0_abs + latch};
  }

  // One touch-trigger point (SEEDS.md 3): approach, probe until the trigger, latch, brake,
  // check over-travel, retract.
  tl::expected<Hit, Fault> measure_point(const PtMeas& m) {
    Tool* tool = active_tool();
    if (!tool) return fault(FaultKind::NoTool, "no tool selected", position, now());
    const bool finite = m.nominal_mm.allFinite() && m.normal.allFinite() && std::isfinite(m.approach_mm) &&
                        std::isfinite(m.search_mm) && std::isfinite(m.retract_mm);
    if (!finite || m.normal.norm() < 1e-9)
      return fault(FaultKind::BadCommand, "ptmeas needs a finite point and a non-zero normal", position, now());
    if (m.approach_mm < 0 || m.search_mm < 0 || m.retract_mm < 0 || m.approach_mm + m.search_mm <= 0)
      return fault(FaultKind::BadCommand, "ptmeas approach, search and retract must be >= 0 and approach + search > 0",
                   position, now());
    const double feed = m.speed_mm_s.value_or(measuring_feed);
    if (!(feed > 0)) return fault(FaultKind::BadCommand, "ptmeas speed must be positive", position, now());

    const Vec3 n = m.normal.normalized();
    const double r = tool->info.effective_radius_mm;
    const Vec3 start = m.nominal_mm + (r + m.approach_mm) * n;
    const Vec3 end = m.nominal_mm + (r - m.search_mm) * n;
    if (auto ok = check_travel(start, "approach point"); !ok) return tl::unexpected(ok.error());
    if (auto ok = check_travel(end, "search end"); !ok) return tl::unexpected(ok.error());
    if (auto ok = move_to(start, positioning_feed); !ok) return tl::unexpected(ok.error());

    const Vec3 u = -n;
    const double len = m.approach_mm + m.search_mm;
    Vec3 latched;
    double latch_abs = 0;
    if (m.blend_mm && (m.two_touch || !(*m.blend_mm >= 0) || *m.blend_mm > m.approach_mm))
      return fault(FaultKind::BadCommand, "a blended ptmeas needs 0 <= blend <= approach and one touch", position, now());
    if (!m.two_touch) {
      auto t = touch(start, u, len, feed, m.search_mm,
                     m.blend_mm ? std::optional<double>(m.approach_mm - *m.blend_mm) : std::nullopt);
      if (!t) return tl::unexpected(t.error());
      latched = t->latched_mm;
      latch_abs = t->latch_time_s;
    } else {
      // SEEDS.md 3, two-touch cycle: (1) fast first touch, (2) back off, (3) slow second touch
      // from rest, which gives the measurement; (4) retract below.
      const auto& tt = *m.two_touch;
      if (!(tt.first_speed_mm_s > 0) || !(tt.backoff_mm > 0) || !std::isfinite(tt.backoff_mm))
        return fault(FaultKind::BadCommand, "two-touch first speed and back-off must be positive", position, now());
      auto first = touch(start, u, len, tt.first_speed_mm_s, m.search_mm);
      if (!first) return tl::unexpected(first.error());
      const Vec3 standoff = first->latched_mm + tt.backoff_mm * n;
      if (auto ok = check_travel(standoff, "two-touch standoff point"); !ok) return tl::unexpected(ok.error());
      if (auto ok = move_to(standoff, positioning_feed); !ok) return tl::unexpected(ok.error());
      auto second = touch(standoff, u, tt.backoff_mm + m.search_mm, feed, m.search_mm);
      if (!second) return tl::unexpected(second.error());
      latched = second->latched_mm;
      latch_abs = second->latch_time_s;
    }

    Hit hit;
    hit.centre_mm = latched;
    hit.normal = n;
    hit.ball_radius_mm = r;
    hit.time_s = latch_abs;
    if (auto ok = move_to(latched + m.retract_mm * n, positioning_feed); !ok) return tl::unexpected(ok.error());
    last_hit = hit;
    return hit;
  }

  // Tool qualification on the reference sphere, from what the controller was told about it.
  tl::expected<ToolInfo, Fault> qualify() {
    Tool* tool = active_tool();
    if (!tool) return fault(FaultKind::NoTool, "no tool selected", position, now());
    const double sphere_r = sphere_diameter_mm / 2;
    const double r = tool->info.effective_radius_mm;
    constexpr double clearance_mm = 10;

    // Each point: up to a safe height, over the approach point, down and probe. All points are
    // on or above the equator, so the vertical descent stays clear of the sphere and post.
    const auto probe_all = [&](const Vec3& centre, const std::vector<Vec3>& dirs, double approach,
                               double search) -> tl::expected<std::vector<Vec3>, Fault> {
      std::vector<Vec3> centres;
      for (const Vec3& d : dirs) {
        const double safe_z = std::max(centre.z() + sphere_r + r + clearance_mm, position.z());
        const Vec3 over = centre + (sphere_r + r + approach) * d;
        if (auto ok = move_to({position.x(), position.y(), safe_z}, positioning_feed); !ok) return tl::unexpected(ok.error());
        if (auto ok = move_to({over.x(), over.y(), safe_z}, positioning_feed); !ok) return tl::unexpected(ok.error());
        PtMeas pt;
        pt.nominal_mm = centre + sphere_r * d;
        pt.normal = d;
        pt.approach_mm = approach;
        pt.search_mm = search;
        pt.retract_mm = 2;
        auto hit = measure_point(pt);
        if (!hit) return tl::unexpected(hit.error());
        centres.push_back(hit->centre_mm);
      }
      if (auto ok = move_to({position.x(), position.y(), centre.z() + sphere_r + r + clearance_mm}, positioning_feed); !ok)
        return tl::unexpected(ok.error());
      return centres;
    };
    const auto direction = [](double azimuth_deg, double elevation_deg) {
      const double a = azimuth_deg * std::numbers::pi / 180, e = elevation_deg * std::numbers::pi / 180;
      return Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
    };
    const auto fit_sphere = [&](const std::vector<Vec3>& pts) -> tl::expected<fitting::FitResult, Fault> {
      fitting::FitOptions options;
      options.inner = false;
      auto f = fitting::fit(fitting::Shape::Sphere, pts, options);
      if (!f) return fault(FaultKind::BadCommand, "qualification sphere fit failed: " + fitting::to_string(f.error()),
                           position, now());
      return *f;
    };

    // First pass: 5 points about the nominal centre, generous search, to find the sphere.
    std::vector<Vec3> dirs = {Vec3::UnitZ(), direction(0, 0), direction(90, 0), direction(180, 0), direction(270, 0)};
    auto rough = probe_all(sphere_centre_mm, dirs, 5, 5);
    if (!rough) return tl::unexpected(rough.error());
    auto first = fit_sphere(*rough);
    if (!first) return tl::unexpected(first.error());

    // Second pass: 25 points (pole and three rings of 8) about the centre found.
    dirs = {Vec3::UnitZ()};
    const double elevations[] = {0, 30, 60};
    for (int ring = 0; ring < 3; ++ring)
      for (int i = 0; i < 8; ++i) dirs.push_back(direction(45.0 * i + 22.5 * (ring % 2), elevations[ring]));
    auto fine = probe_all(first->position, dirs, 2, 2);
    if (!fine) return tl::unexpected(fine.error());
    auto result = fit_sphere(*fine);
    if (!result) return tl::unexpected(result.error());

    // The fitted sphere of ball centres has radius R + r_effective: pre-travel and the delays
    // shorten it just as they shorten every later probing.
    tool->info.effective_radius_mm = result->diameter_mm / 2 - sphere_r;
    tool->info.qualified = true;
    tool->info.qualification_form_mm = result->form_mm;
    return tool->info;
  }

  // SEEDS.md 2: the host writes Ci into a free buffer; the controller scans meanwhile.
  void write_scan_buffer(const ScanBufferWrite& body, Response& response) {
    const auto fail = [&](Fault f) {
      response.status = Response::Status::Fault;
      response.fault = std::move(f);
      segmented_scan.reset();
    };
    if (body.index == 0) {
      if (segmented_scan) return fail({FaultKind::BadCommand, "a segmented scan is already in progress", position, now()});
      const Tool* tool = active_tool();
      if (!tool) return fail({FaultKind::NoTool, "no tool selected", position, now()});
      if (const std::string bad = validate_scan(body.scan); !bad.empty())
        return fail({FaultKind::BadCommand, bad, position, now()});
      if (auto ok = move_to(scan_approach_point(body.scan), positioning_feed); !ok) return fail(ok.error());
      const World& world = sim.world();
      if (!scan_solid) scan_solid = make_world_solid(world);
      const ScanSetup setup{scan_solid.get(), tool->info.nominal_radius_mm + world.probe.ball_radius_error_mm, spec,
                            world.scanning, static_cast<std::uint64_t>(sim.scan_phase() * 0x1.0p53)};
      const SegmentedScanSpec& g = world.scanning.segmented;
      segmented::ControllerConfig cfg;
      cfg.mode = g.mode;
      cfg.buffer_segments = g.buffer_segments;
      cfg.planning_s_per_segment = g.planning_s_per_segment;
      cfg.planning_fixed_s = g.planning_fixed_s;
      cfg.planning_margin = g.planning_margin;
      cfg.low = {g.low_length_mm, g.low_speed_mm_s};
      cfg.dt_s = spec.dt_s;
      const double feed = body.scan.speed_mm_s.value_or(world.scanning.control.feed_mm_s);
      cfg.limits.path = {std::min(feed, spec.max_speed_mm_s), g.path_acceleration_mm_s2, g.path_jerk_mm_s3};
      cfg.limits.normal_acceleration_mm_s2 = world.scanning.control.max_centripetal_mm_s2;
      cfg.retract_mm = body.scan.retract_mm;
      segmented::ProbeDriveSpec drive;
      drive.retract_mm = body.scan.retract_mm;
      ScanPath settings = body.scan;
      settings.path = {};
      auto session = std::make_unique<SegmentedScan>();
      session->probe = std::make_unique<segmented::ProbeScanDriver>(settings, setup, position, now(), drive);
      session->controller = std::make_unique<segmented::SegmentedController>(cfg, session->probe.get());
      segmented_scan = std::move(session);
    } else if (!segmented_scan) {
      return fail({FaultKind::BadCommand,
                   fmt::format("measurement command {} without a segmented scan in progress (the first is 0)", body.index),
                   position, now()});
    }
    SegmentedScan& g = *segmented_scan;
    segmented::SegmentedController& ctl = *g.controller;
    segmented::ProbeScanDriver& probe = *g.probe;
    for (const auto& seg : body.scan.path.segments)
      if (!seg.k.allFinite() || !std::isfinite(seg.d_mm) || seg.d_mm < 0)
        return fail({FaultKind::BadCommand, "scan path has a non-finite segment", position, now()});
    segmented::MeasurementCommand mc;
    mc.index = body.index;
    mc.first_segment = g.next_segment;
    mc.segments = body.scan.path.segments;
    mc.normals = body.scan.path.normals;
    if (body.scan.path.speed_mm_s.size() == mc.segments.size()) mc.speed_mm_s = body.scan.path.speed_mm_s;
    mc.last = body.last;
    const double limit_s = now() + 3600;  // a controller that never frees a buffer is a bug, not a hang
    const auto step = [&] {
      ctl.step();
      emit(probe.time_s(), probe.position_mm(), probe.velocity_mm_s().norm());
    };
    // The host waits on SB: the controller runs until a buffer is writable.
    while (ctl.free_buffer() == 0 && !ctl.finished() && !probe.fault() && probe.time_s() < limit_s) step();
    std::optional<Fault> problem = probe.fault();
    if (!problem) {
      if (auto ok = ctl.load(std::move(mc)); !ok) {
        problem = ok.error();
        problem->position_mm = probe.position_mm();
        problem->time_s = probe.time_s();
      } else {
        g.next_segment += body.scan.path.segments.size();
      }
    }
    if (!problem && body.last) {
      while (!ctl.finished() && !probe.fault() && probe.time_s() < limit_s) step();
      if (!probe.fault() && !probe.finish(ctl.path_state().s_mm))
        problem = Fault{FaultKind::Stalled, "segmented scan did not finish at the path end", probe.position_mm(), probe.time_s()};
      if (probe.fault()) problem = probe.fault();
    }
    const auto& samples = probe.samples();
    response.scan.assign(samples.begin() + static_cast<std::ptrdiff_t>(g.reported), samples.end());
    g.reported = samples.size();
    position = probe.position_mm();
    cycle += cycles_for(probe.time_s() - now());
    if (problem || body.last) {
      const segmented::SegmentedStats& st = ctl.stats();
      response.scan_log.push_back(fmt::format(
          "segmented scan: {} commands of up to {} segments, {} stops, {} retracts, {} late plans, {} samples",
          body.index + 1, ctl.config().buffer_segments, st.stops, probe.retracts(), st.late_plans, samples.size()));
    }
    if (problem) return fail(*problem);
    if (body.last) segmented_scan.reset();
  }

  Response run(const Command& command) {
    Response response;
    response.tag = command.tag;
    response.start_time_s = now();
    const auto fail = [&](Fault f) {
      response.status = Response::Status::Fault;
      response.fault = std::move(f);
    };
    if (segmented_scan && !std::holds_alternative<ScanBufferWrite>(command.body)) {
      fail({FaultKind::BadCommand, "a segmented scan is in progress: only its next measurement command may follow",
            position, now()});
      return response;
    }
    std::visit([&](const auto& body) {
      using T = std::decay_t<decltype(body)>;
      if constexpr (std::is_same_v<T, GoTo>) {
        const double feed = body.speed_mm_s.value_or(positioning_feed);
        if (!(feed > 0) || !body.target_mm.allFinite())
          return fail({FaultKind::BadCommand, "goto needs a finite target and a positive speed", position, now()});
        if (auto ok = move_to(body.target_mm, feed); !ok) fail(ok.error());
      } else if constexpr (std::is_same_v<T, PtMeas>) {
        auto hit = measure_point(body);
        if (hit) response.hit = *hit;
        else fail(hit.error());
      } else if constexpr (std::is_same_v<T, DefineTool>) {
        if (body.name.empty() || !(body.ball_diameter_mm > 0))
          return fail({FaultKind::BadCommand, "a tool needs a name and a positive ball diameter", position, now()});
        Tool t;
        t.definition = body;
        t.info.name = body.name;
        t.info.nominal_radius_mm = body.ball_diameter_mm / 2;
        t.info.effective_radius_mm = t.info.nominal_radius_mm;
        // The probe's data sheet: its rated over-travel is published, so the controller knows it.
        t.info.rated_over_travel_mm = sim.world().probe.over_travel_mm;
        tools[body.name] = t;
        if (active == body.name) sim.mount_stylus(t.info.nominal_radius_mm);
        response.tool = t.info;
      } else if constexpr (std::is_same_v<T, SelectTool>) {
        const auto it = tools.find(body.name);
        if (it == tools.end())
          return fail({FaultKind::UnknownTool, fmt::format("unknown tool '{}'", body.name), position, now()});
        active = body.name;
        sim.mount_stylus(it->second.info.nominal_radius_mm);
        response.tool = it->second.info;
      } else if constexpr (std::is_same_v<T, QualifyTool>) {
        auto info = qualify();
        if (info) response.tool = *info;
        else fail(info.error());
      } else if constexpr (std::is_same_v<T, SetFeeds>) {
        if (body.positioning_mm_s < 0 || body.measuring_mm_s < 0 || body.acceleration_mm_s2 < 0)
          return fail({FaultKind::BadCommand, "feeds and acceleration must not be negative", position, now()});
        // Clamped to the machine's limits, as a controller's override would be.
        if (body.positioning_mm_s > 0) positioning_feed = std::min(body.positioning_mm_s, spec.max_speed_mm_s);
        if (body.measuring_mm_s > 0) measuring_feed = std::min(body.measuring_mm_s, spec.max_speed_mm_s);
        if (body.acceleration_mm_s2 > 0) {
          acceleration = std::min(body.acceleration_mm_s2, spec.max_acceleration_mm_s2);
          acceleration_cap = acceleration;
        }
      } else if constexpr (std::is_same_v<T, ScanPath>) {
        // docs/scanning.md: position to the approach point, then the scanning controller.
        const Tool* tool = active_tool();
        if (!tool) return fail({FaultKind::NoTool, "no tool selected", position, now()});
        if (const std::string bad = validate_scan(body); !bad.empty())
          return fail({FaultKind::BadCommand, bad, position, now()});
        const std::size_t capacity = sim.world().scanning.segmented.buffer_segments;
        if (body.path.segments.size() > capacity)
          return fail({FaultKind::BadCommand,
                       fmt::format("scan path of {} segments exceeds the controller's command buffer of {} segments: "
                                   "the host must send it as measurement commands (ScanBufferWrite)",
                                   body.path.segments.size(), capacity),
                       position, now()});
        if (auto ok = move_to(scan_approach_point(body), positioning_feed); !ok) return fail(ok.error());
        const World& world = sim.world();
        if (!scan_solid) scan_solid = make_world_solid(world);  // kept: a CAD part takes a while to build
        const ScanSetup setup{scan_solid.get(), tool->info.nominal_radius_mm + world.probe.ball_radius_error_mm, spec,
                              world.scanning, static_cast<std::uint64_t>(sim.scan_phase() * 0x1.0p53)};
        ScanOutcome out = run_scan(body, setup, position, now(), [&](const ScanCycle& c) {
          emit(c.time_s + spec.dt_s, c.head_mm, c.velocity_mm_s.norm());
        });
        position = out.end_position_mm;
        cycle += cycles_for(out.end_time_s - now());
        response.scan = std::move(out.samples);
        response.scan_log = std::move(out.log);
        if (out.fault) fail(*out.fault);
      } else if constexpr (std::is_same_v<T, ScanBufferWrite>) {
        write_scan_buffer(body, response);
      }
    }, command.body);
    response.end_time_s = now();
    return response;
  }
};

VirtualCmm::VirtualCmm(World world, std::uint64_t seed) : m_impl(std::make_unique<Impl>(world, seed)) {}
VirtualCmm::~VirtualCmm() = default;

void VirtualCmm::submit(Command command) { m_impl->queue.push_back(std::move(command)); }

std::vector<Response> VirtualCmm::execute() {
  std::vector<Response> out;
  bool faulted = false;
  while (!m_impl->queue.empty()) {
    Command c = std::move(m_impl->queue.front());
    m_impl->queue.pop_front();
    if (faulted) {
      Response r;
      r.tag = c.tag;
      r.status = Response::Status::Fault;
      r.fault = Fault{FaultKind::Aborted, "not executed: an earlier command faulted", m_impl->position, m_impl->now()};
      out.push_back(std::move(r));
      continue;
    }
    out.push_back(m_impl->run(c));
    ++m_impl->executed;
    faulted = out.back().status == Response::Status::Fault;
  }
  return out;
}

MachineState VirtualCmm::state() const {
  MachineState s;
  s.position_mm = m_impl->position;
  s.velocity_mm_s = Vec3::Zero();  // commands run to completion: the machine is at rest between them
  s.time_s = m_impl->now();
  s.active_tool = m_impl->active;
  if (const auto it = m_impl->tools.find(m_impl->active); it != m_impl->tools.end()) s.tool = it->second.info;
  s.last_hit = m_impl->last_hit;
  s.positioning_feed_mm_s = m_impl->positioning_feed;
  s.measuring_feed_mm_s = m_impl->measuring_feed;
  s.queued_commands = m_impl->queue.size();
  s.executed_commands = m_impl->executed;
  s.scan_buffer_segments = m_impl->sim.world().scanning.segmented.buffer_segments;
  return s;
}

std::vector<Command> VirtualCmm::queued() const { return {m_impl->queue.begin(), m_impl->queue.end()}; }
double VirtualCmm::simulated_time_s() const { return m_impl->now(); }
void VirtualCmm::set_trace(std::function<void(const TraceSample&)> trace) { m_impl->trace = std::move(trace); }
const World& VirtualCmm::world() const { return m_impl->sim.world(); }

std::unique_ptr<Machine> make_virtual_cmm(const World& world, std::uint64_t seed) {
  return std::make_unique<VirtualCmm>(world, seed);
}

}  // namespace metron::machine
