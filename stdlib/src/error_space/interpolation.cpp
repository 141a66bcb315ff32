// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/error_space/interpolation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <Eigen/Dense>

namespace metron::error_space {
namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

/// Finds the cell of a coordinate on one axis: uniform grids by division, others by bisection.
class AxisLookup {
 public:
  explicit AxisLookup(const std::vector<double>& x) : m_x(x), m_n(static_cast<int>(x.size())) {
    if (m_n > 1) {
      m_h = (x.back() - x.front()) / (m_n - 1);
      m_uniform = true;
      for (int i = 0; i < m_n; ++i)
        if (std::abs(x[static_cast<std::size_t>(i)] - (x.front() + i * m_h)) > 1e-9 * (x.back() - x.front()))
          m_uniform = false;
    }
  }
  [[nodiscard]] int size() const { return m_n; }
  [[nodiscard]] bool uniform() const { return m_uniform; }
  /// Cell i in [0, n-2] and the fraction r in [0, 1] (clamped); a one-point axis gives (0, 0).
  void locate(double q, int& i, double& r) const {
    if (m_n < 2) {
      i = 0;
      r = 0;
      return;
    }
    if (m_uniform) {
      const double t = std::clamp((q - m_x.front()) / m_h, 0.0, static_cast<double>(m_n - 1));
      i = std::min(static_cast<int>(t), m_n - 2);
      r = t - i;
      return;
    }
    q = std::clamp(q, m_x.front(), m_x.back());
    const auto it = std::upper_bound(m_x.begin(), m_x.end(), q);
    i = std::clamp(static_cast<int>(it - m_x.begin()) - 1, 0, m_n - 2);
    const auto ui = static_cast<std::size_t>(i);
    r = (q - m_x[ui]) / (m_x[ui + 1] - m_x[ui]);
  }

 private:
  std::vector<double> m_x;
  int m_n = 0;
  double m_h = 1;
  bool m_uniform = false;
};

class Trilinear final : public FieldInterpolator {
 public:
  Trilinear(const Grid& g, std::vector<double> v)
      : m_ax{AxisLookup(g.axes_mm[0]), AxisLookup(g.axes_mm[1]), AxisLookup(g.axes_mm[2])}, m_v(std::move(v)) {
    m_nx = g.axes_mm[0].size();
    m_nxy = m_nx * g.axes_mm[1].size();
  }
  [[nodiscard]] double value(double x, double y, double z) const override {
    int i, j, k;
    double rx, ry, rz;
    m_ax[0].locate(x, i, rx);
    m_ax[1].locate(y, j, ry);
    m_ax[2].locate(z, k, rz);
    const std::size_t dx = m_ax[0].size() > 1 ? 1 : 0, dy = m_ax[1].size() > 1 ? m_nx : 0,
                      dz = m_ax[2].size() > 1 ? m_nxy : 0;
    const std::size_t b =
        static_cast<std::size_t>(i) + m_nx * static_cast<std::size_t>(j) + m_nxy * static_cast<std::size_t>(k);
    const double* v = m_v.data();
    // SEEDS.md 4: e = sum over the 8 corners of the corner value times (1-r or r) per axis.
    const double c00 = v[b] * (1 - rx) + v[b + dx] * rx;
    const double c10 = v[b + dy] * (1 - rx) + v[b + dy + dx] * rx;
    const double c01 = v[b + dz] * (1 - rx) + v[b + dz + dx] * rx;
    const double c11 = v[b + dz + dy] * (1 - rx) + v[b + dz + dy + dx] * rx;
    return (c00 * (1 - ry) + c10 * ry) * (1 - rz) + (c01 * (1 - ry) + c11 * ry) * rz;
  }

 private:
  std::array<AxisLookup, 3> m_ax;
  std::vector<double> m_v;
  std::size_t m_nx = 1, m_nxy = 1;
};

/// Interpolating cubic B-spline on a uniform axis: n values -> n+2 control points, with
/// v_i = (c_{i-1} + 4 c_i + c_{i+1}) / 6 at the nodes and not-a-knot ends (third derivative
/// continuous at the second and the last-but-one node; C. de Boor, A Practical Guide to Splines,
/// 1978, ch. IV). Returns the (n+2) x n matrix mapping values to control points.
Eigen::MatrixXd bspline_solver(int n) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n + 2, n + 2);
  for (int i = 0; i < n; ++i) m(i, i) = 1.0 / 6, m(i, i + 1) = 4.0 / 6, m(i, i + 2) = 1.0 / 6;
  const double jump[5] = {1, -4, 6, -4, 1};
  for (int t = 0; t < 5; ++t) m(n, t) = jump[t], m(n + 1, n - 3 + t) = jump[t];
  const Eigen::MatrixXd inv = m.fullPivLu().inverse();
  return inv.leftCols(n);
}

class BSpline final : public FieldInterpolator {
 public:
  BSpline(const Grid& g, const std::vector<double>& v)
      : m_ax{AxisLookup(g.axes_mm[0]), AxisLookup(g.axes_mm[1]), AxisLookup(g.axes_mm[2])} {
    std::array<std::size_t, 3> dims{g.axes_mm[0].size(), g.axes_mm[1].size(), g.axes_mm[2].size()};
    std::vector<double> data = v;
    for (int a = 0; a < 3; ++a) {
      if (dims[a] == 1) continue;
      const Eigen::MatrixXd p = bspline_solver(static_cast<int>(dims[a]));
      std::array<std::size_t, 3> out_dims = dims;
      out_dims[a] = dims[a] + 2;
      std::vector<double> out(out_dims[0] * out_dims[1] * out_dims[2]);
      const std::size_t stride_in = a == 0 ? 1 : a == 1 ? dims[0] : dims[0] * dims[1];
      const std::size_t stride_out = a == 0 ? 1 : a == 1 ? out_dims[0] : out_dims[0] * out_dims[1];
      Eigen::VectorXd line(static_cast<Eigen::Index>(dims[a]));
      for (std::size_t k = 0; k < (a == 2 ? 1 : dims[2]); ++k)
        for (std::size_t j = 0; j < (a == 1 ? 1 : dims[1]); ++j)
          for (std::size_t i = 0; i < (a == 0 ? 1 : dims[0]); ++i) {
            const std::size_t base_in = i + dims[0] * (j + dims[1] * k);
            const std::size_t base_out = i + out_dims[0] * (j + out_dims[1] * k);
            for (std::size_t t = 0; t < dims[a]; ++t)
              line[static_cast<Eigen::Index>(t)] = data[base_in + t * stride_in];
            const Eigen::VectorXd c = p * line;
            for (std::size_t t = 0; t < out_dims[a]; ++t)
              out[base_out + t * stride_out] = c[static_cast<Eigen::Index>(t)];
          }
      data = std::move(out);
      dims = out_dims;
    }
    m_c = std::move(data);
    m_dims = dims;
  }
  [[nodiscard]] double value(double x, double y, double z) const override {
    std::array<double, 4> w[3];
    int start[3], count[3];
    const double q[3] = {x, y, z};
    for (int a = 0; a < 3; ++a) {
      if (m_ax[a].size() == 1) {
        w[a][0] = 1;
        start[a] = 0;
        count[a] = 1;
        continue;
      }
      int i;
      double u;
      m_ax[a].locate(q[a], i, u);
      // Uniform cubic B-spline basis on c_{i-1} .. c_{i+2} (control index i-1 is column i).
      const double u2 = u * u, u3 = u2 * u;
      w[a] = {(1 - u) * (1 - u) * (1 - u) / 6, (3 * u3 - 6 * u2 + 4) / 6, (-3 * u3 + 3 * u2 + 3 * u + 1) / 6, u3 / 6};
      start[a] = i;
      count[a] = 4;
    }
    double sum = 0;
    for (int c = 0; c < count[2]; ++c) {
      double sy = 0;
      for (int b = 0; b < count[1]; ++b) {
        const double* row =
            &m_c[static_cast<std::size_t>(start[0]) + m_dims[0] * (static_cast<std::size_t>(start[1] + b) +
                                                                   m_dims[1] * static_cast<std::size_t>(start[2] + c))];
        double sx = 0;
        for (int a = 0; a < count[0]; ++a) sx += w[0][static_cast<std::size_t>(a)] * row[a];
        sy += w[1][static_cast<std::size_t>(b)] * sx;
      }
      sum += w[2][static_cast<std::size_t>(c)] * sy;
    }
    return sum;
  }

 private:
  std::array<AxisLookup, 3> m_ax;
  std::vector<double> m_c;
  std::array<std::size_t, 3> m_dims{};
};

/// SEEDS.md 4 (3): least squares on a model around each cell: x^ = (A^T A)^-1 A^T y,
/// sigma^2 = |y - A x^|^2 / (m - p), Cx = sigma^2 (A^T A)^-1, sigma_e^2 = phi Cx phi^T. Fitted per
/// cell at construction so that a query is one dot product.
class LeastSquares final : public FieldInterpolator {
 public:
  LeastSquares(const Grid& g, const std::vector<double>& v, const LeastSquaresOptions& o, std::string& error)
      : m_ax{AxisLookup(g.axes_mm[0]), AxisLookup(g.axes_mm[1]), AxisLookup(g.axes_mm[2])}, m_grid(g) {
    int window[3];
    for (int a = 0; a < 3; ++a) {
      const int n = m_ax[a].size();
      window[a] = std::min(2 * o.neighbourhood, n);
      m_cells[a] = std::max(n - 1, 1);
    }
    // Monomials u^p v^q w^r of total degree <= degree, each power below the window size.
    for (int r = 0; r <= o.degree; ++r)
      for (int q = 0; q <= o.degree; ++q)
        for (int p = 0; p <= o.degree; ++p)
          if (p + q + r <= o.degree && p < window[0] && q < window[1] && r < window[2]) m_terms.push_back({p, q, r});
    const int np = static_cast<int>(m_terms.size());
    const int points = window[0] * window[1] * window[2];
    if (points < np) {
      error = fmt::format("least squares: {} points around a cell cannot fit {} model terms", points, np);
      return;
    }
    const std::size_t cells = static_cast<std::size_t>(m_cells[0] * m_cells[1] * m_cells[2]);
    m_coef.resize(cells * static_cast<std::size_t>(np));
    m_cov.resize(cells * static_cast<std::size_t>(np * np));
    Eigen::MatrixXd A(points, np);
    Eigen::VectorXd y(points);
    for (int ck = 0; ck < m_cells[2]; ++ck)
      for (int cj = 0; cj < m_cells[1]; ++cj)
        for (int ci = 0; ci < m_cells[0]; ++ci) {
          const int c[3] = {ci, cj, ck};
          int lo[3];
          for (int a = 0; a < 3; ++a) lo[a] = std::clamp(c[a] - (o.neighbourhood - 1), 0, m_ax[a].size() - window[a]);
          int row = 0;
          for (int k = lo[2]; k < lo[2] + window[2]; ++k)
            for (int j = lo[1]; j < lo[1] + window[1]; ++j)
              for (int i = lo[0]; i < lo[0] + window[0]; ++i) {
                const int idx[3] = {i, j, k};
                double u[3];
                for (int a = 0; a < 3; ++a) u[a] = local(a, c[a], m_grid.axes_mm[a][static_cast<std::size_t>(idx[a])]);
                phi(u, &A(row, 0), A.outerStride());
                y[row] =
                    v[g.index(static_cast<std::size_t>(i), static_cast<std::size_t>(j), static_cast<std::size_t>(k))];
                ++row;
              }
          const Eigen::MatrixXd ata = A.transpose() * A;
          Eigen::FullPivLU<Eigen::MatrixXd> lu(ata);
          if (lu.rank() < np) {
            error = "least squares: the model is not determined by the points around a cell";
            return;
          }
          const Eigen::MatrixXd inv = lu.inverse();
          const Eigen::VectorXd xhat = inv * (A.transpose() * y);
          const int dof = points - np;
          const double s2 = dof > 0 ? (y - A * xhat).squaredNorm() / dof : nan;
          const std::size_t cell = static_cast<std::size_t>(ci + m_cells[0] * (cj + m_cells[1] * ck));
          for (int t = 0; t < np; ++t)
            m_coef[cell * static_cast<std::size_t>(np) + static_cast<std::size_t>(t)] = xhat[t];
          for (int t = 0; t < np * np; ++t)
            m_cov[cell * static_cast<std::size_t>(np * np) + static_cast<std::size_t>(t)] = s2 * inv(t % np, t / np);
        }
  }
  [[nodiscard]] double value(double x, double y, double z) const override {
    return estimate_impl(x, y, z, false).value_mm;
  }
  [[nodiscard]] Estimate estimate(double x, double y, double z) const override { return estimate_impl(x, y, z, true); }

 private:
  /// Coordinate in units of the cell's own spacing, from its first corner (conditioning).
  [[nodiscard]] double local(int a, int cell, double q) const {
    const auto& x = m_grid.axes_mm[a];
    if (x.size() < 2) return 0;
    const auto c = static_cast<std::size_t>(cell);
    return (q - x[c]) / (x[c + 1] - x[c]);
  }
  void phi(const double u[3], double* out, Eigen::Index stride) const {
    const double pw[3][3] = {{1, u[0], u[0] * u[0]}, {1, u[1], u[1] * u[1]}, {1, u[2], u[2] * u[2]}};
    for (std::size_t t = 0; t < m_terms.size(); ++t)
      out[static_cast<Eigen::Index>(t) * stride] = pw[0][m_terms[t][0]] * pw[1][m_terms[t][1]] * pw[2][m_terms[t][2]];
  }
  [[nodiscard]] Estimate estimate_impl(double x, double y, double z, bool with_sd) const {
    int c[3];
    double r[3];
    m_ax[0].locate(x, c[0], r[0]);
    m_ax[1].locate(y, c[1], r[1]);
    m_ax[2].locate(z, c[2], r[2]);
    const std::size_t np = m_terms.size();
    double f[20];
    phi(r, f, 1);
    const std::size_t cell = static_cast<std::size_t>(c[0] + m_cells[0] * (c[1] + m_cells[1] * c[2]));
    const double* b = &m_coef[cell * np];
    Estimate e{0, nan};
    for (std::size_t t = 0; t < np; ++t) e.value_mm += f[t] * b[t];
    if (with_sd) {
      const double* cv = &m_cov[cell * np * np];
      double s = 0;
      for (std::size_t p = 0; p < np; ++p)
        for (std::size_t q = 0; q < np; ++q) s += f[p] * cv[p + np * q] * f[q];
      e.sd_mm = std::sqrt(std::max(s, 0.0));
    }
    return e;
  }

  std::array<AxisLookup, 3> m_ax;
  Grid m_grid;
  int m_cells[3] = {1, 1, 1};
  std::vector<std::array<int, 3>> m_terms;
  std::vector<double> m_coef, m_cov;
};

}  // namespace

std::string_view to_string(Method m) {
  switch (m) {
    case Method::Trilinear: return "trilinear";
    case Method::BSpline: return "bspline";
    case Method::LeastSquares: return "least-squares";
  }
  return "?";
}

Estimate FieldInterpolator::estimate(double x, double y, double z) const { return {value(x, y, z), nan}; }

tl::expected<std::unique_ptr<FieldInterpolator>, std::string> make_field(const Grid& grid, const std::vector<double>& v,
                                                                         const InterpolationSpec& spec) {
  if (!grid.valid()) return tl::unexpected(std::string("the grid axes must be non-empty and strictly increasing"));
  if (v.size() != grid.size())
    return tl::unexpected(fmt::format("{} values for a grid of {} points", v.size(), grid.size()));
  switch (spec.method) {
    case Method::Trilinear: return std::make_unique<Trilinear>(grid, v);
    case Method::BSpline:
      for (int a = 0; a < 3; ++a) {
        const AxisLookup ax(grid.axes_mm[a]);
        if (ax.size() == 1) continue;
        if (ax.size() < 4)
          return tl::unexpected(
              fmt::format("bspline: axis {} has {} points, needs 1 or at least 4", "xyz"[a], ax.size()));
        if (!ax.uniform()) return tl::unexpected(fmt::format("bspline: axis {} is not uniformly spaced", "xyz"[a]));
      }
      return std::make_unique<BSpline>(grid, v);
    case Method::LeastSquares: {
      if (spec.least_squares.degree < 1 || spec.least_squares.degree > 2 || spec.least_squares.neighbourhood < 1)
        return tl::unexpected(std::string("least squares: degree 1 or 2 and neighbourhood >= 1"));
      std::string error;
      auto f = std::make_unique<LeastSquares>(grid, v, spec.least_squares, error);
      if (!error.empty()) return tl::unexpected(error);
      return f;
    }
  }
  return tl::unexpected(std::string("unknown interpolation method"));
}

tl::expected<SpaceInterpolator, std::string> SpaceInterpolator::build(const ErrorSpace& space,
                                                                      const InterpolationSpec& spec) {
  SpaceInterpolator out;
  for (int c = 0; c < 3; ++c) {
    if (space.values_mm[c].empty()) continue;
    auto f = make_field(space.grid, space.values_mm[c], spec);
    if (!f) return tl::unexpected(fmt::format("component {}: {}", "xyz"[c], f.error()));
    out.m_fields[c] = std::move(*f);
  }
  return out;
}

std::array<double, 3> SpaceInterpolator::error_at(double x, double y, double z) const {
  std::array<double, 3> e{0, 0, 0};
  for (int c = 0; c < 3; ++c)
    if (m_fields[c]) e[c] = m_fields[c]->value(x, y, z);
  return e;
}

Estimate SpaceInterpolator::estimate(Component c, double x, double y, double z) const {
  const auto& f = m_fields[static_cast<int>(c)];
  return f ? f->estimate(x, y, z) : Estimate{0, nan};
}

tl::expected<Validation, std::string> validate_every_second(const Grid& grid, const std::vector<double>& v,
                                                            const InterpolationSpec& spec) {
  if (v.size() != grid.size()) return tl::unexpected(std::string("values do not match the grid"));
  Grid sub;
  std::array<std::size_t, 3> last{};
  for (int a = 0; a < 3; ++a) {
    const auto& x = grid.axes_mm[a];
    for (std::size_t i = 0; i < x.size(); i += (x.size() > 1 ? 2 : 1)) sub.axes_mm[a].push_back(x[i]), last[a] = i;
  }
  std::vector<double> sv;
  sv.reserve(sub.size());
  for (std::size_t k = 0; k <= last[2]; k += grid.axes_mm[2].size() > 1 ? 2 : 1)
    for (std::size_t j = 0; j <= last[1]; j += grid.axes_mm[1].size() > 1 ? 2 : 1)
      for (std::size_t i = 0; i <= last[0]; i += grid.axes_mm[0].size() > 1 ? 2 : 1)
        sv.push_back(v[grid.index(i, j, k)]);
  auto f = make_field(sub, sv, spec);
  if (!f) return tl::unexpected(f.error());
  Validation out;
  double sum2 = 0;
  for (std::size_t k = 0; k <= last[2]; ++k)
    for (std::size_t j = 0; j <= last[1]; ++j)
      for (std::size_t i = 0; i <= last[0]; ++i) {
        const bool in_sub = (grid.axes_mm[0].size() == 1 || i % 2 == 0) &&
                            (grid.axes_mm[1].size() == 1 || j % 2 == 0) && (grid.axes_mm[2].size() == 1 || k % 2 == 0);
        if (in_sub) continue;
        const double d =
            (*f)->value(grid.axes_mm[0][i], grid.axes_mm[1][j], grid.axes_mm[2][k]) - v[grid.index(i, j, k)];
        sum2 += d * d;
        out.max_abs_mm = std::max(out.max_abs_mm, std::abs(d));
        ++out.points;
      }
  if (out.points == 0) return tl::unexpected(std::string("validation: no grid point left to predict"));
  out.rms_mm = std::sqrt(sum2 / static_cast<double>(out.points));
  return out;
}

}  // namespace metron::error_space
