// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/error_space/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace metron::machine {
namespace {

int u_of(int c) { return c == 0 ? 1 : 0; }
int v_of(int c) { return c == 2 ? 1 : 2; }

void check_plan(const SpaceCalibrationPlan& plan, int c) {
  if (!plan.grid.valid()) throw std::invalid_argument("error-space calibration: invalid grid");
  const double d = plan.head.spacing_mm;
  for (int a : {u_of(c), v_of(c)}) {
    const auto& x = plan.grid.axes_mm[a];
    if (x.size() < 2)
      throw std::invalid_argument(
          fmt::format("error-space calibration: component {} needs at least 2 grid points on {}", "xyz"[c], "xyz"[a]));
    for (std::size_t i = 1; i < x.size(); ++i)
      if (std::abs(x[i] - x[i - 1] - d) > 1e-9)
        throw std::invalid_argument(
            fmt::format("error-space calibration: the {} grid must step by the sensor spacing {} mm", "xyz"[a], d));
  }
}

Vec3 grid_point(const error_space::Grid& g, int c, std::size_t i, std::size_t j, std::size_t k) {
  Vec3 q;
  q[u_of(c)] = g.axes_mm[u_of(c)][i];
  q[v_of(c)] = g.axes_mm[v_of(c)][j];
  q[c] = g.axes_mm[c][k];
  return q;
}

std::size_t flat_index(const error_space::Grid& g, int c, std::size_t i, std::size_t j, std::size_t k) {
  std::size_t idx[3];
  idx[u_of(c)] = i, idx[v_of(c)] = j, idx[c] = k;
  return g.index(idx[0], idx[1], idx[2]);
}

/// The hidden error e_c over one plane (i along u, j along v), as the rig's pose sees it.
Eigen::MatrixXd plane_truth(const MachineErrorModel& hidden, const SpaceCalibrationPlan& plan, int c, std::size_t k,
                            double t) {
  const auto& g = plan.grid;
  const auto nu = g.axes_mm[u_of(c)].size(), nv = g.axes_mm[v_of(c)].size();
  Eigen::MatrixXd e(static_cast<Eigen::Index>(nu), static_cast<Eigen::Index>(nv));
  MachinePose p;
  p.probe_offset_mm = plan.head.sensor_offset_mm;
  p.approach = {1, 1, 1};
  for (std::size_t i = 0; i < nu; ++i)
    for (std::size_t j = 0; j < nv; ++j) {
      p.axes_mm = grid_point(g, c, i, j, k);
      e(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = hidden.tool_displacement(p, t)[c];
    }
  return e;
}

}  // namespace

FlatPlate plan_plate(const SpaceCalibrationPlan& plan, int c, int k) {
  const auto& g = plan.grid;
  const int u = u_of(c), v = v_of(c);
  const double span = std::max(g.axes_mm[u].back() - g.axes_mm[u].front(), g.axes_mm[v].back() - g.axes_mm[v].front());
  FlatPlate plate = FlatPlate::commercial(plan.plate_form_mm, span + 2 * plan.head.spacing_mm + 20, plan.plate_seed);
  const Vec3& t = plan.head.sensor_offset_mm;
  Vec3 origin;
  origin[u] = g.axes_mm[u].front() + t[u] - 10;
  origin[v] = g.axes_mm[v].front() + t[v] - 10;
  origin[c] =
      g.axes_mm[c][static_cast<std::size_t>(k)] + t[c] - plan.head.standoff_mm;  // the sensors at their standoff
  plate.place(c, +1, origin);
  return plate;
}

SpaceCalibration calibrate_space(const MachineErrorModel& hidden, const SpaceCalibrationPlan& plan) {
  SpaceCalibration out;
  out.space.grid = plan.grid;
  double time_s = plan.start_time_s;
  // The machine's thermometer at the start labels the space (a world without one: 20 C).
  if (const auto t = hidden.machine_temperature_c(time_s)) out.space.temperature_c = std::round(*t * 100) / 100;
  Rng laser_rng(plan.seed ^ 0x5a5a5a5aULL);
  for (int c = 0; c < 3; ++c) {
    if (!plan.components[static_cast<std::size_t>(c)]) continue;
    check_plan(plan, c);
    const auto& g = plan.grid;
    const std::size_t nu = g.axes_mm[u_of(c)].size(), nv = g.axes_mm[v_of(c)].size(), nc = g.axes_mm[c].size();
    // The laser along the normal axis through the planes' first corners: their offsets.
    std::vector<double> offsets(nc, 0.0);
    double laser_sd = 0;
    if (plan.laser_offsets && nc > 1) {
      LaserPlan lp;
      lp.axis = c;
      lp.targets_mm = g.axes_mm[c];
      lp.line_axes_mm = grid_point(g, c, 0, 0, 0);
      lp.reflector_offset_mm = plan.head.sensor_offset_mm;
      lp.cycles = plan.laser_cycles;
      lp.noise_sd_mm = plan.laser_noise_sd_mm;
      auto records = measure_positioning(hidden, lp, laser_rng, time_s);
      const auto eval = error_space::evaluate_positioning(records);
      if (!eval) throw std::logic_error("laser evaluation: " + eval.error());
      // The rig approaches every plane moving in +, so the + means (ISO 230-2 x-bar up) apply.
      for (std::size_t k = 0; k < nc; ++k) offsets[k] = eval->targets[k].mean_up_mm;
      laser_sd = plan.laser_noise_sd_mm / std::sqrt(static_cast<double>(plan.laser_cycles));
      out.laser.insert(out.laser.end(), records.begin(), records.end());
    }
    // An angle instrument's noise reaches B's corrected readings on the lever d.
    const double sigma_b = plan.head.angle_instrument
                               ? std::hypot(plan.head.noise_sd_mm, plan.head.angle_noise_sd_rad * plan.head.spacing_mm)
                               : plan.head.noise_sd_mm;
    const double reversal_sd =
        std::hypot(plan.head.noise_sd_mm, sigma_b) / std::sqrt(2.0 * static_cast<double>(nu - 1));
    const Eigen::MatrixXd floor =
        error_space::surface_noise_sd_mm(static_cast<int>(nu - 1), static_cast<int>(nv - 1), plan.head.noise_sd_mm,
                                         plan.delta_by_reversal ? reversal_sd
                                         : plan.known_delta_mm  ? 0.0
                                                                : -1.0,
                                         sigma_b);
    auto& values = out.space.values_mm[static_cast<std::size_t>(c)];
    auto& sd = out.space.sd_mm[static_cast<std::size_t>(c)];
    values.assign(g.size(), 0.0);
    sd.assign(g.size(), 0.0);
    TwoPointRig rig(hidden, plan_plate(plan, c, 0), plan.head, plan.seed + static_cast<std::uint64_t>(c) * 7919,
                    time_s);
    for (std::size_t k = 0; k < nc; ++k) {
      // The same plate, put where plan_plate puts it: the sensors at their standoff over the plane.
      Vec3 origin;
      origin[u_of(c)] = g.axes_mm[u_of(c)].front() + plan.head.sensor_offset_mm[u_of(c)] - 10;
      origin[v_of(c)] = g.axes_mm[v_of(c)].front() + plan.head.sensor_offset_mm[v_of(c)] - 10;
      origin[c] = g.axes_mm[c][k] + plan.head.sensor_offset_mm[c] - plan.head.standoff_mm;
      rig.place_plate(c, +1, origin);
      const int runs = std::max(1, plan.runs);
      PlaneCalibration pc{c, static_cast<int>(k), {}, offsets[k]};
      for (int r = 0; r < runs; ++r) {
        const auto readings = rig.measure_surface(grid_point(g, c, 0, 0, k), u_of(c), v_of(c), static_cast<int>(nu - 1),
                                                  static_cast<int>(nv - 1));
        error_space::SurfaceOptions opt;
        opt.sensor_sigma_mm = plan.head.noise_sd_mm;
        opt.s7_factor = plan.s7_factor;
        opt.known_delta_mm = plan.known_delta_mm;
        if (plan.delta_by_reversal) {
          // A fresh forward line and the reversed one, so Delta's noise is independent of the plane's.
          const auto forward = rig.measure_line(grid_point(g, c, 0, 0, k), u_of(c), static_cast<int>(nu - 1));
          const auto reversed =
              rig.measure_line(grid_point(g, c, 0, 0, k), u_of(c), static_cast<int>(nu - 1), false, true);
          opt.known_delta_mm = error_space::delta_by_reversal(forward, reversed);
        }
        auto result = error_space::solve_surface(readings, opt);
        if (r == 0) {
          pc.surface = std::move(result);
        } else {
          // The runs share the grid and the reference (e(0,0) = 0, the same slope rule): their mean
          // is the seed's merge of redundant data; S7 asks for a re-measure if any run does.
          pc.surface.error_mm += result.error_mm;
          pc.surface.profile_mm += result.profile_mm;
          pc.surface.remeasure = pc.surface.remeasure || result.remeasure;
        }
      }
      pc.surface.error_mm /= runs;
      pc.surface.profile_mm /= runs;
      if (pc.surface.remeasure) ++out.planes_to_remeasure;
      for (std::size_t i = 0; i < nu; ++i)
        for (std::size_t j = 0; j < nv; ++j) {
          const auto fi = flat_index(g, c, i, j, k);
          values[fi] = pc.surface.error_mm(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) + offsets[k];
          const double s = floor(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) /
                           std::sqrt(static_cast<double>(std::max(1, plan.runs)));
          sd[fi] = std::sqrt(s * s + laser_sd * laser_sd);
        }
      out.planes.push_back(std::move(pc));
    }
    time_s = rig.time_s();
  }
  out.end_time_s = time_s;
  return out;
}

error_space::ErrorSpace truth_in_reference(const MachineErrorModel& hidden, const SpaceCalibrationPlan& plan,
                                           double t) {
  error_space::ErrorSpace out;
  out.grid = plan.grid;
  for (int c = 0; c < 3; ++c) {
    if (!plan.components[static_cast<std::size_t>(c)]) continue;
    const auto& g = plan.grid;
    const std::size_t nc = g.axes_mm[c].size();
    auto& values = out.values_mm[static_cast<std::size_t>(c)];
    values.assign(g.size(), 0.0);
    const double first = plane_truth(hidden, plan, c, 0, t)(0, 0);
    for (std::size_t k = 0; k < nc; ++k) {
      const Eigen::MatrixXd e = plane_truth(hidden, plan, c, k, t);
      // e - e(0,0) - s (i + j); with a known Delta the method keeps the slope: e - e(0,0).
      const Eigen::MatrixXd ref = plan.known_delta_mm || plan.delta_by_reversal ? Eigen::MatrixXd(e.array() - e(0, 0))
                                                                                : error_space::surface_reference(e);
      const double offset = plan.laser_offsets && nc > 1 ? e(0, 0) - first : 0.0;
      for (Eigen::Index i = 0; i < e.rows(); ++i)
        for (Eigen::Index j = 0; j < e.cols(); ++j)
          values[flat_index(g, c, static_cast<std::size_t>(i), static_cast<std::size_t>(j), k)] = ref(i, j) + offset;
    }
  }
  return out;
}

Eigen::MatrixXd plate_truth_in_reference(const MachineErrorModel& hidden, const SpaceCalibrationPlan& plan, int c,
                                         int k) {
  const FlatPlate plate = plan_plate(plan, c, k);
  const Eigen::MatrixXd e = plane_truth(hidden, plan, c, static_cast<std::size_t>(k), 0);
  const Eigen::Index l = e.rows() - 1;
  const bool keeps_slope = plan.known_delta_mm || plan.delta_by_reversal;
  const double s = keeps_slope ? 0.0 : (e(l, 0) - e(0, 0)) / static_cast<double>(l);
  Eigen::MatrixXd f(e.rows(), e.cols());
  for (Eigen::Index i = 0; i < e.rows(); ++i)
    for (Eigen::Index j = 0; j < e.cols(); ++j) {
      const Vec3 p = grid_point(plan.grid, c, static_cast<std::size_t>(i), static_cast<std::size_t>(j),
                                static_cast<std::size_t>(k)) +
                     plan.head.sensor_offset_mm;
      const Vec2 uv = plate.plate_uv(p);
      f(i, j) = plate.profile_mm(uv.x(), uv.y());
    }
  const double f00 = f(0, 0);
  for (Eigen::Index i = 0; i < e.rows(); ++i)
    for (Eigen::Index j = 0; j < e.cols(); ++j) f(i, j) -= f00 + s * static_cast<double>(i + j);
  return f;
}

}  // namespace metron::machine
