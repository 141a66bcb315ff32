// SPDX-License-Identifier: GPL-3.0-or-later
// Cylinder and cone: several algebraic starts, each refined by Levenberg-Marquardt with Forbes'
// re-linearisation about the current axis; the lowest sum of squares wins.
#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>

#include "geometry_fits.hpp"
#include "levenberg_marquardt.hpp"

namespace metron::fitting::detail {
namespace {

/// At most `count` of the points, evenly strided: enough to rank starting guesses, so the
/// search costs the same for a 20000-point scan as for a 400-point one.
std::vector<Vec3> subsample(const std::vector<Vec3>& q, std::size_t count) {
  if (q.size() <= count) return q;
  std::vector<Vec3> out;
  out.reserve(count);
  for (std::size_t k = 0; k < count; ++k) out.push_back(q[k * q.size() / count]);
  return out;
}

/// Rows u, v, a: rotates world vectors into the frame whose z axis is `axis`.
Mat3 axis_frame(const Vec3& axis) {
  const Vec3 u = any_perpendicular(axis);
  Mat3 r;
  r.row(0) = u.transpose();
  r.row(1) = axis.cross(u).transpose();
  r.row(2) = axis.transpose();
  return r;
}

/// Local step of the axis (A. B. Forbes, "Least-squares best-fit geometric elements", NPL
/// Report DITC 140/89, 1989): the axis through (d0, d1, 0) along
/// (d2, d3, 1) in the frame of the current axis. The new point is moved to the foot of the
/// origin (the centroid), the NIST reference point; returns that axial shift.
double step_axis(const Vec3& point, const Vec3& axis, const Eigen::VectorXd& delta, Vec3& new_point, Vec3& new_axis) {
  const Mat3 rt = axis_frame(axis).transpose();
  new_axis = (rt * Vec3(delta(2), delta(3), 1)).normalized();
  new_point = point + rt * Vec3(delta(0), delta(1), 0);
  const double shift = -new_point.dot(new_axis);
  new_point += shift * new_axis;
  return shift;
}

struct CylinderState {
  Vec3 point;  ///< on the axis, foot of the centroid
  Vec3 axis;   ///< unit
  double radius = 0;
};

/// d_i = rho_i - r, rho_i the distance from the axis (Shakarji 1998, cylinders).
struct CylinderModel {
  const std::vector<Vec3>& points;

  void evaluate(const CylinderState& s, Eigen::VectorXd& r, Eigen::MatrixXd& jac) const {
    const Mat3 rot = axis_frame(s.axis);
    const auto n = static_cast<Eigen::Index>(points.size());
    r.resize(n);
    jac.resize(n, 5);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Vec3 l = rot * (points[static_cast<std::size_t>(i)] - s.point);
      const double rho = std::sqrt(l.x() * l.x() + l.y() * l.y());
      const double cx = rho > 0 ? l.x() / rho : 0;
      const double cy = rho > 0 ? l.y() / rho : 0;
      r(i) = rho - s.radius;
      jac.row(i) << -cx, -cy, -cx * l.z(), -cy * l.z(), -1;
    }
  }
  CylinderState step(const CylinderState& s, const Eigen::VectorXd& delta) const {
    CylinderState t;
    step_axis(s.point, s.axis, delta, t.point, t.axis);
    t.radius = s.radius + delta(4);
    return t;
  }
};

struct ConeState {
  Vec3 point;             ///< on the axis, foot of the centroid
  Vec3 axis;              ///< unit
  double half_angle = 0;  ///< psi, radius grows along +axis when positive
  double distance = 0;    ///< s: orthogonal distance from `point` to the surface
};

/// d_i = rho_i cos(psi) - w_i sin(psi) - s, with w_i the axial coordinate from the point
/// (Shakarji 1998, cones; Forbes, NPL DITC 140/89).
struct ConeModel {
  const std::vector<Vec3>& points;

  void evaluate(const ConeState& s, Eigen::VectorXd& r, Eigen::MatrixXd& jac) const {
    const Mat3 rot = axis_frame(s.axis);
    const double c = std::cos(s.half_angle);
    const double sn = std::sin(s.half_angle);
    const auto n = static_cast<Eigen::Index>(points.size());
    r.resize(n);
    jac.resize(n, 6);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Vec3 l = rot * (points[static_cast<std::size_t>(i)] - s.point);
      const double rho = std::sqrt(l.x() * l.x() + l.y() * l.y());
      const double cx = rho > 0 ? l.x() / rho : 0;
      const double cy = rho > 0 ? l.y() / rho : 0;
      const double w = l.z();
      r(i) = rho * c - w * sn - s.distance;
      jac.row(i) << -c * cx, -c * cy, -cx * w * c - sn * l.x(), -cy * w * c - sn * l.y(), -rho * sn - w * c, -1;
    }
  }
  ConeState step(const ConeState& s, const Eigen::VectorXd& delta) const {
    ConeState t;
    const double shift = step_axis(s.point, s.axis, delta, t.point, t.axis);
    t.half_angle = s.half_angle + delta(4);
    // Moving the point along the axis by `shift` changes its distance to the surface by shift*sin(psi).
    t.distance = s.distance + delta(5) + shift * std::sin(t.half_angle);
    return t;
  }
};

/// Candidate axis directions, in order of preference: the hint, the three principal axes (long
/// cylinders lie along the largest, short rings and flat cones along the smallest, partial
/// patches may need the middle one; `smallest_first` for cones, which are mostly short: seats,
/// countersinks, chamfers), and the distinct eigenvector of an algebraic quadric through the points.
std::vector<Vec3> candidate_axes(const std::vector<Vec3>& q, const std::optional<Vec3>& hint, bool smallest_first) {
  std::vector<Vec3> axes;
  auto add = [&axes](const Vec3& a) {
    if (!(a.norm() > 0) || !a.allFinite()) return;
    const Vec3 unit = a.normalized();
    for (const Vec3& b : axes) {
      if (std::abs(unit.dot(b)) > 1 - 1e-12) return;
    }
    axes.push_back(unit);
  };
  if (hint) add(*hint);
  const PrincipalAxes pa = principal_axes(q);
  for (int k = 0; k < 3; ++k) add(pa.axes.col(smallest_first ? 2 - k : k));
  if (q.size() >= 10) {
    // General quadric x'Ax + b'x + c = 0 by the smallest singular vector; for a cylinder or cone
    // the axis is the eigenvector of A whose eigenvalue differs from the other two.
    Eigen::MatrixXd m(static_cast<Eigen::Index>(q.size()), 10);
    for (std::size_t i = 0; i < q.size(); ++i) {
      const Vec3& p = q[i];
      m.row(static_cast<Eigen::Index>(i)) << p.x() * p.x(), p.y() * p.y(), p.z() * p.z(), p.x() * p.y(), p.x() * p.z(),
          p.y() * p.z(), p.x(), p.y(), p.z(), 1;
    }
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(m, Eigen::ComputeThinV);
    const Eigen::VectorXd c = svd.matrixV().col(9);
    Mat3 a;
    a << c(0), c(3) / 2, c(4) / 2, c(3) / 2, c(1), c(5) / 2, c(4) / 2, c(5) / 2, c(2);
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(a);
    const Vec3 ev = eig.eigenvalues();
    add(eig.eigenvectors().col(ev(1) - ev(0) > ev(2) - ev(1) ? 0 : 2));
  }
  return axes;
}

/// Circle through the points projected along `axis` (Kasa's linear fit): a cylinder start.
std::optional<CylinderState> cylinder_start(const std::vector<Vec3>& q, const Vec3& axis) {
  const Mat3 rot = axis_frame(axis);
  const auto n = static_cast<Eigen::Index>(q.size());
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 l = rot * q[static_cast<std::size_t>(i)];
    a.row(i) << 2 * l.x(), 2 * l.y(), 1;
    b(i) = l.x() * l.x() + l.y() * l.y();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr = a.colPivHouseholderQr();
  if (qr.rank() < 3) return std::nullopt;
  const Eigen::Vector3d x = qr.solve(b);
  const double r2 = x(2) + x(0) * x(0) + x(1) * x(1);
  if (!(r2 > 0) || !std::isfinite(r2)) return std::nullopt;
  return CylinderState{rot.transpose() * Vec3(x(0), x(1), 0), axis, std::sqrt(r2)};
}

/// Linear fit of u^2 + v^2 = 2 u u0 + 2 v v0 + (R0^2 - u0^2 - v0^2) + 2 R0 t w + t^2 w^2, the
/// cone (u - u0)^2 + (v - v0)^2 = (R0 + t w)^2 about a fixed axis direction (t = tan psi).
std::optional<ConeState> cone_start(const std::vector<Vec3>& q, const Vec3& axis) {
  const Mat3 rot = axis_frame(axis);
  const auto n = static_cast<Eigen::Index>(q.size());
  Eigen::MatrixXd a(n, 5);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 l = rot * q[static_cast<std::size_t>(i)];
    a.row(i) << 2 * l.x(), 2 * l.y(), 1, l.z(), l.z() * l.z();
    b(i) = l.x() * l.x() + l.y() * l.y();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr = a.colPivHouseholderQr();
  if (qr.rank() < 5) return std::nullopt;
  const Eigen::VectorXd x = qr.solve(b);
  const double r2 = x(2) + x(0) * x(0) + x(1) * x(1);
  if (!(r2 > 0) || !std::isfinite(r2)) return std::nullopt;
  const double r0 = std::sqrt(r2);
  const double psi = std::atan(x(3) / (2 * r0));
  return ConeState{rot.transpose() * Vec3(x(0), x(1), 0), axis, psi, r0 * std::cos(psi)};
}

/// A runaway radius means the data is (nearly) flat or straight: no finite cylinder.
bool plausible(const CylinderState& s) { return s.point.allFinite() && std::abs(s.radius) < 1e8; }
bool plausible(const ConeState& s) {
  return s.point.allFinite() && std::isfinite(s.distance) && std::abs(s.distance) < 1e8 &&
         std::abs(s.half_angle) < std::numbers::pi / 2;
}

/// Runs every start, returns the converged state with the smallest sum of squares. Costs equal
/// to within rounding go to the earlier start, so that when several shapes pass through the
/// points exactly (as many points as parameters) the answer does not depend on rounding noise.
template <class Model, class State>
std::optional<std::pair<State, int>> best_of(const Model& model, const std::vector<State>& starts) {
  std::optional<std::pair<State, int>> best;
  double best_cost = std::numeric_limits<double>::infinity();
  const double noise = 1e-28 * static_cast<double>(model.points.size());
  for (State s : starts) {
    const LmOutcome out = levenberg_marquardt(model, s);
    if (out.converged && plausible(s) && out.cost < best_cost * (1 - 1e-10) - noise) {
      best_cost = out.cost;
      best = std::pair{s, out.iterations};
    }
  }
  return best;
}

/// `count` directions spread evenly over a hemisphere (a Fibonacci lattice: A. Gonzalez,
/// "Measurement of areas on a sphere using Fibonacci and latitude-longitude lattices",
/// Math. Geosci. 42, 2010).
std::vector<Vec3> hemisphere_directions(int count) {
  std::vector<Vec3> out;
  out.reserve(static_cast<std::size_t>(count));
  const double golden_angle = std::numbers::pi * (3 - std::sqrt(5.0));
  for (int k = 0; k < count; ++k) {
    const double z = (k + 0.5) / count;
    const double r = std::sqrt(1 - z * z);
    out.emplace_back(r * std::cos(golden_angle * k), r * std::sin(golden_angle * k), z);
  }
  return out;
}

/// Appends starts from a coarse search over axis directions: the algebraic start about each of
/// 200 directions (about 10 degrees apart) is scored by its geometric sum of squares and the best
/// few, at least 20 degrees apart, are kept. Partial arcs and short patches can have their
/// minimum far from every principal axis; this finds its basin.
template <class Model, class State, class MakeStart>
void add_searched_starts(const Model& model, MakeStart make_start, std::vector<State>& starts) {
  struct Scored {
    double cost;
    State state;
  };
  std::vector<Scored> scored;
  Eigen::VectorXd r;
  Eigen::MatrixXd jac;
  for (const Vec3& axis : hemisphere_directions(200)) {
    for (const State& s : make_start(axis)) {
      model.evaluate(s, r, jac);
      if (r.allFinite()) scored.push_back({r.squaredNorm(), s});
    }
  }
  std::stable_sort(scored.begin(), scored.end(), [](const Scored& a, const Scored& b) { return a.cost < b.cost; });
  const double min_cos = std::cos(20 * std::numbers::pi / 180);
  std::vector<Vec3> kept;
  for (const Scored& c : scored) {
    if (kept.size() == 3) break;
    if (std::any_of(kept.begin(), kept.end(), [&](const Vec3& a) { return std::abs(a.dot(c.state.axis)) > min_cos; })) {
      continue;
    }
    kept.push_back(c.state.axis);
    starts.push_back(c.state);
  }
}

/// Points used to rank starting guesses.
constexpr std::size_t search_sample_size = 400;

/// A plane is the limit of cylinders and cones whose radius grows without bound, so their least
/// sum of squares is at most the plane's. A best fit worse than the plane means the minimum lies
/// at infinity (nearly flat data) or was missed: either way there is no fit to report.
template <class Model, class State>
bool beaten_by_plane(const Model& model, const State& best, const PrincipalAxes& pa) {
  Eigen::VectorXd r;
  Eigen::MatrixXd jac;
  model.evaluate(best, r, jac);
  const double plane_cost = static_cast<double>(model.points.size()) * pa.rms_extent(2) * pa.rms_extent(2);
  return r.squaredNorm() > plane_cost * (1 + 1e-9) + 1e-28 * static_cast<double>(model.points.size());
}

/// The best start: from the hint alone when `hint_only` and that converges to something better
/// than a plane (a measured feature fitted from its nominal), else the lowest of every candidate
/// axis and a coarse search over directions.
template <class Model, class MakeStart>
auto search_best(const Model& model, const std::vector<Vec3>& sample, MakeStart make_start,
                 const std::optional<Vec3>& axis_hint, bool hint_only, bool cone, const PrincipalAxes& pa) {
  using State = typename decltype(make_start(sample, Vec3::UnitZ()))::value_type;
  std::optional<std::pair<State, int>> best;
  if (hint_only && axis_hint) best = best_of(model, make_start(model.points, axis_hint->normalized()));
  if (best && !beaten_by_plane(model, best->first, pa)) return best;
  std::vector<State> starts;
  for (const Vec3& axis : candidate_axes(sample, axis_hint, cone)) {
    for (const State& s : make_start(model.points, axis)) starts.push_back(s);
  }
  add_searched_starts(
      Model{sample}, [&](const Vec3& axis) { return make_start(sample, axis); }, starts);
  return best_of(model, starts);
}

/// Centred and scaled points, their principal axes and the sample used to rank starts; a set
/// without extent in two directions determines no axis.
struct AxialInput {
  NormalizedPoints np;
  PrincipalAxes pa;
  std::vector<Vec3> sample;
};

tl::expected<AxialInput, FitFailure> prepare_axial(const std::vector<Vec3>& points) {
  NormalizedPoints np = normalize(points);
  PrincipalAxes pa = principal_axes(np.points);
  if (!(pa.rms_extent(1) > degenerate_extent * pa.rms_extent(0))) return tl::unexpected(FitFailure::Degenerate);
  std::vector<Vec3> sample = subsample(np.points, search_sample_size);
  return AxialInput{std::move(np), std::move(pa), std::move(sample)};
}

}  // namespace

tl::expected<Geometry, FitFailure> fit_cylinder_geometry(const std::vector<Vec3>& points,
                                                         const std::optional<Vec3>& axis_hint, bool hint_only) {
  const auto prepared = prepare_axial(points);
  if (!prepared) return tl::unexpected(prepared.error());
  const auto& [np, pa, sample] = *prepared;
  auto make_start = [](const std::vector<Vec3>& q, const Vec3& axis) {
    std::vector<CylinderState> out;
    if (auto s = cylinder_start(q, axis)) out.push_back(*s);
    return out;
  };
  const CylinderModel model{np.points};
  const auto best = search_best(model, sample, make_start, axis_hint, hint_only, false, pa);
  if (!best || beaten_by_plane(model, best->first, pa)) return tl::unexpected(FitFailure::NoConvergence);
  const auto& [s, iterations] = *best;
  Geometry g;
  g.position = np.to_world(s.point);
  g.direction = s.axis;
  g.radius_mm = std::abs(s.radius) * np.scale;
  g.iterations = iterations;
  return g;
}

tl::expected<Geometry, FitFailure> fit_cone_geometry(const std::vector<Vec3>& points,
                                                     const std::optional<Vec3>& axis_hint, bool hint_only) {
  const auto prepared = prepare_axial(points);
  if (!prepared) return tl::unexpected(prepared.error());
  const auto& [np, pa, sample] = *prepared;
  auto make_start = [](const std::vector<Vec3>& q, const Vec3& axis) {
    std::vector<ConeState> out;
    if (auto s = cone_start(q, axis)) out.push_back(*s);
    // A cylinder start as well: the linear cone fit is poor for nearly cylindrical cones.
    if (auto c = cylinder_start(q, axis)) out.push_back(ConeState{c->point, c->axis, 0, c->radius});
    return out;
  };
  const ConeModel model{np.points};
  const auto best = search_best(model, sample, make_start, axis_hint, hint_only, true, pa);
  if (!best || beaten_by_plane(model, best->first, pa)) return tl::unexpected(FitFailure::NoConvergence);
  auto [s, iterations] = *best;
  if (s.half_angle < 0) {
    // Same cone: d = rho cos(psi) - w sin(psi) - s is unchanged by w -> -w, psi -> -psi.
    s.axis = -s.axis;
    s.half_angle = -s.half_angle;
  }
  Geometry g;
  g.position = np.to_world(s.point);
  g.direction = s.axis;
  g.half_angle_rad = s.half_angle;
  g.cone_distance_mm = s.distance * np.scale;
  g.iterations = iterations;
  return g;
}

}  // namespace metron::fitting::detail
