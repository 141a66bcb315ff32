// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/discrepancy/analysis.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <tuple>

#include <fmt/format.h>
#include <Eigen/Dense>

namespace metron::discrepancy {
namespace {

constexpr double kPi = 3.14159265358979323846;
const char* const kAxis[4] = {"x", "y", "z", "n"};

// Regularised incomplete beta I_x(a, b) by Lentz's continued fraction (Numerical Recipes 3rd ed.,
// 6.4, betacf).
double incomplete_beta(double a, double b, double x) {
  if (x <= 0) return 0;
  if (x >= 1) return 1;
  const double lbeta = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b);
  const double front = std::exp(lbeta + a * std::log(x) + b * std::log1p(-x));
  auto cf = [](double aa, double bb, double xx) {
    const double tiny = 1e-300;
    double c = 1, d = 1 - (aa + bb) * xx / (aa + 1);
    if (std::abs(d) < tiny) d = tiny;
    d = 1 / d;
    double h = d;
    for (int m = 1; m < 300; ++m) {
      const double m2 = 2.0 * m;
      double num = m * (bb - m) * xx / ((aa + m2 - 1) * (aa + m2));
      d = 1 + num * d, c = 1 + num / c;
      d = std::abs(d) < tiny ? 1 / tiny : 1 / d;
      c = std::abs(c) < tiny ? tiny : c;
      h *= d * c;
      num = -(aa + m) * (aa + bb + m) * xx / ((aa + m2) * (aa + m2 + 1));
      d = 1 + num * d, c = 1 + num / c;
      d = std::abs(d) < tiny ? 1 / tiny : 1 / d;
      c = std::abs(c) < tiny ? tiny : c;
      const double del = d * c;
      h *= del;
      if (std::abs(del - 1) < 1e-14) break;
    }
    return h;
  };
  if (x < (a + 1) / (a + b + 2)) return front * cf(a, b, x) / a;
  return 1 - front * cf(b, a, 1 - x) / b;
}

double variance(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  const double m = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double s = 0;
  for (double x : v) s += (x - m) * (x - m);
  return s / static_cast<double>(v.size() - 1);
}

double rms(const Eigen::VectorXd& v) {
  return v.size() ? std::sqrt(v.squaredNorm() / static_cast<double>(v.size())) : 0;
}

// Least squares by normal equations on RMS-normalised columns (the columns mix mm, mm^2, s).
struct Fit {
  Eigen::VectorXd beta, residual;
  Eigen::MatrixXd cov_unscaled;  // (X^T X)^-1
  double rss = 0;
  bool ok = false;
};

Fit least_squares(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, bool want_cov = false) {
  Fit f;
  const Eigen::Index p = X.cols();
  Eigen::VectorXd scale(p);
  for (Eigen::Index j = 0; j < p; ++j) {
    const double n = X.col(j).norm();
    scale[j] = n > 0 ? 1 / n : 0;
  }
  const Eigen::MatrixXd Xs = X * scale.asDiagonal();
  Eigen::MatrixXd A = Xs.transpose() * Xs;
  A.diagonal().array() += 1e-12;
  Eigen::LDLT<Eigen::MatrixXd> ldlt(A);
  if (ldlt.info() != Eigen::Success) return f;
  const Eigen::VectorXd bs = ldlt.solve(Xs.transpose() * y);
  f.beta = scale.asDiagonal() * bs;
  f.residual = y - X * f.beta;
  f.rss = f.residual.squaredNorm();
  if (want_cov) f.cov_unscaled = scale.asDiagonal() * ldlt.solve(Eigen::MatrixXd::Identity(p, p)) * scale.asDiagonal();
  f.ok = f.beta.allFinite();
  return f;
}

// What the catalogue looks at, per observation.
struct Features {
  std::size_t n = 0;
  std::vector<std::array<double, 3>> q;  // nominal position
  std::vector<int> comp;
  std::vector<double> t, dir, acc, theta;  // empty when not recorded
  std::array<bool, 3> q_varies{false, false, false};
  std::vector<const Series*> temperatures;
  std::vector<std::size_t> row;
};

// A candidate effect: its columns given the nonlinear parameter, and how to describe it.
struct Candidate {
  Candidate(std::string k, std::string w, std::string cond, std::string e, int c, int a = -1)
      : kind(std::move(k)),
        what(std::move(w)),
        condition(std::move(cond)),
        explanation(std::move(e)),
        component(c),
        along(a) {}
  std::string kind, what, condition, explanation;
  int component = 0;
  int along = -1, along2 = -1;  // position axes
  const Series* temperature = nullptr;
  std::vector<double> grid;  // nonlinear parameter values to search (empty: linear)
  bool log_refine = false;   // refine the nonlinear parameter (golden section)
  double tests = 1;          // independent search points (Bonferroni)
  std::string nl_name, nl_unit;
  std::function<Eigen::MatrixXd(double)> columns;
};

struct Evaluated {
  double rss = INFINITY, nl = 0;
  Eigen::MatrixXd cols;
};

Evaluated fit_candidate(const Candidate& c, const Eigen::MatrixXd& base, const Eigen::VectorXd& y) {
  auto rss_at = [&](double nl, Eigen::MatrixXd* keep) {
    Eigen::MatrixXd cols = c.columns(nl);
    Eigen::MatrixXd X(base.rows(), base.cols() + cols.cols());
    X << base, cols;
    const Fit f = least_squares(X, y);
    if (keep) *keep = std::move(cols);
    return f.ok ? f.rss : INFINITY;
  };
  Evaluated best;
  if (c.grid.empty()) {
    best.rss = rss_at(0, &best.cols);
    return best;
  }
  std::size_t bi = 0;
  std::vector<double> r(c.grid.size());
  for (std::size_t i = 0; i < c.grid.size(); ++i) {
    r[i] = rss_at(c.grid[i], nullptr);
    if (r[i] < r[bi]) bi = i;
  }
  double nl = c.grid[bi], rss = r[bi];
  if (c.log_refine && c.grid.size() > 2) {
    // Golden-section search between the neighbours of the best grid point (in the grid's own spacing).
    double a = c.grid[bi > 0 ? bi - 1 : bi], b = c.grid[std::min(bi + 1, c.grid.size() - 1)];
    const double g = 0.6180339887498949;
    double x1 = b - g * (b - a), x2 = a + g * (b - a);
    double f1 = rss_at(x1, nullptr), f2 = rss_at(x2, nullptr);
    for (int it = 0; it < 25; ++it) {
      if (f1 < f2)
        b = x2, x2 = x1, f2 = f1, x1 = b - g * (b - a), f1 = rss_at(x1, nullptr);
      else
        a = x1, x1 = x2, f1 = f2, x2 = a + g * (b - a), f2 = rss_at(x2, nullptr);
    }
    const double xm = 0.5 * (a + b), fm = rss_at(xm, nullptr);
    if (fm < rss) nl = xm, rss = fm;
  }
  best.nl = nl;
  best.rss = rss_at(nl, &best.cols);
  return best;
}

std::vector<double> logspace(double lo, double hi, int n) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(lo * std::pow(hi / lo, static_cast<double>(i) / (n - 1)));
  return v;
}

// Observation indices of each fold: whole cycles when cycles are recorded (leave one cycle out, up
// to 10 folds), otherwise contiguous blocks of rows (rows are in time order: a block is a period).
std::vector<int> make_folds(const Problem& p, std::string& how, int& count) {
  const std::size_t n = p.row.size();
  std::vector<int> fold(n, 0);
  const Series* cyc = p.data->find(Role::Cycle);
  if (cyc) {
    std::set<double> cycles(cyc->values.begin(), cyc->values.end());
    if (cycles.size() >= 3) {
      std::vector<double> cv(cycles.begin(), cycles.end());
      count = static_cast<int>(std::min<std::size_t>(cv.size(), 10));
      for (std::size_t o = 0; o < n; ++o) {
        const auto idx =
            static_cast<std::size_t>(std::lower_bound(cv.begin(), cv.end(), cyc->values[p.row[o]]) - cv.begin());
        fold[o] = static_cast<int>(idx * static_cast<std::size_t>(count) / cv.size());
      }
      how = fmt::format("leave cycles out ({} folds of whole cycles)", count);
      return fold;
    }
  }
  count = static_cast<int>(std::min<std::size_t>(10, std::max<std::size_t>(2, p.data->rows / 8)));
  for (std::size_t o = 0; o < n; ++o)
    fold[o] = static_cast<int>(p.row[o] * static_cast<std::size_t>(count) / p.data->rows);
  how = fmt::format("{} contiguous blocks of rows (time order)", count);
  return fold;
}

Eigen::VectorXd cv_residual(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const std::vector<int>& fold,
                            int count) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(y.size());
  for (int k = 0; k < count; ++k) {
    std::vector<Eigen::Index> tr, te;
    for (Eigen::Index i = 0; i < y.size(); ++i) (fold[static_cast<std::size_t>(i)] == k ? te : tr).push_back(i);
    if (te.empty()) continue;
    const Fit f = least_squares(X(tr, Eigen::all), y(tr));
    if (!f.ok) {
      out(te) = y(te);  // no prediction from a failed fit
      continue;
    }
    out(te) = y(te) - X(te, Eigen::all) * f.beta;
  }
  return out;
}

// Binned means along a condition: one-way ANOVA F over B equal-count bins.
Structure binned_means(const std::vector<double>& x, const Eigen::VectorXd& r, const std::vector<Eigen::Index>& idx,
                       int bins) {
  Structure s;
  std::vector<Eigen::Index> order = idx;
  std::sort(order.begin(), order.end(),
            [&](auto a, auto b) { return x[static_cast<std::size_t>(a)] < x[static_cast<std::size_t>(b)]; });
  const auto n = order.size();
  std::set<double> distinct;
  for (auto i : order) distinct.insert(x[static_cast<std::size_t>(i)]);
  if (distinct.size() < 2 || n < 8) return s;
  const int B = static_cast<int>(std::min<std::size_t>({static_cast<std::size_t>(bins), distinct.size(), n / 4}));
  if (B < 2) return s;
  std::vector<double> sum(static_cast<std::size_t>(B), 0), cnt(static_cast<std::size_t>(B), 0);
  std::vector<int> bin(n);
  // Equal-count bins that never split equal condition values.
  std::size_t k = 0;
  for (int b = 0; b < B; ++b) {
    const std::size_t end = (b + 1 == B) ? n : (n * static_cast<std::size_t>(b + 1)) / static_cast<std::size_t>(B);
    while (k < n &&
           (k < end || (k > 0 && x[static_cast<std::size_t>(order[k])] == x[static_cast<std::size_t>(order[k - 1])]))) {
      bin[k] = b;
      sum[static_cast<std::size_t>(b)] += r[order[k]];
      cnt[static_cast<std::size_t>(b)] += 1;
      ++k;
    }
  }
  double mean = 0;
  for (auto i : order) mean += r[i];
  mean /= static_cast<double>(n);
  double between = 0, within = 0, lo = INFINITY, hi = -INFINITY;
  int used = 0;
  for (int b = 0; b < B; ++b)
    if (cnt[static_cast<std::size_t>(b)] > 0) {
      const double m = sum[static_cast<std::size_t>(b)] / cnt[static_cast<std::size_t>(b)];
      between += cnt[static_cast<std::size_t>(b)] * (m - mean) * (m - mean);
      lo = std::min(lo, m), hi = std::max(hi, m);
      ++used;
    }
  for (std::size_t j = 0; j < n; ++j) {
    const double m = sum[static_cast<std::size_t>(bin[j])] / cnt[static_cast<std::size_t>(bin[j])];
    within += (r[order[j]] - m) * (r[order[j]] - m);
  }
  if (used < 2 || within <= 0) return s;
  const double d1 = used - 1, d2 = static_cast<double>(n) - used;
  s.statistic = (between / d1) / (within / d2);
  s.p_value = f_upper_tail(s.statistic, d1, d2);
  s.size_mm = hi - lo;
  s.test = "binned means";
  return s;
}

}  // namespace

double f_upper_tail(double f, double d1, double d2) {
  if (!(f > 0)) return 1;
  return incomplete_beta(d2 / 2, d1 / 2, d2 / (d2 + d1 * f));
}

std::vector<double> first_order_lag(const std::vector<double>& t, const std::vector<double>& T, double tau) {
  std::vector<double> y(T.size());
  if (T.empty()) return y;
  y[0] = T[0];
  for (std::size_t i = 1; i < T.size(); ++i) {
    const double h = t[i] - t[i - 1];
    if (tau <= 0) {
      y[i] = T[i];
    } else if (h <= 0) {
      y[i] = y[i - 1];
    } else {
      // docs/error-space.md (thermal): T(s) = A + B (s - tau) + (T(0) - A + B tau) exp(-s / tau).
      const double A = T[i - 1], B = (T[i] - T[i - 1]) / h;
      y[i] = A + B * (h - tau) + (y[i - 1] - A + B * tau) * std::exp(-h / tau);
    }
  }
  return y;
}

const std::vector<CatalogueEntry>& catalogue() {
  static const std::vector<CatalogueEntry> c{
      {"scale", "e_c = s q_c",
       "scale (positioning) error of axis c: scale pitch, uncompensated uniform expansion (ISO 230-2 linear trend)"},
      {"squareness", "e_c = k q_j",
       "out-of-squareness of axes c and j, or a constant angular error with an Abbe lever (ISO 230-1)"},
      {"cross-axis", "e_c = k q_i q_j",
       "non-rigid term: the error along c grows with two axes together, e.g. a bridge or beam bending under the "
       "carriage (twist)"},
      {"reversal", "e_c = B/2 d_c",
       "reversal (backlash, friction, servo lag at the stop): half the reversal value with the sign of the approach "
       "(ISO 230-2 B)"},
      {"cyclic", "e_c = a sin(2 pi q_j / P) + b cos(2 pi q_j / P)",
       "cyclic error of a lead screw, rack or scale graduation with period P (ISO 230-2 periodic error)"},
      {"drift", "e_c = r (t - t0)", "linear drift over time: warm-up, creep, sensor drift"},
      {"transient", "e_c = A exp(-(t - t0) / tau)",
       "start-up transient: the first readings after a start or a pause settle with time constant tau (warm-up of "
       "drives, settling of a stepper)"},
      {"thermal", "e_c = (k0 + k1 q_c)(T_lag(t; tau) - T_ref)",
       "thermal expansion of part, scale or structure following a recorded temperature through a first-order lag tau "
       "(ISO 230-3)"},
      {"acceleration", "e_c = k a",
       "deflection under acceleration: inertial bending of the structure or the stylus (dynamic error)"},
      {"lobing", "e_n = a cos(m theta) + b sin(m theta)",
       "probe pre-travel lobing: a kinematic touch-trigger probe triggers later in some directions (m = 3 for a "
       "three-point seat)"},
  };
  return c;
}

Problem make_problem(const MeasuredData& data, const std::function<double(std::size_t, int)>& predicted) {
  Problem p;
  p.data = &data;
  for (std::size_t r = 0; r < data.rows; ++r)
    for (int a : data.measured_axes()) {
      p.row.push_back(r);
      p.axis.push_back(a);
      p.measured_mm.push_back(data.deviation_mm(r, a));
      p.predicted_mm.push_back(predicted(r, a));
      p.residual_mm.push_back(p.measured_mm.back() - p.predicted_mm.back());
    }
  return p;
}

Analysis analyse(const Problem& p, const Options& opt) {
  Analysis out;
  const MeasuredData& data = *p.data;
  const auto n = static_cast<Eigen::Index>(p.row.size());
  const std::size_t nu = p.row.size();
  out.observations = nu;
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(p.residual_mm.data(), n);
  out.rms_base_mm = rms(y);
  auto say = [&](const std::string& s) {
    if (opt.progress) opt.progress(s);
  };
  const double sign = data.description.kind == DataKind::Artefact ? -1.0 : 1.0;  // data deviation = sign * e

  // Features.
  Features F;
  F.n = nu;
  F.comp = p.axis;
  F.row = p.row;
  std::set<int> comps(p.axis.begin(), p.axis.end());
  for (std::size_t o = 0; o < nu; ++o) F.q.push_back(data.position_mm(p.row[o]));
  for (int a = 0; a < 3; ++a) {
    std::set<double> v;
    for (auto& q : F.q) v.insert(q[static_cast<std::size_t>(a)]);
    F.q_varies[static_cast<std::size_t>(a)] = v.size() >= 3;
  }
  const Series* time = data.find(Role::Time);
  const Series* dir_any = nullptr;
  for (const auto& s : data.series)
    if (s.role == Role::Direction) dir_any = &s;
  const Series* acc_any = data.find(Role::Acceleration);
  const Series* ax = data.find(Role::Approach, 0);
  const Series* ay = data.find(Role::Approach, 1);
  for (const auto& s : data.series)
    if (s.role == Role::Temperature && variance(s.values) > 1e-4) F.temperatures.push_back(&s);

  // Nuisance: a zero offset per component; for artefacts with x and y, the placement (rotation about z).
  std::vector<Eigen::VectorXd> nuis;
  for (int c : comps) {
    Eigen::VectorXd v(n);
    for (Eigen::Index o = 0; o < n; ++o) v[o] = F.comp[static_cast<std::size_t>(o)] == c ? 1 : 0;
    nuis.push_back(v);
    out.nuisance.push_back(fmt::format("zero offset of {}", kAxis[c]));
  }
  if (data.description.kind == DataKind::Artefact && comps.count(0) && comps.count(1) && F.q_varies[0] &&
      F.q_varies[1]) {
    Eigen::VectorXd v(n);
    for (Eigen::Index o = 0; o < n; ++o) {
      const auto& q = F.q[static_cast<std::size_t>(o)];
      const int c = F.comp[static_cast<std::size_t>(o)];
      v[o] = c == 0 ? -q[1] : c == 1 ? q[0] : 0;
    }
    nuis.push_back(v);
    out.nuisance.push_back("rotation of the artefact about z (its placement)");
  }
  if (data.description.per_position_table) {
    // One systematic deviation per (component, nominal position): the zero offsets are in it.
    std::map<std::pair<int, std::array<double, 3>>, std::size_t> group;
    for (std::size_t o = 0; o < nu; ++o) group.emplace(std::make_pair(F.comp[o], F.q[o]), group.size());
    nuis.clear();
    for (const auto& [key, g] : group) {
      Eigen::VectorXd v(n);
      for (Eigen::Index o = 0; o < n; ++o)
        v[o] = std::make_pair(F.comp[static_cast<std::size_t>(o)], F.q[static_cast<std::size_t>(o)]) == key ? 1 : 0;
      nuis.push_back(v);
    }
    out.nuisance = {
        fmt::format("a table of {} systematic deviations per nominal position (ISO 230-2 mean bidirectional deviation)",
                    group.size())};
  }
  Eigen::MatrixXd base(n, static_cast<Eigen::Index>(nuis.size()));
  for (std::size_t k = 0; k < nuis.size(); ++k) base.col(static_cast<Eigen::Index>(k)) = nuis[k];

  auto on = [&](int c, auto f) {  // a column acting on component c
    Eigen::VectorXd v(n);
    for (Eigen::Index o = 0; o < n; ++o)
      v[o] = F.comp[static_cast<std::size_t>(o)] == c ? f(static_cast<std::size_t>(o)) : 0.0;
    return v;
  };
  auto enabled = [&](const std::string& k) {
    return std::find(opt.disabled.begin(), opt.disabled.end(), k) == opt.disabled.end();
  };

  // Catalogue candidates.
  std::vector<Candidate> cands;
  const auto& cat = catalogue();
  auto expl = [&](const std::string& k) {
    for (const auto& e : cat)
      if (e.kind == k) return e.explanation;
    return std::string{};
  };
  for (int c : comps) {
    const std::size_t cu = static_cast<std::size_t>(c);
    if (c < 3 && F.q_varies[cu] && enabled("scale")) {
      Candidate k{
          "scale", fmt::format("scale error of {}", kAxis[c]), fmt::format("{} position", kAxis[c]), expl("scale"), c,
          c};
      k.columns = [&, c, cu](double) {
        Eigen::MatrixXd m(n, 1);
        m.col(0) = on(c, [&](std::size_t o) { return F.q[o][cu]; });
        return m;
      };
      cands.push_back(k);
    }
    for (int j = 0; j < 3; ++j) {
      const std::size_t ju = static_cast<std::size_t>(j);
      if (!F.q_varies[ju]) continue;
      // With the artefact's rotation free, "y along x" equals "x along y" (one squareness xy): keep one.
      const bool rotation_free = out.nuisance.size() > comps.size();
      if (j != c && c < 3 && enabled("squareness") && !(rotation_free && c == 1 && j == 0)) {
        Candidate k{"squareness",
                    fmt::format("{} error growing with {} (squareness {}{})", kAxis[c], kAxis[j], kAxis[std::min(c, j)],
                                kAxis[std::max(c, j)]),
                    fmt::format("{} position", kAxis[j]),
                    expl("squareness"),
                    c,
                    j};
        k.columns = [&, c, ju](double) {
          Eigen::MatrixXd m(n, 1);
          m.col(0) = on(c, [&](std::size_t o) { return F.q[o][ju]; });
          return m;
        };
        cands.push_back(k);
      }
      for (int i = 0; i < j; ++i) {
        const std::size_t iu = static_cast<std::size_t>(i);
        if (!F.q_varies[iu] || c == 3 || !enabled("cross-axis")) continue;
        Candidate k{"cross-axis",
                    fmt::format("{} error growing with {}*{}", kAxis[c], kAxis[i], kAxis[j]),
                    fmt::format("{}*{} position", kAxis[i], kAxis[j]),
                    expl("cross-axis"),
                    c,
                    i};
        k.along2 = j;
        k.columns = [&, c, iu, ju](double) {
          Eigen::MatrixXd m(n, 1);
          m.col(0) = on(c, [&](std::size_t o) { return F.q[o][iu] * F.q[o][ju]; });
          return m;
        };
        cands.push_back(k);
      }
      if (enabled("cyclic")) {
        std::vector<double> v;
        for (std::size_t o = 0; o < nu; ++o)
          if (F.comp[o] == c) v.push_back(F.q[o][ju]);
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end()), v.end());
        if (v.size() >= 8) {
          std::vector<double> gaps;
          for (std::size_t i = 1; i < v.size(); ++i) gaps.push_back(v[i] - v[i - 1]);
          std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
          const double span = v.back() - v.front();
          // At least two whole periods in the span: a longer wave is a form (bow) error, not a
          // screw's or scale's cycle, and stays unexplained rather than forced into this entry.
          const double pmin = std::max(2 * gaps[gaps.size() / 2], span / 200), pmax = span / 2;
          Candidate k{"cyclic",
                      fmt::format("cyclic error of {} along {}", kAxis[c], kAxis[j]),
                      fmt::format("{} position", kAxis[j]),
                      expl("cyclic"),
                      c,
                      j};
          // Frequencies 1/pmax .. 1/pmin, four times oversampled (Lomb-Scargle practice).
          const double df = 1 / (4 * span);
          for (double f = 1 / pmax; f <= 1 / pmin; f += df) k.grid.push_back(1 / f);
          k.log_refine = true;
          k.tests = std::max(1.0, span / pmin);
          k.nl_name = "period", k.nl_unit = "mm";
          k.columns = [&, c, ju](double P) {
            Eigen::MatrixXd m(n, 2);
            m.col(0) = on(c, [&](std::size_t o) { return std::sin(2 * kPi * F.q[o][ju] / P); });
            m.col(1) = on(c, [&](std::size_t o) { return std::cos(2 * kPi * F.q[o][ju] / P); });
            return m;
          };
          cands.push_back(k);
        }
      }
    }
    const Series* dir = data.find(Role::Direction, c);
    if (!dir) dir = dir_any;
    if (dir && variance(dir->values) > 0 && enabled("reversal")) {
      Candidate k{"reversal", fmt::format("reversal of {}", kAxis[c]), dir->name, expl("reversal"), c};
      k.columns = [&, c, dir](double) {
        Eigen::MatrixXd m(n, 1);
        m.col(0) = on(c, [&](std::size_t o) { return 0.5 * dir->values[F.row[o]]; });
        return m;
      };
      cands.push_back(k);
    }
    if (time && variance(time->values) > 0 && enabled("drift")) {
      const double t0 = *std::min_element(time->values.begin(), time->values.end());
      Candidate k{"drift", fmt::format("drift of {}", kAxis[c]), time->name, expl("drift"), c};
      k.columns = [&, c, t0](double) {
        Eigen::MatrixXd m(n, 1);
        m.col(0) = on(c, [&](std::size_t o) { return time->values[F.row[o]] - t0; });
        return m;
      };
      cands.push_back(k);
    }
    if (time && variance(time->values) > 0 && enabled("transient")) {
      // A start-up transient decaying from the first reading: e = A exp(-(t - t0) / tau).
      const double t0 = *std::min_element(time->values.begin(), time->values.end());
      const double t1 = *std::max_element(time->values.begin(), time->values.end());
      Candidate k{"transient", fmt::format("start-up transient of {}", kAxis[c]), time->name, expl("transient"), c};
      const double dtmin = std::max((t1 - t0) / static_cast<double>(data.rows), 1e-6);
      k.grid = logspace(dtmin, (t1 - t0) / 2, 30);
      k.log_refine = true;
      k.tests = 10;
      k.nl_name = "time constant", k.nl_unit = "s";
      k.columns = [&, c, t0](double tau) {
        Eigen::MatrixXd m(n, 1);
        m.col(0) = on(c, [&](std::size_t o) { return std::exp(-(time->values[F.row[o]] - t0) / std::max(tau, 1e-9)); });
        return m;
      };
      cands.push_back(k);
    }
    const Series* acc = data.find(Role::Acceleration, c);
    if (!acc) acc = acc_any;
    if (acc && variance(acc->values) > 0 && enabled("acceleration")) {
      Candidate k{"acceleration", fmt::format("deflection of {} under acceleration", kAxis[c]), acc->name,
                  expl("acceleration"), c};
      k.columns = [&, c, acc](double) {
        Eigen::MatrixXd m(n, 1);
        m.col(0) = on(c, [&](std::size_t o) { return acc->values[F.row[o]]; });
        return m;
      };
      cands.push_back(k);
    }
    if (time && enabled("thermal")) {
      for (const Series* T : F.temperatures) {
        // The temperature table in time order (first value of repeated times), the lag on it.
        std::vector<std::size_t> order(data.rows);
        std::iota(order.begin(), order.end(), 0);
        std::stable_sort(order.begin(), order.end(), [&](auto a, auto b) { return time->values[a] < time->values[b]; });
        auto tt = std::make_shared<std::vector<double>>(), TT = std::make_shared<std::vector<double>>();
        auto node = std::make_shared<std::vector<std::size_t>>(data.rows);
        for (auto r : order) {
          if (tt->empty() || time->values[r] > tt->back()) tt->push_back(time->values[r]), TT->push_back(T->values[r]);
          (*node)[r] = tt->size() - 1;
        }
        const double dur = tt->back() - tt->front();
        if (tt->size() < 8 || dur <= 0) continue;
        const double tref = data.description.reference_temperature_c;
        const bool along = c < 3 && F.q_varies[static_cast<std::size_t>(c)];
        Candidate k{"thermal", fmt::format("thermal expansion of {} following {}", kAxis[c], T->name),
                    T->name + " (lagged)", expl("thermal"), c};
        k.temperature = T;
        k.grid = {0.0};
        const double dtmin = std::max(dur / static_cast<double>(tt->size()), 1e-3);
        for (double v : logspace(dtmin, dur, 40)) k.grid.push_back(v);
        k.log_refine = true;
        k.tests = 10;
        k.nl_name = "lag", k.nl_unit = "s";
        k.columns = [&, c, tt, TT, node, tref, along](double tau) {
          const auto lag = first_order_lag(*tt, *TT, std::max(0.0, tau));
          Eigen::MatrixXd m(n, along ? 2 : 1);
          m.col(0) = on(c, [&](std::size_t o) { return lag[(*node)[F.row[o]]] - tref; });
          if (along)
            m.col(1) = on(c, [&](std::size_t o) {
              return (lag[(*node)[F.row[o]]] - tref) * F.q[o][static_cast<std::size_t>(c)];
            });
          return m;
        };
        cands.push_back(k);
      }
    }
    if (c == 3 && ax && ay && enabled("lobing")) {
      Candidate k{"lobing", "probe pre-travel lobing", "approach angle", expl("lobing"), c};
      for (int m = 2; m <= 8; ++m) k.grid.push_back(m);
      k.tests = 7;
      k.nl_name = "lobes", k.nl_unit = "";
      k.columns = [&, c](double m) {
        Eigen::MatrixXd M(n, 2);
        M.col(0) =
            on(c, [&](std::size_t o) { return std::cos(m * std::atan2(ay->values[F.row[o]], ax->values[F.row[o]])); });
        M.col(1) =
            on(c, [&](std::size_t o) { return std::sin(m * std::atan2(ay->values[F.row[o]], ax->values[F.row[o]])); });
        return M;
      };
      cands.push_back(k);
    }
  }
  double total_tests = 0;
  for (const auto& c : cands) total_tests += c.tests;
  total_tests = std::max(1.0, total_tests);

  std::string how;
  int count = 0;
  const auto fold = make_folds(p, how, count);
  out.folds = how;
  out.fold_count = count;
  Eigen::VectorXd cv0 = cv_residual(base, y, fold, count);
  out.cv_rms_before_mm = rms(cv0);
  Fit f0 = least_squares(base, y);
  out.residual_before_mm.assign(f0.residual.data(), f0.residual.data() + n);

  // Forward selection (a stepwise form of sparse identification: SINDy's sparsity, with an F test
  // in place of a threshold).
  Eigen::MatrixXd current = base;
  double rss_cur = f0.rss, cv_cur = out.cv_rms_before_mm;
  std::vector<std::pair<std::size_t, Evaluated>> chosen;
  std::set<std::size_t> used;
  const double dn = static_cast<double>(n);
  for (int step = 0; step < opt.max_effects; ++step) {
    std::size_t best = cands.size();
    Evaluated be;
    for (std::size_t i = 0; i < cands.size(); ++i) {
      if (used.count(i)) continue;
      say(fmt::format("step {}: candidate {}/{}: {}", step + 1, i + 1, cands.size(), cands[i].what));
      Evaluated e = fit_candidate(cands[i], current, y);
      if (e.rss < be.rss) be = std::move(e), best = i;
    }
    if (best == cands.size()) break;
    const Candidate& c = cands[best];
    const double k = static_cast<double>(be.cols.cols()) + (c.grid.empty() ? 0 : 1);
    const double p1 = static_cast<double>(current.cols()) + k;
    if (dn - p1 < 1) break;
    const double Fst = ((rss_cur - be.rss) / k) / (be.rss / (dn - p1));
    const double pv = f_upper_tail(Fst, k, dn - p1);
    const double bic = dn * std::log(be.rss / rss_cur) + k * std::log(dn);
    Eigen::MatrixXd next(n, current.cols() + be.cols.cols());
    next << current, be.cols;
    const double cv1 = rms(cv_residual(next, y, fold, count));
    const bool significant = opt.significance ? (pv * total_tests < opt.alpha && bic < 0) : true;
    say(fmt::format("best: {} F={:.3g} p={:.3g} x{:.0f} tests, dBIC={:.1f}, CV {:.4g} -> {:.4g} mm{}", c.what, Fst, pv,
                    total_tests, bic, cv_cur, cv1, significant ? "" : " (not significant)"));
    if (!significant || (opt.significance && cv1 >= cv_cur)) {
      out.stopped_at = fmt::format(
          "best remaining candidate {}: F={:.3g}, p={:.2g} x {:.0f} tests, dBIC={:.1f}, CV RMS {:.4g} -> {:.4g} um: {}",
          c.what, Fst, pv, total_tests, bic, cv_cur * 1e3, cv1 * 1e3,
          !significant ? "not significant" : "significant in the fit but not confirmed by cross-validation");
      break;
    }
    Effect eff;
    eff.kind = c.kind, eff.what = c.what, eff.explanation = c.explanation, eff.condition = c.condition,
    eff.component = c.component;
    eff.f_statistic = Fst, eff.p_value = pv, eff.tests = total_tests, eff.delta_bic = bic, eff.cv_rms_mm = cv1;
    out.effects.push_back(eff);
    chosen.emplace_back(best, be);
    used.insert(best);
    current = std::move(next);
    rss_cur = be.rss, cv_cur = cv1;
  }

  // Final fit: parameters, uncertainties, contributions.
  const Fit ff = least_squares(current, y, true);
  const double dof = std::max(1.0, dn - static_cast<double>(current.cols()) - static_cast<double>(chosen.size()));
  const double s2 = ff.rss / dof;
  out.fit_rms_after_mm = rms(ff.residual);
  out.residual_after_mm.assign(ff.residual.data(), ff.residual.data() + n);
  out.cv_rms_after_mm = cv_cur;
  Eigen::Index col = base.cols();
  for (std::size_t e = 0; e < chosen.size(); ++e) {
    const Candidate& c = cands[chosen[e].first];
    const Evaluated& ev = chosen[e].second;
    Effect& eff = out.effects[e];
    const Eigen::Index k = ev.cols.cols();
    const Eigen::VectorXd bd = ff.beta.segment(col, k);
    const Eigen::MatrixXd C = s2 * ff.cov_unscaled.block(col, col, k, k);
    const Eigen::VectorXd contrib = ev.cols * bd;
    eff.contribution_mm.assign(contrib.data(), contrib.data() + n);
    const Eigen::VectorXd b = sign * bd;  // parameters of the machine error e (data deviation = sign * e)
    // Nonlinear parameter: sd from the curvature of the profile RSS, var = 2 s^2 / RSS''.
    double nl_sd = 0;
    if (!c.grid.empty() && c.log_refine) {
      Eigen::MatrixXd others(n, current.cols() - k);
      others << current.leftCols(col), current.rightCols(current.cols() - col - k);
      auto prof = [&](double v) {
        Eigen::MatrixXd X(n, others.cols() + k);
        X << others, c.columns(v);
        return least_squares(X, y).rss;
      };
      const double h = std::max(1e-6, std::abs(ev.nl) * 1e-3);
      const double d2 = (prof(ev.nl + h) - 2 * ff.rss + prof(ev.nl - h)) / (h * h);
      nl_sd = d2 > 0 ? std::sqrt(2 * s2 / d2) : INFINITY;
    }
    const std::string cx = kAxis[c.component];
    const double um = 1e3;
    if (c.kind == "scale" || c.kind == "squareness") {
      eff.parameters.push_back({c.kind == "scale" ? "scale" : "slope", b[0] * 1e6, std::sqrt(C(0, 0)) * 1e6,
                                c.kind == "scale" ? "ppm" : "urad"});
      eff.world_term = {{"kind", "linear"}, {"component", cx}, {"along", kAxis[c.along]}, {"coefficient", b[0]}};
    } else if (c.kind == "cross-axis") {
      eff.parameters.push_back({"coefficient", b[0] * 1e6, std::sqrt(C(0, 0)) * 1e6,
                                "um/m^2"});  // mm/mm^2 * 1e6 = um/m^2 * ... (1 mm/mm^2 = 1e9 um/m^2)
      eff.parameters.back().value = b[0] * 1e9, eff.parameters.back().sd = std::sqrt(C(0, 0)) * 1e9;
      eff.world_term = {{"kind", "cross_axis"},
                        {"component", cx},
                        {"along", {kAxis[c.along], kAxis[c.along2]}},
                        {"coefficient", b[0]}};
    } else if (c.kind == "reversal") {
      eff.parameters.push_back({"reversal B", b[0] * um, std::sqrt(C(0, 0)) * um, "um"});
      eff.world_term = {{"kind", "reversal"}, {"component", cx}, {"reversal_mm", b[0]}};
    } else if (c.kind == "drift") {
      eff.parameters.push_back({"rate", b[0] * um * 3600, std::sqrt(C(0, 0)) * um * 3600, "um/h"});
      const double t0 = *std::min_element(time->values.begin(), time->values.end());
      eff.world_term = {{"kind", "drift"}, {"component", cx}, {"rate_mm_per_s", b[0]}, {"t0_s", t0}};
    } else if (c.kind == "transient") {
      eff.parameters.push_back({"amplitude", b[0] * um, std::sqrt(C(0, 0)) * um, "um"});
      eff.parameters.push_back({"time constant", ev.nl, nl_sd, "s"});
      const double t0 = *std::min_element(time->values.begin(), time->values.end());
      eff.world_term = {
          {"kind", "transient"}, {"component", cx}, {"amplitude_mm", b[0]}, {"tau_s", ev.nl}, {"t0_s", t0}};
    } else if (c.kind == "acceleration") {
      eff.parameters.push_back({"compliance", b[0] * um, std::sqrt(C(0, 0)) * um, "um per mm/s^2"});
    } else if (c.kind == "cyclic" || c.kind == "lobing") {
      const double a = b[0], bb = b[1], A = std::hypot(a, bb);
      const double sdA = A > 0 ? std::sqrt((a * a * C(0, 0) + 2 * a * bb * C(0, 1) + bb * bb * C(1, 1))) / A : 0;
      eff.parameters.push_back({"amplitude", A * um, sdA * um, "um"});
      if (c.kind == "cyclic") {
        eff.parameters.push_back({"period", ev.nl, nl_sd, "mm"});
        const double phase = std::atan2(bb, a);  // a sin + b cos = A sin(w q + phase)
        eff.parameters.push_back({"phase", phase, A > 0 ? sdA / A : 0, "rad"});
        eff.world_term = {{"kind", "cyclic"},  {"component", cx},    {"along", kAxis[c.along]},
                          {"amplitude_mm", A}, {"period_mm", ev.nl}, {"phase_rad", phase}};
      } else {
        eff.parameters.push_back({"lobes", ev.nl, 0, ""});
        eff.parameters.push_back({"phase", std::atan2(bb, a), A > 0 ? sdA / A : 0, "rad"});
      }
    } else if (c.kind == "thermal") {
      eff.parameters.push_back({"offset coefficient", b[0] * um, std::sqrt(C(0, 0)) * um, "um/K"});
      if (k > 1) eff.parameters.push_back({"expansion coefficient", b[1] * 1e6, std::sqrt(C(1, 1)) * 1e6, "ppm/K"});
      eff.parameters.push_back({"lag", ev.nl, nl_sd, "s"});
      std::vector<double> tt, TT;
      std::vector<std::size_t> order(data.rows);
      std::iota(order.begin(), order.end(), 0);
      std::stable_sort(order.begin(), order.end(),
                       [&](auto a2, auto b2) { return time->values[a2] < time->values[b2]; });
      for (auto r : order)
        if (tt.empty() || time->values[r] > tt.back())
          tt.push_back(time->values[r]), TT.push_back(c.temperature->values[r]);
      eff.world_term = {{"kind", "thermal"},
                        {"component", cx},
                        {"mm_per_k", b[0]},
                        {"per_k", k > 1 ? b[1] : 0.0},
                        {"reference_c", data.description.reference_temperature_c},
                        {"temperature", {{"t_s", tt}, {"temperature_c", TT}, {"lag_s", std::max(0.0, ev.nl)}}}};
    }
    col += k;
  }

  // Noise: stated, or the pooled repeatability of repeated conditions (same row position, direction
  // and component over cycles), or the final residual.
  if (std::isfinite(data.description.noise_mm)) {
    out.noise_mm = data.description.noise_mm, out.noise_stated = true, out.noise_source = "stated in the description";
  } else {
    // Pooled repeatability: readings repeated at the same component, position and direction
    // (ISO 230-2's unidirectional s_i), after the effects; else the residual's sd.
    std::map<std::tuple<int, std::array<double, 3>, double>, std::vector<double>> groups;
    const Series* dir = dir_any;
    for (std::size_t o = 0; o < nu; ++o)
      groups[{F.comp[o], F.q[o], dir ? dir->values[F.row[o]] : 0.0}].push_back(
          ff.residual[static_cast<Eigen::Index>(o)]);
    double ss = 0, df = 0;
    for (const auto& [k, v] : groups) {
      if (v.size() < 2) continue;
      ss += variance(v) * static_cast<double>(v.size() - 1);
      df += static_cast<double>(v.size() - 1);
    }
    if (data.find(Role::Cycle) && df >= 5 && df >= 0.3 * dn) {
      out.noise_mm = std::sqrt(ss / df);
      out.noise_source = fmt::format("repeatability of repeated readings ({} degrees of freedom)", df);
    } else {
      out.noise_mm = std::sqrt(s2);
      out.noise_source = "estimated from the residual after the effects";
    }
  }

  // Structure searches: every recorded condition and position, binned means; periodograms.
  auto search = [&](const Eigen::VectorXd& r, std::vector<Structure>& found, std::vector<Spectrum>& spectra) {
    std::vector<std::pair<std::string, std::vector<double>>> conds;
    for (int a = 0; a < 3; ++a)
      if (F.q_varies[static_cast<std::size_t>(a)]) {
        std::vector<double> v(nu);
        for (std::size_t o = 0; o < nu; ++o) v[o] = F.q[o][static_cast<std::size_t>(a)];
        conds.emplace_back(fmt::format("{} position", kAxis[a]), v);
      }
    for (const auto& s : data.series) {
      if (s.role == Role::Nominal || s.role == Role::Measured || s.role == Role::Deviation) continue;
      if (variance(s.values) <= 0) continue;
      std::vector<double> v(nu);
      for (std::size_t o = 0; o < nu; ++o) v[o] = s.values[F.row[o]];
      conds.emplace_back(s.name, v);
    }
    const double tests = static_cast<double>(conds.size() * comps.size()) * 2;
    for (int c : comps) {
      std::vector<Eigen::Index> idx;
      for (std::size_t o = 0; o < nu; ++o)
        if (F.comp[o] == c) idx.push_back(static_cast<Eigen::Index>(o));
      for (const auto& [name, v] : conds) {
        Structure s = binned_means(v, r, idx, 20);
        s.p_value = std::min(1.0, s.p_value * tests);
        s.condition = name, s.component = c;
        if (!s.test.empty() && s.p_value < opt.alpha) found.push_back(s);
      }
      // Periodograms against positions and time (the cyclic candidate's F at each period).
      for (const auto& [name, v] : conds) {
        if (name.find("position") == std::string::npos && !(time && name == time->name)) continue;
        std::vector<double> xs;
        for (auto i : idx) xs.push_back(v[static_cast<std::size_t>(i)]);
        std::sort(xs.begin(), xs.end());
        xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
        if (xs.size() < 8) continue;
        const double span = xs.back() - xs.front();
        std::vector<double> gaps;
        for (std::size_t i = 1; i < xs.size(); ++i) gaps.push_back(xs[i] - xs[i - 1]);
        std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
        const double pmin = std::max(2 * gaps[gaps.size() / 2], span / 200);
        Eigen::VectorXd rr(static_cast<Eigen::Index>(idx.size()));
        std::vector<double> xv(idx.size());
        for (std::size_t i = 0; i < idx.size(); ++i)
          rr[static_cast<Eigen::Index>(i)] = r[idx[i]], xv[i] = v[static_cast<std::size_t>(idx[i])];
        const double r0 = (rr.array() - rr.mean()).matrix().squaredNorm();
        Spectrum sp;
        sp.against = name, sp.component = c;
        double best_p = 0, best_P = 0;
        const auto m = static_cast<Eigen::Index>(idx.size());
        for (double f = 1 / span; f <= 1 / pmin; f += 1 / (4 * span)) {
          Eigen::MatrixXd X(m, 3);
          for (Eigen::Index i = 0; i < m; ++i)
            X(i, 0) = 1, X(i, 1) = std::sin(2 * kPi * f * xv[static_cast<std::size_t>(i)]),
                 X(i, 2) = std::cos(2 * kPi * f * xv[static_cast<std::size_t>(i)]);
          const double pw = r0 > 0 ? 1 - least_squares(X, rr).rss / r0 : 0;
          sp.period.push_back(1 / f), sp.power.push_back(pw);
          if (pw > best_p) best_p = pw, best_P = 1 / f;
        }
        spectra.push_back(sp);
        const double dm = static_cast<double>(m);
        if (best_p > 0 && best_p < 1 && dm > 5) {
          const double Fst = (best_p / 2) / ((1 - best_p) / (dm - 3));
          Structure s;
          s.test = "periodogram", s.condition = name, s.component = c, s.statistic = Fst, s.period = best_P;
          s.p_value = std::min(1.0, f_upper_tail(Fst, 2, dm - 3) * tests * span / pmin);
          s.size_mm = 2 * std::sqrt(2 * best_p * r0 / dm);
          if (s.p_value < opt.alpha) found.push_back(s);
        }
      }
    }
    std::sort(found.begin(), found.end(), [](const Structure& a, const Structure& b) { return a.p_value < b.p_value; });
  };
  say("structure searches");
  search(f0.residual, out.structure_before, out.spectra_before);
  search(ff.residual, out.unexplained, out.spectra_after);
  return out;
}

nlohmann::json to_json(const Analysis& a) {
  using nlohmann::json;
  json j;
  j["observations"] = a.observations;
  j["rms_base_mm"] = a.rms_base_mm;
  j["cv_rms_before_mm"] = a.cv_rms_before_mm;
  j["cv_rms_after_mm"] = a.cv_rms_after_mm;
  j["fit_rms_after_mm"] = a.fit_rms_after_mm;
  j["noise_mm"] = a.noise_mm;
  j["noise_source"] = a.noise_source;
  j["folds"] = a.folds;
  j["nuisance"] = a.nuisance;
  j["stopped_at"] = a.stopped_at;
  j["effects"] = json::array();
  for (const auto& e : a.effects) {
    json je{{"kind", e.kind},
            {"what", e.what},
            {"explanation", e.explanation},
            {"condition", e.condition},
            {"component", kAxis[e.component]},
            {"f", e.f_statistic},
            {"p_value", e.p_value},
            {"tests", e.tests},
            {"delta_bic", e.delta_bic},
            {"cv_rms_mm", e.cv_rms_mm}};
    je["parameters"] = json::array();
    for (const auto& p : e.parameters)
      je["parameters"].push_back({{"name", p.name}, {"value", p.value}, {"sd", p.sd}, {"unit", p.unit}});
    je["world_term"] =
        e.world_term.is_null() ? json("not expressible as a machine error term") : json(e.world_term.value("kind", ""));
    j["effects"].push_back(je);
  }
  auto structs = [](const std::vector<Structure>& v) {
    json arr = json::array();
    for (const auto& s : v)
      arr.push_back({{"condition", s.condition},
                     {"component", kAxis[s.component]},
                     {"test", s.test},
                     {"f", s.statistic},
                     {"p_value", s.p_value},
                     {"size_mm", s.size_mm},
                     {"period", s.period}});
    return arr;
  };
  j["structure_before"] = structs(a.structure_before);
  j["unexplained"] = structs(a.unexplained);
  return j;
}

std::string summary(const Analysis& a, const MeasuredData& data) {
  std::string s;
  s += fmt::format("{}: {} rows, {} observations ({})\n", data.file, data.rows, a.observations, data.description.name);
  s += fmt::format("base model: residual RMS {:.3f} um; cross-validated with nuisance terms ({}) {:.3f} um\n",
                   a.rms_base_mm * 1e3, fmt::join(a.nuisance, ", "), a.cv_rms_before_mm * 1e3);
  if (!a.structure_before.empty()) {
    s += "what the base model gets wrong (structure in its residual):\n";
    for (std::size_t i = 0; i < std::min<std::size_t>(6, a.structure_before.size()); ++i) {
      const auto& st = a.structure_before[i];
      s += fmt::format("  {} residual follows {} ({}, F={:.1f}, p={:.2g}, size {:.3f} um{})\n", kAxis[st.component],
                       st.condition, st.test, st.statistic, st.p_value, st.size_mm * 1e3,
                       st.period > 0 ? fmt::format(", period {:.4g}", st.period) : "");
    }
  } else {
    s += "no structure found in the base model's residual\n";
  }
  if (a.effects.empty()) s += "effects claimed: none\n";
  for (const auto& e : a.effects) {
    s += fmt::format("effect: {} [{}] F={:.1f} p={:.2g} (x{:.0f} tests) dBIC={:.1f}, CV RMS -> {:.3f} um\n", e.what,
                     e.kind, e.f_statistic, e.p_value, e.tests, e.delta_bic, e.cv_rms_mm * 1e3);
    s += fmt::format("  cause: {}\n", e.explanation);
    for (const auto& p : e.parameters) s += fmt::format("  {} = {:.6g} +- {:.2g} {}\n", p.name, p.value, p.sd, p.unit);
    if (e.world_term.is_null()) s += "  (not written into the world: no machine error term simulates it yet)\n";
  }
  if (!a.stopped_at.empty()) s += "stopped: " + a.stopped_at + "\n";
  s += fmt::format("gain: cross-validated RMS {:.3f} um -> {:.3f} um ({}), noise {:.3f} um ({})\n",
                   a.cv_rms_before_mm * 1e3, a.cv_rms_after_mm * 1e3, a.folds, a.noise_mm * 1e3, a.noise_source);
  if (a.unexplained.empty()) s += "unexplained structure: none\n";
  for (const auto& st : a.unexplained)
    s += fmt::format("unexplained structure: {} residual follows {} ({}, F={:.1f}, p={:.2g}, size {:.3f} um{})\n",
                     kAxis[st.component], st.condition, st.test, st.statistic, st.p_value, st.size_mm * 1e3,
                     st.period > 0 ? fmt::format(", period {:.4g}", st.period) : "");
  return s;
}

}  // namespace metron::discrepancy
