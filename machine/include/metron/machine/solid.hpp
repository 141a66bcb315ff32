// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

/// Simulated material in machine coordinates, described by a signed distance field.
class Solid {
 public:
  virtual ~Solid() = default;
  /// Signed distance from p to the surface, mm: > 0 outside the material, < 0 inside. Exact
  /// near faces; elsewhere its magnitude may be smaller than the true distance (never larger
  /// than lipschitz() times it), which keeps sphere tracing safe.
  [[nodiscard]] virtual double signed_distance(const Vec3& p) const = 0;
  /// Outward unit normal at (or near) p: the normalised gradient of the distance field.
  [[nodiscard]] virtual Vec3 normal(const Vec3& p) const;
  /// Bound on |grad signed_distance| (1 for a true distance field; form deviations add slope).
  [[nodiscard]] virtual double lipschitz() const { return 1.0; }
  /// Name of the feature whose surface is nearest p (for messages); empty when unnamed.
  [[nodiscard]] virtual std::string feature_at(const Vec3& /*p*/) const { return {}; }
  /// A view of this solid for many queries near `centre_mm`, as a scanning probe makes every
  /// control cycle: the same values everywhere, cheaper for a query p whose nearest surface is
  /// within radius_mm - |p - centre_mm| of p. It refers to this solid, which must outlive it,
  /// and serves one thread. The default forwards every query.
  [[nodiscard]] virtual std::unique_ptr<Solid> local_view(const Vec3& centre_mm, double radius_mm) const;
};

/// Several solids as one: the union of their material.
class SolidUnion final : public Solid {
 public:
  explicit SolidUnion(std::vector<std::unique_ptr<Solid>> solids);
  [[nodiscard]] double signed_distance(const Vec3& p) const override;
  [[nodiscard]] Vec3 normal(const Vec3& p) const override;
  [[nodiscard]] double lipschitz() const override;
  [[nodiscard]] std::string feature_at(const Vec3& p) const override;
  /// The union of the members' local views.
  [[nodiscard]] std::unique_ptr<Solid> local_view(const Vec3& centre_mm, double radius_mm) const override;

 private:
  [[nodiscard]] const Solid& nearest(const Vec3& p) const;
  std::vector<std::unique_ptr<Solid>> m_solids;
};

}  // namespace metron::machine
