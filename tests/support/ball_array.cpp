// SPDX-License-Identifier: GPL-3.0-or-later
#include "ball_array.hpp"

#include <cmath>

#include <fmt/format.h>

#include "metron/stdlib/fitting/fit.hpp"

namespace metron::test_support {

using namespace machine;

BallMeasurement measure_balls(Machine& cmm, const std::vector<Vec3>& nominal_centres_mm, double diameter_mm,
                              double safe_z_mm) {
  BallMeasurement out;
  std::uint64_t tag = 0;
  const auto run = [&](decltype(Command::body) body) -> std::optional<Response> {
    cmm.submit({++tag, std::move(body)});
    auto r = cmm.execute();
    if (r.size() != 1 || r.front().status != Response::Status::Done) {
      if (out.error.empty())
        out.error = r.empty() ? "no response" : r.front().fault ? r.front().fault->message : "fault";
      return std::nullopt;
    }
    return r.front();
  };
  run(DefineTool{"T1", 4.0});
  run(SelectTool{"T1"});
  run(SetFeeds{200, 0, 0});
  const double probe_r = 2.0, approach = 2.0;
  const double big_r = diameter_mm / 2;
  for (const Vec3& c : nominal_centres_mm) {
    std::vector<Vec3> normals{Vec3::UnitZ()};
    for (int k = 0; k < 4; ++k) {
      const double a = M_PI / 2 * k + M_PI / 4;
      normals.emplace_back(std::cos(a) * std::sqrt(0.5), std::sin(a) * std::sqrt(0.5), std::sqrt(0.5));
    }
    for (int k = 0; k < 4; ++k) {
      const double a = M_PI / 2 * k;
      normals.emplace_back(std::cos(a), std::sin(a), 0);
    }
    const double above_z = c.z() + big_r + probe_r + 5;
    run(GoTo{Vec3(c.x(), c.y(), safe_z_mm), std::nullopt});
    std::vector<Vec3> hits;
    for (const Vec3& n : normals) {
      const Vec3 start = c + (big_r + probe_r + approach) * n;
      run(GoTo{Vec3(start.x(), start.y(), above_z), std::nullopt});
      PtMeas m;
      m.nominal_mm = c + big_r * n;
      m.normal = n;
      m.approach_mm = approach;
      if (auto r = run(m); r && r->hit) hits.push_back(r->hit->centre_mm);
      run(GoTo{Vec3(start.x(), start.y(), above_z), std::nullopt});
    }
    run(GoTo{Vec3(c.x(), c.y(), safe_z_mm), std::nullopt});
    auto f = fitting::fit(fitting::Shape::Sphere, hits);
    out.centres_mm.push_back(f ? f->position : Vec3(Vec3::Constant(std::nan(""))));
    if (!f && out.error.empty())
      out.error = fmt::format("sphere fit failed for the ball at ({}, {}, {})", c.x(), c.y(), c.z());
  }
  out.simulated_time_s = cmm.state().time_s;
  return out;
}

LengthErrors length_errors(const std::vector<Vec3>& measured_mm, const std::vector<Vec3>& truth_mm) {
  LengthErrors out;
  double sum = 0;
  for (std::size_t i = 0; i < truth_mm.size() && i < measured_mm.size(); ++i)
    for (std::size_t j = i + 1; j < truth_mm.size() && j < measured_mm.size(); ++j) {
      const double e = (measured_mm[i] - measured_mm[j]).norm() - (truth_mm[i] - truth_mm[j]).norm();
      sum += e * e;
      out.max_abs_mm = std::max(out.max_abs_mm, std::abs(e));
      ++out.pairs;
    }
  out.rms_mm = out.pairs ? std::sqrt(sum / static_cast<double>(out.pairs)) : 0;
  return out;
}

Vec3 TruthErrorMap::error_at_mm(const Vec3& q_mm) const {
  MachinePose pose;
  pose.axes_mm = q_mm - m_stylus_offset_mm;
  pose.probe_offset_mm = m_stylus_offset_mm;
  return m_model.displacement(pose, 0);
}

error_space::ErrorSpaceFile truth_error_space(const MachineErrorModel& model, const error_space::Grid& grid,
                                              const Vec3& stylus_offset_mm,
                                              const error_space::InterpolationSpec& spec) {
  error_space::ErrorSpace space;
  space.grid = grid;
  for (auto& v : space.values_mm) v.assign(grid.size(), 0.0);
  MachinePose pose;
  pose.probe_offset_mm = stylus_offset_mm;
  for (std::size_t k = 0; k < grid.axes_mm[2].size(); ++k)
    for (std::size_t j = 0; j < grid.axes_mm[1].size(); ++j)
      for (std::size_t i = 0; i < grid.axes_mm[0].size(); ++i) {
        pose.axes_mm = Vec3(grid.axes_mm[0][i], grid.axes_mm[1][j], grid.axes_mm[2][k]);
        const Vec3 e = model.displacement(pose, 0);
        for (int c = 0; c < 3; ++c) space.values_mm[c][grid.index(i, j, k)] = e[c];
      }
  error_space::ErrorSpaceFile file;
  file.spaces.push_back(std::move(space));
  file.interpolation = spec;
  file.sensor_offset_mm = {stylus_offset_mm.x(), stylus_offset_mm.y(), stylus_offset_mm.z()};
  file.description = "the hidden truth sampled at the grid (tests only)";
  return file;
}

}  // namespace metron::test_support
