// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/alignment_ops.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace metron::runtime {
namespace {

// The direction a datum feature gives: a plane's normal, an axis's direction, a line's direction.
// A closed slot (CPARLN) has two: as the first (primary) direction its plane's normal, after it
// its long axis, which is what a slot orients when a plane already set the primary axis.
Vec3 datum_direction(const Geometry& g, bool primary) {
  if (g.type == FeatureType::ClosedSlot && !primary) return g.slot_axis.normalized();
  return g.direction.normalized();
}

bool point_like(FeatureType t) {
  return t == FeatureType::Point || t == FeatureType::Circle || t == FeatureType::Arc || t == FeatureType::Sphere;
}

}  // namespace

tl::expected<Frame, std::string> datset(const Frame& current, const std::vector<DatsetClause>& clauses) {
  Mat3 axes = current.linear();  // columns: X, Y, Z of the current frame in MCS
  std::optional<int> primary;
  std::optional<int> secondary;
  for (const auto& c : clauses) {
    if (!c.direction) continue;
    const int k = static_cast<int>(*c.direction);
    Vec3 d = datum_direction(c.datum, !primary) * (c.minus ? -1.0 : 1.0);
    if (!primary) {
      primary = k;
      axes.col(k) = d;
    } else if (!secondary) {
      if (k == *primary) return tl::unexpected(std::string("two datums orient the same axis"));
      const Vec3 p = axes.col(*primary);
      d = d - d.dot(p) * p;
      // A sphere has no direction of its own: it always orients from the origin toward it.
      if ((d.norm() < 1e-9 && point_like(c.datum.type)) || c.datum.type == FeatureType::Sphere) {
        // A hole (or point) whose axis is the primary's orients the secondary axis from the origin
        // toward its centre: the plane-hole-hole alignment, `DAT(A),ZDIR,ZORIG,DAT(B),XORIG,YORIG,
        // DAT(C),XDIR`. The origin is the position of the other datum that fixes an origin across
        // the primary axis (else the current origin).
        Vec3 pivot = current.translation();
        for (const auto& o : clauses)
          if (&o != &c &&
              std::any_of(o.origins.begin(), o.origins.end(), [&](Axis a) { return static_cast<int>(a) != *primary; }))
            pivot = o.datum.position;
        d = (c.datum.position - pivot) * (c.minus ? -1.0 : 1.0);
        d = d - d.dot(p) * p;
        if (d.norm() < 1e-9)
          return tl::unexpected(
              std::string("the secondary datum lies on the origin across the primary axis: it gives no direction"));
      }
      if (d.norm() < 1e-9) return tl::unexpected(std::string("the secondary datum is parallel to the primary datum"));
      secondary = k;
      axes.col(k) = d.normalized();
    } else {
      return tl::unexpected(std::string("at most two datums can orient axes; the third is implied"));
    }
  }
  if (primary) {
    const int p = *primary;
    if (!secondary) {
      // Keep the current frame's next axis, made perpendicular to the primary.
      const int s = (p + 1) % 3;
      Vec3 d = current.linear().col(s);
      d = d - d.dot(axes.col(p)) * axes.col(p);
      if (d.norm() < 1e-9) d = any_perpendicular(axes.col(p));
      axes.col(s) = d.normalized();
      secondary = s;
    }
    const int s = *secondary;
    const int t = 3 - p - s;
    // Right-handed completion: X = Y x Z, Y = Z x X, Z = X x Y.
    axes.col(t) = axes.col((t + 1) % 3).cross(axes.col((t + 2) % 3)).normalized();
  }
  // Origin: along each axis fixed by a datum the datum's position has coordinate 0; other axes
  // keep the current origin's coordinate.
  Vec3 coeff;
  for (int k = 0; k < 3; ++k) coeff[k] = current.translation().dot(axes.col(k));
  for (const auto& c : clauses)
    for (Axis a : c.origins) {
      const int k = static_cast<int>(a);
      coeff[k] = c.datum.position.dot(axes.col(k));
    }
  Frame f = Frame::Identity();
  f.linear() = axes;
  f.translation() = axes * coeff;
  return f;
}

Frame translate_origin(const Frame& current, const std::optional<double> (&origin)[3]) {
  Vec3 shift = Vec3::Zero();
  for (int k = 0; k < 3; ++k)
    if (origin[k]) shift[k] = *origin[k];
  Frame f = current;
  f.translation() = current * shift;
  return f;
}

Frame rotate_about(const Frame& current, Axis axis, double angle_deg) {
  const Vec3 local_axis = Vec3::Unit(static_cast<int>(axis));
  Frame f = current;
  f.linear() =
      current.linear() * Eigen::AngleAxisd(angle_deg * std::numbers::pi / 180.0, local_axis).toRotationMatrix();
  return f;
}

tl::expected<Frame, std::string> rotate_to(const Frame& current, Axis about, const Vec3& direction, Axis align) {
  if (about == align) return tl::unexpected(std::string("cannot align the rotation axis itself"));
  const Vec3 local = current.linear().transpose() * direction;
  const int a = static_cast<int>(about);
  const int u = (a + 1) % 3;  // first axis of the rotation plane (X for Z, Y for X, Z for Y)
  const int v = (a + 2) % 3;
  const double angle_dir = std::atan2(local[v], local[u]);
  if (std::hypot(local[u], local[v]) < 1e-9)
    return tl::unexpected(std::string("the feature's direction is parallel to the rotation axis"));
  const double angle_axis = static_cast<int>(align) == u ? 0.0 : std::numbers::pi / 2.0;
  return rotate_about(current, about, (angle_dir - angle_axis) * 180.0 / std::numbers::pi);
}

Geometry to_frame(const Geometry& g, const Frame& part_to_machine) {
  const Frame inv = part_to_machine.inverse();
  Geometry out = g;
  out.position = inv * g.position;
  out.direction = inv.linear() * g.direction;
  out.normal2 = inv.linear() * g.normal2;
  out.slot_axis = inv.linear() * g.slot_axis;
  out.arc_reference = inv.linear() * g.arc_reference;
  return out;
}

Geometry to_machine(const Geometry& g, const Frame& part_to_machine) {
  Geometry out = g;
  out.position = part_to_machine * g.position;
  out.direction = part_to_machine.linear() * g.direction;
  out.normal2 = part_to_machine.linear() * g.normal2;
  out.slot_axis = part_to_machine.linear() * g.slot_axis;
  out.arc_reference = part_to_machine.linear() * g.arc_reference;
  return out;
}

}  // namespace metron::runtime
