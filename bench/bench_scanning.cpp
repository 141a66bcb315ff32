// SPDX-License-Identifier: GPL-3.0-or-later
// Scanning benchmark (docs/scanning.md, SEEDS.md 1):
//  (1) the three trajectory-correction laws side by side on ramps of 0..60 degrees, on a part
//      offset from its design and rough: |Ep| - E0 (RMS, peak), oscillation, distance from the
//      path, completion;
//  (2) simulation speed of the 1 kHz scanning loop on a CAD mesh of >= 100k triangles.
//  (1b) cases where the path deviates from the surface across the scan direction: lateral error
//      for no correction, Vc1, Vc1', Vc2, and a Kc-only sweep per law (--lateral-only);
// Build with -DMETRON_BENCH=ON; run ./build/bench/bench_scanning [--table-only | --lateral-only | --speed-only |
// --step-only |
// --profile-sphere] [--full-search].
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "fixtures.hpp"
#include "metron/machine/active_scanning/scan_controller.hpp"
#include "metron/machine/mesh_solid.hpp"
#include "metron/machine/world_solid.hpp"
#include "scan_paths.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

const Vec3 part_origin(100, 100, 0);  // design pose of the ramp part in the machine
constexpr double ball_radius_mm = 2;  // 4 mm stylus ball

// RBJ audio-EQ-cookbook second-order Butterworth high-pass, run over a sampled signal.
std::vector<double> high_pass(const std::vector<double>& x, double cutoff_hz, double rate_hz) {
  const double w = 2 * std::numbers::pi * cutoff_hz / rate_hz, alpha = std::sin(w) / (2 * std::sqrt(0.5));
  const double c = std::cos(w), a0 = 1 + alpha;
  const double b0 = (1 + c) / 2 / a0, b1 = -(1 + c) / a0, b2 = b0, a1 = -2 * c / a0, a2 = (1 - alpha) / a0;
  std::vector<double> y(x.size(), 0.0);
  double x1 = x.empty() ? 0 : x[0], x2 = x1, y1 = 0, y2 = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    y[i] = b0 * x[i] + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
    x2 = x1, x1 = x[i], y2 = y1, y1 = y[i];
  }
  return y;
}

struct Row {
  ScanOutcome outcome;
  double hf_rms_mm = 0;         // RMS of |Ep| above the cutoff
  double reversals_per_mm = 0;  // sign changes of the high-passed |Ep| per mm of path
};

Row scan_ramp(ScanLaw law, double angle_deg, const Vec3& offset_mm, double roughness_mm, double cutoff_hz,
              double gain_1_s = 0) {
  World world = default_world();
  if (gain_1_s > 0)
    world.machine.scanning.control.deflection_gain_1_s = world.machine.scanning.control.trajectory_gain_1_s = gain_1_s;
  PartSpec part;
  part.design = scan_test::ramp_design(angle_deg);
  part.pose.translation_mm = part_origin + offset_mm;  // the part as machined sits off its design
  part.roughness = {roughness_mm, 0.5};
  part.seed = 7;
  world.truth.part = part;
  world.truth.probe.ball_radius_error_mm = 0;
  const auto solid = make_world_solid(world.truth);

  ScanPath cmd;
  cmd.path = scan_test::profile_path_xz(scan_test::ramp_profile(angle_deg), ball_radius_mm - 0.3, ball_radius_mm - 0.3);
  for (auto& s : cmd.path.segments) s.k.col(0) += part_origin;  // design pose: part to machine
  cmd.approach_normal = Vec3::UnitZ();
  cmd.law = law;
  cmd.sample_spacing_mm = 0.1;
  ScanSetup setup{solid.get(), ball_radius_mm, world.machine, world.truth.scanning, 11};
  std::vector<double> e;
  std::vector<double> s;
  Row row;
  row.outcome = run_scan(cmd, setup, scan_approach_point(cmd), 0, [&](const ScanCycle& c) {
    if (!c.scanning) return;
    e.push_back(c.deflection_mm.norm());
    s.push_back(c.path_s_mm);
  });
  const double rate = 1 / world.machine.dt_s;
  const auto hp = high_pass(e, cutoff_hz, rate);
  const std::size_t skip = std::min<std::size_t>(hp.size(), 200);  // the filter's own settling
  double sum = 0;
  int reversals = 0;
  for (std::size_t i = skip; i < hp.size(); ++i) {
    sum += hp[i] * hp[i];
    if (i > skip && (hp[i] > 0) != (hp[i - 1] > 0)) ++reversals;
  }
  const std::size_t n = hp.size() > skip ? hp.size() - skip : 0;
  row.hf_rms_mm = n ? std::sqrt(sum / static_cast<double>(n)) : 0;
  const double travelled = n ? s.back() - s[skip] : 0;
  row.reversals_per_mm = travelled > 0 ? reversals / travelled : 0;
  return row;
}

const char* law_name(ScanLaw law) {
  switch (law) {
    case ScanLaw::Vc1: return "Vc1";
    case ScanLaw::Vc1Prime: return "Vc1'";
    case ScanLaw::Vc2: return "Vc2";
  }
  return "?";
}

void table() {
  const double roughness_mm = 0.003, cutoff_hz = 25;
  const std::vector<Vec3> offsets = {Vec3(-0.3, 0, 0), Vec3(-1.0, 0, 0), Vec3(1.0, 0, 0.2)};
  const World defaults = default_world();
  const auto& c = defaults.machine.scanning.control;
  fmt::print(
      "Ramp scans (docs/scanning.md): flat 20 mm, ramp rising 5 mm, plateau; 4 mm ball, E0 {} mm, feed {} mm/s,\n"
      "K {} /s, Kc {} /s, servo {} Hz / zeta {} / {} cycle delay, roughness {} mm (0.5 mm correlation).\n"
      "offset = the part as machined minus its design (mm). osc = RMS of |Ep| above {} Hz (2nd-order Butterworth\n"
      "high-pass), rev/mm = its sign changes per mm of path. dist = largest |P - Pp|. done = the path end was "
      "reached.\n\n",
      defaults.machine.scanning.probe.reference_deflection_mm, c.feed_mm_s, c.deflection_gain_1_s,
      c.trajectory_gain_1_s, defaults.truth.scanning.servo.natural_frequency_hz, defaults.truth.scanning.servo.damping,
      defaults.truth.scanning.servo.command_delay_cycles, roughness_mm, cutoff_hz);
  fmt::print("{:<5} {:<18} {:>5} | {:>9} {:>9} {:>9} {:>7} {:>8} {:>8} | {}\n", "law", "offset", "angle", "rms dE um",
             "peak dE um", "osc um", "rev/mm", "dist mm", "reach mm", "done");
  for (const Vec3& off : offsets)
    for (ScanLaw law : {ScanLaw::Vc1, ScanLaw::Vc1Prime, ScanLaw::Vc2}) {
      for (int a = 0; a <= 60; a += 5) {
        const Row r = scan_ramp(law, a, off, roughness_mm, cutoff_hz);
        const ScanStats& st = r.outcome.stats;
        fmt::print(
            "{:<5} ({:5.2f},{:4.1f},{:4.1f}) {:>5} | {:>9.2f} {:>9.2f} {:>9.2f} {:>7.2f} {:>8.3f} {:>8.2f} | {}\n",
            law_name(law), off.x(), off.y(), off.z(), a, 1000 * st.rms_deflection_error_mm,
            1000 * st.peak_deflection_error_mm, 1000 * r.hf_rms_mm, r.reversals_per_mm, st.max_path_distance_mm,
            st.reached_mm,
            r.outcome.completed ? "yes"
                                : fmt::format("no: {}", r.outcome.fault ? to_string(r.outcome.fault->kind) : "?"));
      }
      fmt::print("\n");
    }
}

// Why Vc1 does not ring at the default gains: along eu its term adds to Ve, so the normal loop's
// gain is K + Kc(.eu) instead of K. Raising K = Kc shows where each law starts to ring.
void gain_sweep() {
  const double roughness_mm = 0.003, cutoff_hz = 25;
  fmt::print(
      "Gain sweep: K = Kc, 20 degree ramp, offset (-0.30, 0, 0.10), roughness {} mm; osc = RMS of |Ep| above {} Hz\n",
      roughness_mm, cutoff_hz);
  fmt::print("{:>6} | {:>16} {:>16} {:>16}\n", "K 1/s", "Vc1 osc/rms um", "Vc1' osc/rms um", "Vc2 osc/rms um");
  for (double k : {20.0, 40.0, 60.0, 80.0, 100.0, 120.0, 140.0, 160.0}) {
    fmt::print("{:>6.0f} |", k);
    for (ScanLaw law : {ScanLaw::Vc1, ScanLaw::Vc1Prime, ScanLaw::Vc2}) {
      const Row r = scan_ramp(law, 20, Vec3(-0.3, 0, 0.1), roughness_mm, cutoff_hz, k);
      const ScanStats& st = r.outcome.stats;
      if (st.scan_cycles < 400)  // too short a scan for the high-pass figure
        fmt::print(" {:>16}", r.outcome.fault ? to_string(r.outcome.fault->kind) : "-");
      else
        fmt::print(" {:>7.2f}/{:>6.1f}{}", 1000 * r.hf_rms_mm, 1000 * st.rms_deflection_error_mm,
                   r.outcome.completed ? " " : "*");
    }
    fmt::print("\n");
  }
  fmt::print("(* = not completed; a fault name: it came within 0.4 s of scanning)\n\n");
}

// Cases where the path deviates from the actual surface ACROSS the scan direction (issue 11
// item 1, SEEDS.md 1): there Vc2 = (Vc1 . q) q does its work. lateral = (P - Pp) . q, the
// deviation from the foot of the perpendicular along q (ScanCycle::lateral_error_mm).
struct LateralRow {
  ScanOutcome outcome;
  double late_lateral_mm = 0;  // mean |lateral| over the second half of the path (steady state)
  double hf_rms_mm = 0;        // RMS of |Ep| above the cutoff (oscillation)
};

LateralRow scan_lateral(const scan_test::LateralCase& lc, ScanLaw law, double kc) {
  World w = lc.world;
  w.machine.scanning.control.trajectory_gain_1_s = kc;
  const auto solid = make_world_solid(w.truth);
  ScanPath cmd = lc.command;
  cmd.law = law;
  ScanSetup setup{solid.get(), ball_radius_mm, w.machine, w.truth.scanning, 11};
  std::vector<double> e, lat, s;
  LateralRow row;
  row.outcome = run_scan(cmd, setup, lc.start_mm, 0, [&](const ScanCycle& c) {
    if (!c.scanning) return;
    e.push_back(c.deflection_mm.norm());
    lat.push_back(std::abs(c.lateral_error_mm));
    s.push_back(c.path_s_mm);
  });
  const double half = row.outcome.stats.path_length_mm / 2;
  double sum = 0;
  int n = 0;
  for (std::size_t i = 0; i < lat.size(); ++i)
    if (s[i] >= half) sum += lat[i], ++n;
  row.late_lateral_mm = n ? sum / n : std::numeric_limits<double>::quiet_NaN();
  const auto hp = high_pass(e, 25, 1 / w.machine.dt_s);
  double sq = 0;
  std::size_t m = 0;
  for (std::size_t i = std::min<std::size_t>(hp.size(), 200); i < hp.size(); ++i) sq += hp[i] * hp[i], ++m;
  row.hf_rms_mm = m ? std::sqrt(sq / static_cast<double>(m)) : 0;
  return row;
}

std::vector<scan_test::LateralCase> lateral_cases(double roughness_mm) {
  std::vector<scan_test::LateralCase> cases = {scan_test::tilted_plane_case(20, 0.3, roughness_mm),
                                               scan_test::start_offset_case(0.5, roughness_mm),
                                               scan_test::sphere_latitude_case(Vec3(0.3, -0.3, 0.2), 45, roughness_mm),
                                               scan_test::free_form_case(0.5, roughness_mm)};
  cases[0].name = "plane tilted 20 deg sideways, +0.3 mm";
  cases[1].name = "flat, start 0.5 mm sideways";
  cases[2].name = "sphere D40 latitude 45, centre (0.3,-0.3,0.2) off";
  cases[3].name = "free-form (20 deg side slope), 0.5 mm sideways";
  // A ramp climbing 30 degrees along x, its block also tilted 15 degrees sideways and starting
  // 0.5 mm early: Vc1' opposes Vf on the slope, Vc1 fights Ve, both while correcting sideways.
  scan_test::LateralCase ramp = scan_test::tilted_plane_case(0, 0, roughness_mm);
  ramp.name = "ramp 30 deg, tilted 15 deg sideways, 0.5 mm early";
  ramp.world.truth.part->design = scan_test::ramp_design(30);
  ramp.world.truth.part->pose.rotation_deg = Vec3(15, 0, 0);
  // Keep the part's (0, 0, 10) at the design's place after the tilt about the machine x axis.
  const double a = 15 * scan_test::deg;
  ramp.world.truth.part->pose.translation_mm = part_origin + Vec3(-0.5, 10 * std::sin(a), 10 - 10 * std::cos(a));
  ramp.command.path =
      scan_test::profile_path_xz(scan_test::ramp_profile(30), ball_radius_mm - 0.3, ball_radius_mm - 0.3);
  for (auto& seg : ramp.command.path.segments) seg.k.col(0) += part_origin;
  ramp.start_mm = scan_approach_point(ramp.command);
  cases.push_back(ramp);
  return cases;
}

std::string done_text(const ScanOutcome& o) {
  return o.completed ? "yes"
                     : fmt::format("no: {} at {:.1f} mm", o.fault ? to_string(o.fault->kind) : "?", o.stats.reached_mm);
}

void lateral_table() {
  const double roughness_mm = 0.003;
  const World d = default_world();
  const double kc0 = d.machine.scanning.control.trajectory_gain_1_s;
  fmt::print(
      "Lateral cases (issue 11, SEEDS.md 1): the path deviates from the actual surface across the scan\n"
      "direction. lat = (P - Pp) . q, q = eu x t: rms over the scan, peak, and the mean |lat| over the second\n"
      "half of the path (steady state). K {} /s, Kc {} /s, roughness {} mm; \"none\" = Kc 0 (Vf + Ve only).\n\n",
      d.machine.scanning.control.deflection_gain_1_s, kc0, roughness_mm);
  fmt::print("{:<50} {:<5} | {:>8} {:>8} {:>9} | {:>9} {:>9} {:>7} {:>7} | {}\n", "case", "law", "lat rms", "lat pk",
             "lat late", "rms dE um", "pk dE um", "osc um", "dist", "done");
  const auto cases = lateral_cases(roughness_mm);
  for (const auto& lc : cases) {
    const auto row = [&](const char* name, ScanLaw law, double kc) {
      const LateralRow r = scan_lateral(lc, law, kc);
      const ScanStats& st = r.outcome.stats;
      fmt::print("{:<50} {:<5} | {:>8.4f} {:>8.4f} {:>9.4f} | {:>9.2f} {:>9.2f} {:>7.2f} {:>7.3f} | {}\n", lc.name,
                 name, st.rms_lateral_error_mm, st.max_lateral_error_mm, r.late_lateral_mm,
                 1000 * st.rms_deflection_error_mm, 1000 * st.peak_deflection_error_mm, 1000 * r.hf_rms_mm,
                 st.max_path_distance_mm, done_text(r.outcome));
    };
    row("none", ScanLaw::Vc2, 0);
    for (ScanLaw law : {ScanLaw::Vc1, ScanLaw::Vc1Prime, ScanLaw::Vc2}) row(law_name(law), law, kc0);
    fmt::print("\n");
  }
}

// Each law at its own best Kc (K fixed): a Kc-only sweep, scored by lat rms + rms dE (both mm of
// deviation from where the probe should be), so Vc1 is not judged only at K = Kc.
void lateral_kc_sweep() {
  const double roughness_mm = 0.003;
  const std::vector<double> gains = {2.5, 5, 10, 20, 40, 80, 160};
  fmt::print(
      "Kc-only sweep (K = {} /s fixed): per law, lat rms / rms dE in um (* = not completed); [best] = the\n"
      "smallest lat rms + rms dE among completed runs.\n\n",
      default_world().machine.scanning.control.deflection_gain_1_s);
  for (const auto& lc : lateral_cases(roughness_mm)) {
    fmt::print("{}\n{:>6} |", lc.name, "Kc");
    for (ScanLaw law : {ScanLaw::Vc1, ScanLaw::Vc1Prime, ScanLaw::Vc2}) fmt::print(" {:>18}", law_name(law));
    fmt::print("\n");
    double best[3] = {1e300, 1e300, 1e300}, best_kc[3] = {0, 0, 0};
    std::vector<std::array<std::string, 3>> cells;
    for (double kc : gains) {
      std::array<std::string, 3> line;
      int i = 0;
      for (ScanLaw law : {ScanLaw::Vc1, ScanLaw::Vc1Prime, ScanLaw::Vc2}) {
        const LateralRow r = scan_lateral(lc, law, kc);
        const ScanStats& st = r.outcome.stats;
        const double score = st.rms_lateral_error_mm + st.rms_deflection_error_mm;
        if (r.outcome.completed && score < best[i]) best[i] = score, best_kc[i] = kc;
        line[static_cast<std::size_t>(i)] =
            fmt::format("{:.1f}/{:.1f}{}", 1000 * st.rms_lateral_error_mm, 1000 * st.rms_deflection_error_mm,
                        r.outcome.completed ? " " : "*");
        ++i;
      }
      fmt::print("{:>6.1f} | {:>18} {:>18} {:>18}\n", kc, line[0], line[1], line[2]);
    }
    fmt::print("  best | {:>18} {:>18} {:>18}\n\n", fmt::format("Kc {} ({:.1f})", best_kc[0], 1000 * best[0]),
               fmt::format("Kc {} ({:.1f})", best_kc[1], 1000 * best[1]),
               fmt::format("Kc {} ({:.1f})", best_kc[2], 1000 * best[2]));
  }
}

// A UV sphere of radius R with `rings` x `sectors` quads (2 triangles each, fans at the poles).
geometry::Mesh uv_sphere(double radius, int rings, int sectors) {
  std::vector<Vec3> v;
  std::vector<geometry::Mesh::Face> f;
  v.emplace_back(0, 0, radius);
  for (int i = 1; i < rings; ++i) {
    const double th = std::numbers::pi * i / rings;
    for (int j = 0; j < sectors; ++j) {
      const double ph = 2 * std::numbers::pi * j / sectors;
      v.emplace_back(radius * std::sin(th) * std::cos(ph), radius * std::sin(th) * std::sin(ph), radius * std::cos(th));
    }
  }
  v.emplace_back(0, 0, -radius);
  const auto id = [&](int ring, int j) { return static_cast<std::uint32_t>(1 + (ring - 1) * sectors + (j % sectors)); };
  const auto south = static_cast<std::uint32_t>(v.size() - 1);
  for (int j = 0; j < sectors; ++j) f.push_back({0, id(1, j), id(1, j + 1)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < sectors; ++j) {
      f.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      f.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  for (int j = 0; j < sectors; ++j) f.push_back({id(rings - 1, j), south, id(rings - 1, j + 1)});
  return *geometry::Mesh::from_triangles(std::move(v), std::move(f));
}

// Wall and CPU (this thread) seconds of one scan, the best of `repeats` runs with the mesh
// search's coherent path off and on, interleaved; the machine is shared, so the CPU time is the
// steadier figure and the minimum the least disturbed run.
struct Timing {
  double wall_s = 1e300, cpu_s = 1e300;
  ScanOutcome out;
};

std::pair<Timing, Timing> time_scan(const ScanPath& cmd, const ScanSetup& setup, int repeats) {
  Timing t[2];
  for (int r = 0; r < repeats; ++r)
    for (int fast = 0; fast < 2; ++fast) {
      MeshSolid::set_coherent_search(fast == 1);
      const double c0 = test_support::thread_cpu_s();
      const auto w0 = std::chrono::steady_clock::now();
      ScanOutcome out = run_scan(cmd, setup, scan_approach_point(cmd), 0);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
      const double cpu = test_support::thread_cpu_s() - c0;
      t[fast].wall_s = std::min(t[fast].wall_s, wall);
      t[fast].cpu_s = std::min(t[fast].cpu_s, cpu);
      t[fast].out = std::move(out);
    }
  MeshSolid::set_coherent_search(true);
  return {t[0], t[1]};
}

// One line per mode, and whether both modes scanned the same points.
void print_timing(const std::pair<Timing, Timing>& t) {
  for (const Timing* m : {&t.first, &t.second}) {
    const double sim = m->out.end_time_s, cycles = static_cast<double>(m->out.stats.cycles);
    fmt::print(
        "  {:<28} {:>6.0f}x real time by wall clock ({:.2f} us per cycle), {:>6.0f}x by CPU time ({:.2f} us); "
        "completed: {}\n",
        m == &t.first ? "full search per query:" : "coherent search (default):", sim / m->wall_s,
        1e6 * m->wall_s / cycles, sim / m->cpu_s, 1e6 * m->cpu_s / cycles, m->out.completed ? "yes" : "no");
  }
  const auto& a = t.first.out.samples;
  const auto& b = t.second.out.samples;
  double diff = a.size() == b.size() ? 0 : 1e300;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    diff = std::max(diff, (a[i].centre_mm - b[i].centre_mm).norm());
  fmt::print("  speed-up {:.2f}x (wall) / {:.2f}x (CPU); {} samples each, largest difference {:.1e} mm\n",
             t.first.wall_s / t.second.wall_s, t.first.cpu_s / t.second.cpu_s, b.size(), diff);
}

// The NIST DCX test part (STEP, tessellated at the default 1 um chord tolerance) with the table:
// a 120 mm line on its flat top at z = -50 (y = 69), Vc2.
void speed_on_step_part() {
  const std::string file = std::string(METRON_SOURCE_DIR) + "/programs/worlds/nist_dcx_part.json";
  auto world = load_world(file);
  if (!world) {
    fmt::print("DCX part not available: {}\n", world.error().message);
    return;
  }
  const auto& cad = std::get<CadDesign>(world->truth.part->design);
  const auto solid = make_world_solid(world->truth);
  (void)solid->local_view(Vec3(300, 69, -48), 1);  // builds the mesh's grid outside the timing
  ScanPath cmd;
  const double z = -50 + ball_radius_mm - 0.3;
  cmd.path.segments.push_back(geometry::PccSegment::hermite({280, 69, z}, {400, 69, z}, Vec3::UnitX(), Vec3::UnitX()));
  cmd.approach_normal = Vec3::UnitZ();
  cmd.law = ScanLaw::Vc2;
  ScanSetup setup{solid.get(), ball_radius_mm, world->machine, world->truth.scanning, 3};
  const auto t = time_scan(cmd, setup, 5);
  fmt::print(
      "Simulation speed on a STEP part: NIST DCX part ({} triangles, exact CAD faces) plus table, a 120 mm\n"
      "line at 10 mm/s, {} cycles = {:.2f} s simulated (best of 5 runs){}:\n",
      cad.mesh->face_count(), t.second.out.stats.cycles, t.second.out.end_time_s,
      t.second.out.fault ? " (" + t.second.out.fault->message + ")" : "");
  print_timing(t);
}

// profile_only: one untimed scan of the sphere, for a profiler (docs/scanning.md).
void speed(bool profile_only = false) {
  const double radius = 30;
  auto mesh = std::make_shared<const geometry::Mesh>(uv_sphere(radius, 230, 230));
  const Vec3 centre(400, 400, 100);
  Frame pose = Frame::Identity();
  pose.translate(centre);
  MeshSolid solid(mesh, pose);
  const World world = default_world();
  ScanPath cmd;
  cmd.path = scan_test::circle_path(centre, radius + ball_radius_mm - 0.3, true);
  cmd.approach_normal = Vec3::UnitX();
  cmd.law = ScanLaw::Vc2;
  cmd.speed_mm_s = 10;
  ScanSetup setup{&solid, ball_radius_mm, world.machine, world.truth.scanning, 3};
  (void)solid.signed_distance(centre);  // builds the mesh's search trees (lazy) outside the timing
  (void)solid.local_view(centre, 1);    // and its grid
  if (profile_only) {
    const ScanOutcome o = run_scan(cmd, setup, scan_approach_point(cmd), 0);
    fmt::print("one scan of the sphere: {} cycles, completed: {}\n", o.stats.cycles, o.completed ? "yes" : "no");
    return;
  }
  const auto t = time_scan(cmd, setup, 5);
  const ScanOutcome& out = t.second.out;
  fmt::print(
      "Simulation speed: Vc2 scan of a {:.0f} mm circle on a UV-sphere mesh of {} triangles (MeshSolid), {} control\n"
      "cycles of {} ms = {:.2f} s simulated (best of 5 runs):\n",
      2 * radius, mesh->face_count(), out.stats.cycles, 1000 * world.machine.dt_s, out.end_time_s);
  print_timing(t);
  for (const auto& line : out.log) fmt::print("  log: {}\n", line);
  {
    // Diagnostics: cost of a local view and of queries through it (the probe's radius with the
    // coherent search: renewed every 1 mm).
    const Vec3 h = centre + Vec3(radius + 1.7, 0, 0);
    auto t1 = std::chrono::steady_clock::now();
    const int n_views = 200;
    for (int i = 0; i < n_views; ++i) (void)solid.local_view(h + Vec3(0, 0.01 * i, 0), 3.6);
    auto t2 = std::chrono::steady_clock::now();
    const auto view = solid.local_view(h, 3.6);
    double sum = 0;
    const int n_q = 20000;
    for (int i = 0; i < n_q; ++i) sum += view->signed_distance(h + Vec3(0, 1e-5 * i, 0));
    auto t3 = std::chrono::steady_clock::now();
    for (int i = 0; i < n_q; ++i) sum += solid.signed_distance(h + Vec3(0, 1e-5 * i, 0));
    auto t4 = std::chrono::steady_clock::now();
    fmt::print(
        "  where the time goes: a local view of the mesh (MeshSolid::local_view, renewed every 1 mm) takes {:.1f} us\n"
        "  to build; a distance query through it {:.3f} us, on the whole mesh {:.3f} us [{}]\n",
        1e6 * std::chrono::duration<double>(t2 - t1).count() / n_views,
        1e6 * std::chrono::duration<double>(t3 - t2).count() / n_q,
        1e6 * std::chrono::duration<double>(t4 - t3).count() / n_q, sum > 0 ? "ok" : "?");
  }
  {
    // The controller's own cost: the same kind of scan on an analytic surface (CSG plane, table).
    World plain = default_world();
    plain.truth.part.reset();
    const auto table = make_world_solid(plain.truth);
    ScanPath line;
    const double z = ball_radius_mm - 0.3;
    line.path.segments.push_back(
        geometry::PccSegment::hermite({100, 100, z}, {300, 100, z}, Vec3::UnitX(), Vec3::UnitX()));
    line.approach_normal = Vec3::UnitZ();
    ScanSetup flat{table.get(), ball_radius_mm, plain.machine, plain.truth.scanning, 3};
    const auto t1 = std::chrono::steady_clock::now();
    const ScanOutcome o = run_scan(line, flat, scan_approach_point(line), 0);
    const double w = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    fmt::print(
        "  the controller alone (a 200 mm line on the table, an analytic plane): {:.0f}x real time ({:.2f} us per "
        "cycle)\n",
        o.end_time_s / w, 1e6 * w / static_cast<double>(o.stats.cycles));
  }
  speed_on_step_part();
}

}  // namespace

int main(int argc, char** argv) {
  // --full-search (last argument): the mesh search without its coherent path, to compare results.
  if (argc > 1 && std::strcmp(argv[argc - 1], "--full-search") == 0) {
    MeshSolid::set_coherent_search(false);
    --argc;
  }
  const bool table_only = argc > 1 && std::strcmp(argv[1], "--table-only") == 0;
  if (argc > 1 && std::strcmp(argv[1], "--lateral-only") == 0) {
    lateral_table();
    lateral_kc_sweep();
    return 0;
  }
  const bool speed_only = argc > 1 && std::strcmp(argv[1], "--speed-only") == 0;
  if (argc > 1 && std::strcmp(argv[1], "--profile-sphere") == 0) {
    speed(true);
    return 0;
  }
  if (argc > 1 && std::strcmp(argv[1], "--step-only") == 0) {
    speed_on_step_part();
    return 0;
  }
  if (!speed_only) table();
  if (!speed_only) gain_sweep();
  if (!speed_only) lateral_table();
  if (!speed_only) lateral_kc_sweep();
  if (!table_only) speed();
  return 0;
}
