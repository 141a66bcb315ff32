// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/solid.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace metron::machine {

Vec3 Solid::normal(const Vec3& p) const {
  // Central differences; h is far above the rounding of distances of ~1e3 mm (1e-13 mm).
  constexpr double h = 1e-6;
  Vec3 g;
  for (int i = 0; i < 3; ++i) {
    Vec3 dp = Vec3::Zero();
    dp[i] = h;
    g[i] = (signed_distance(p + dp) - signed_distance(p - dp)) / (2 * h);
  }
  const double n = g.norm();
  return n > 0 ? Vec3(g / n) : Vec3::UnitZ();
}

namespace {

// The default local view: every query goes to the solid itself.
class Forwarding final : public Solid {
 public:
  explicit Forwarding(const Solid& solid) : m_solid(solid) {}
  [[nodiscard]] double signed_distance(const Vec3& p) const override { return m_solid.signed_distance(p); }
  [[nodiscard]] Vec3 normal(const Vec3& p) const override { return m_solid.normal(p); }
  [[nodiscard]] double lipschitz() const override { return m_solid.lipschitz(); }
  [[nodiscard]] std::string feature_at(const Vec3& p) const override { return m_solid.feature_at(p); }

 private:
  const Solid& m_solid;
};

}  // namespace

std::unique_ptr<Solid> Solid::local_view(const Vec3& /*centre_mm*/, double /*radius_mm*/) const {
  return std::make_unique<Forwarding>(*this);
}

SolidUnion::SolidUnion(std::vector<std::unique_ptr<Solid>> solids) : m_solids(std::move(solids)) {
  std::erase(m_solids, nullptr);
  if (m_solids.empty()) throw std::invalid_argument("a solid union needs at least one solid");
}

const Solid& SolidUnion::nearest(const Vec3& p) const {
  const Solid* best = m_solids.front().get();
  double best_d = std::numeric_limits<double>::infinity();
  for (const auto& s : m_solids) {
    const double d = s->signed_distance(p);
    if (d < best_d) best_d = d, best = s.get();
  }
  return *best;
}

double SolidUnion::signed_distance(const Vec3& p) const {
  double d = std::numeric_limits<double>::infinity();
  for (const auto& s : m_solids) d = std::min(d, s->signed_distance(p));
  return d;
}

Vec3 SolidUnion::normal(const Vec3& p) const { return nearest(p).normal(p); }

double SolidUnion::lipschitz() const {
  double l = 1;
  for (const auto& s : m_solids) l = std::max(l, s->lipschitz());
  return l;
}

std::string SolidUnion::feature_at(const Vec3& p) const { return nearest(p).feature_at(p); }

std::unique_ptr<Solid> SolidUnion::local_view(const Vec3& centre_mm, double radius_mm) const {
  std::vector<std::unique_ptr<Solid>> views;
  for (const auto& s : m_solids) views.push_back(s->local_view(centre_mm, radius_mm));
  return std::make_unique<SolidUnion>(std::move(views));
}

}  // namespace metron::machine
