// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/csg_solid.hpp"

#include "metron/stdlib/geometry/ellipse.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>
#include <stdexcept>

namespace metron::machine {
namespace {

constexpr double deg = std::numbers::pi / 180.0;

enum class Kind { HalfSpace, Cylinder, CappedCylinder, Sphere, Cone, Torus, EllipticCylinder };

// A primitive ready to evaluate: distances are computed in its (deviated) local frame.
struct Prim {
  std::string name;
  Kind kind = Kind::HalfSpace;
  Frame part_to_local = Frame::Identity();
  double radius = 0;                       // cylinder, sphere; torus: the centre circle's
  double tube_radius = 0;                  // torus
  double length = 0;                       // capped cylinder, capped elliptic cylinder (0: infinite)
  double semi_major = 0, semi_minor = 0;   // elliptic cylinder, along local x and y
  double sin_a = 0, cos_a = 1, tan_a = 0;  // cone
  double size_term = 0;                    // subtracted from the distance
  int lobes = 0;
  double lobe_amplitude = 0, lobe_phase = 0;
  double wave_amplitude = 0, wave_number = 0, wave_phase = 0;

  [[nodiscard]] double distance(const Vec3& p_part) const {
    const Vec3 q = part_to_local * p_part;
    const double rho = std::hypot(q.x(), q.y());
    double d = 0;
    switch (kind) {
      case Kind::HalfSpace: d = q.z(); break;
      case Kind::Cylinder: d = rho - radius; break;
      case Kind::CappedCylinder: {
        // Exact capped cylinder in (radial, axial) coordinates.
        const double dr = rho - radius, dz = std::abs(q.z() - length / 2) - length / 2;
        d = std::min(std::max(dr, dz), 0.0) + std::hypot(std::max(dr, 0.0), std::max(dz, 0.0));
        break;
      }
      case Kind::Sphere: d = q.norm() - radius; break;
      case Kind::Cone: {
        // Behind the apex (the foot on the generator would be before the apex) the apex is nearest.
        const double along_generator = rho * sin_a + q.z() * cos_a;
        d = along_generator < 0 ? q.norm() : rho * cos_a - q.z() * sin_a;
        break;
      }
      case Kind::Torus: d = std::hypot(rho - radius, q.z()) - tube_radius; break;  // exact
      case Kind::EllipticCylinder: {
        // The exact section distance, extruded and capped as the capped cylinder above.
        const double dr = geometry::ellipse_foot(semi_major, semi_minor, {q.x(), q.y()}).signed_distance;
        if (length == 0) {
          d = dr;
          break;
        }
        const double dz = std::abs(q.z() - length / 2) - length / 2;
        d = std::min(std::max(dr, dz), 0.0) + std::hypot(std::max(dr, 0.0), std::max(dz, 0.0));
        break;
      }
    }
    d -= size_term;
    if (lobe_amplitude != 0) d -= lobing(q, rho);
    if (wave_amplitude != 0) d -= wave_amplitude * std::cos(wave_number * q.x() - wave_phase);
    return d;
  }

  // amplitude * cos(n (theta - phase)), faded as (rho / rho_0)^n inside rho_0 so that the field
  // stays smooth on the axis (rho^n cos(n theta) is a harmonic polynomial). Cylinders and cones
  // keep the whole amplitude down to half their radius (rho_0 = R/2): inside a bore or a
  // countersink the ball centre runs at R - r, and a ball up to half the radius must see the form
  // the surface has. A sphere fades from its radius (toward the poles as sin(polar)^n).
  [[nodiscard]] double lobing(const Vec3& q, double rho) const {
    double reference = radius;
    if (kind == Kind::Cone) reference = std::max(q.z(), 0.0) * tan_a;
    if (kind != Kind::Sphere) reference /= 2;
    const double c = std::cos(lobes * (std::atan2(q.y(), q.x()) - lobe_phase));
    const double fade = rho >= reference ? 1.0 : std::pow(rho / reference, lobes);
    return lobe_amplitude * c * fade;
  }
};

Prim compile_primitive(const csg::Primitive& p, const csg::Deviation* dev, double& lipschitz_extra) {
  Prim out;
  out.name = p.name;
  const Frame nominal = csg::local_frame(p);
  Frame local = nominal;
  if (dev) {
    // Machined frame = translate(offset) * nominal * tilt (tilt about local x, then local y).
    const Eigen::Matrix3d tilt = (Eigen::AngleAxisd(dev->tilt_deg.y() * deg, Vec3::UnitY()) *
                                  Eigen::AngleAxisd(dev->tilt_deg.x() * deg, Vec3::UnitX()))
                                     .toRotationMatrix();
    local = Eigen::Translation3d(dev->offset_mm) * nominal;
    local.rotate(tilt);
  }
  out.part_to_local = local.inverse(Eigen::Isometry);
  const double size = dev ? dev->size_mm : 0.0;
  std::visit(
      [&](const auto& s) {
        using T = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<T, csg::HalfSpace>) {
          out.kind = Kind::HalfSpace;
          out.size_term = size;
        } else if constexpr (std::is_same_v<T, csg::Cylinder>) {
          out.kind = s.length_mm ? Kind::CappedCylinder : Kind::Cylinder;
          out.radius = s.diameter_mm / 2;
          out.length = s.length_mm.value_or(0);
          out.size_term = size / 2;
        } else if constexpr (std::is_same_v<T, csg::Sphere>) {
          out.kind = Kind::Sphere;
          out.radius = s.diameter_mm / 2;
          out.size_term = size / 2;
        } else if constexpr (std::is_same_v<T, csg::Torus>) {
          out.kind = Kind::Torus;
          out.radius = s.major_diameter_mm / 2;
          out.tube_radius = s.minor_diameter_mm / 2;
          out.size_term = size / 2;
        } else if constexpr (std::is_same_v<T, csg::EllipticCylinder>) {
          // A size deviation changes both diameters: the machined section stays an ellipse.
          out.kind = Kind::EllipticCylinder;
          out.semi_major = (s.major_diameter_mm + size) / 2;
          out.semi_minor = (s.minor_diameter_mm + size) / 2;
          out.radius = out.semi_minor;  // lobing's reference
          out.length = s.length_mm.value_or(0);
        } else {
          out.kind = Kind::Cone;
          const double a = s.half_angle_deg * deg;
          out.sin_a = std::sin(a), out.cos_a = std::cos(a), out.tan_a = std::tan(a);
          out.size_term = size / 2 * out.cos_a;  // a diameter change at every height
        }
      },
      p.shape);
  if (dev && dev->lobing && dev->lobing->amplitude_mm != 0) {
    out.lobes = dev->lobing->lobes;
    out.lobe_amplitude = dev->lobing->amplitude_mm;
    out.lobe_phase = dev->lobing->phase_deg * deg;
    // |grad| <= amplitude * lobes / rho_0 (R/2 for a cylinder, R for a sphere; 1 mm for a cone,
    // whose radius varies).
    const double reference = out.kind == Kind::Cone ? 1.0 : out.kind == Kind::Sphere ? out.radius : out.radius / 2;
    lipschitz_extra += std::abs(out.lobe_amplitude) * out.lobes / reference;
  }
  if (dev && dev->waviness && dev->waviness->amplitude_mm != 0) {
    out.wave_amplitude = dev->waviness->amplitude_mm;
    out.wave_number = 2 * std::numbers::pi / dev->waviness->wavelength_mm;
    out.wave_phase = dev->waviness->phase_deg * deg;
    lipschitz_extra += std::abs(out.wave_amplitude) * out.wave_number;
  }
  return out;
}

struct CNode {
  csg::Node::Op op = csg::Node::Op::Primitive;
  std::size_t prim = 0;
  std::vector<CNode> children;
};

struct Value {
  double d;
  std::size_t prim;
};

}  // namespace

struct CsgSolid::Compiled {
  std::vector<Prim> prims;
  CNode root;

  CNode compile(const csg::Node& n, const std::map<std::string, csg::Deviation>& devs, std::set<std::string>& used,
                double& lipschitz_extra) {
    CNode c;
    c.op = n.op;
    if (n.op == csg::Node::Op::Primitive) {
      const csg::Deviation* dev = nullptr;
      if (const auto it = devs.find(n.primitive.name); !n.primitive.name.empty() && it != devs.end()) {
        dev = &it->second;
        used.insert(it->first);
      }
      c.prim = prims.size();
      prims.push_back(compile_primitive(n.primitive, dev, lipschitz_extra));
      return c;
    }
    if (n.children.empty()) throw std::invalid_argument("a CSG operation without children");
    for (const csg::Node& child : n.children) c.children.push_back(compile(child, devs, used, lipschitz_extra));
    return c;
  }

  [[nodiscard]] Value eval(const CNode& n, const Vec3& p) const {
    using Op = csg::Node::Op;
    if (n.op == Op::Primitive) return {prims[n.prim].distance(p), n.prim};
    Value v = eval(n.children.front(), p);
    for (std::size_t i = 1; i < n.children.size(); ++i) {
      Value c = eval(n.children[i], p);
      if (n.op == Op::Difference) c.d = -c.d;
      const bool take = n.op == Op::Union ? c.d < v.d : c.d > v.d;
      if (take) v = c;
    }
    return v;
  }
};

CsgSolid::CsgSolid(const csg::Node& design, const Frame& part_to_machine,
                   const std::map<std::string, csg::Deviation>& deviations)
    : m_compiled(std::make_unique<Compiled>()), m_machine_to_part(part_to_machine.inverse(Eigen::Isometry)) {
  std::set<std::string> used;
  double extra = 0;
  m_compiled->root = m_compiled->compile(design, deviations, used, extra);
  for (const auto& [name, dev] : deviations)
    if (!used.count(name)) throw std::invalid_argument("no primitive named '" + name + "' in the design");
  m_lipschitz = 1 + extra;
}

CsgSolid::~CsgSolid() = default;
CsgSolid::CsgSolid(CsgSolid&&) noexcept = default;
CsgSolid& CsgSolid::operator=(CsgSolid&&) noexcept = default;

double CsgSolid::signed_distance(const Vec3& p) const {
  return m_compiled->eval(m_compiled->root, m_machine_to_part * p).d;
}

std::string CsgSolid::feature_at(const Vec3& p) const {
  const Value v = m_compiled->eval(m_compiled->root, m_machine_to_part * p);
  return m_compiled->prims[v.prim].name;
}

Frame csg::local_frame(const Primitive& primitive) {
  Vec3 origin = Vec3::Zero(), z = Vec3::UnitZ();
  std::optional<Vec3> major;
  std::visit(
      [&](const auto& s) {
        using T = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<T, HalfSpace>)
          origin = s.point, z = s.normal;
        else if constexpr (std::is_same_v<T, Cylinder>)
          origin = s.point, z = s.axis;
        else if constexpr (std::is_same_v<T, Sphere>)
          origin = s.centre;
        else if constexpr (std::is_same_v<T, Torus>)
          origin = s.centre, z = s.axis;
        else if constexpr (std::is_same_v<T, EllipticCylinder>)
          origin = s.point, z = s.axis, major = s.major_axis;
        else
          origin = s.apex, z = s.axis;
      },
      primitive.shape);
  z.normalize();
  // Local x: an elliptic cylinder's major axis; otherwise any direction normal to z.
  const Vec3 ref = major ? *major : std::abs(z.x()) <= 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 x = (ref - ref.dot(z) * z).normalized();
  Frame f = Frame::Identity();
  f.linear().col(0) = x;
  f.linear().col(1) = z.cross(x);
  f.linear().col(2) = z;
  f.translation() = origin;
  return f;
}

}  // namespace metron::machine
