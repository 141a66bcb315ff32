// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/world_solid.hpp"

#include <cmath>

#include "metron/machine/csg_solid.hpp"
#include "metron/machine/mesh_solid.hpp"

namespace metron::machine {
namespace {

std::uint64_t splitmix64(std::uint64_t x) {  // S. Vigna's finaliser, a well-mixed hash
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Roughness: smooth value noise on a cubic lattice (values uniform in [-1, 1] at the nodes,
// smoothstep-weighted trilinear interpolation), a fixed function of position for a given seed.
class RoughSolid final : public Solid {
 public:
  RoughSolid(std::unique_ptr<Solid> base, Roughness roughness, std::uint64_t seed)
      : m_base(std::move(base)), m_roughness(roughness), m_seed(splitmix64(seed)) {}

  [[nodiscard]] double signed_distance(const Vec3& p) const override {
    return m_base->signed_distance(p) - m_roughness.amplitude_mm * noise(p / m_roughness.correlation_mm);
  }
  [[nodiscard]] double lipschitz() const override {
    // Per axis the interpolant's slope is at most 1.5 (smoothstep) * 2 (node range) per cell.
    return m_base->lipschitz() + std::sqrt(3.0) * 3.0 * m_roughness.amplitude_mm / m_roughness.correlation_mm;
  }
  [[nodiscard]] std::string feature_at(const Vec3& p) const override { return m_base->feature_at(p); }
  [[nodiscard]] std::unique_ptr<Solid> local_view(const Vec3& centre_mm, double radius_mm) const override {
    return std::unique_ptr<Solid>(
        new RoughSolid(m_base->local_view(centre_mm, radius_mm), m_roughness, m_seed, Seeded{}));
  }

 private:
  struct Seeded {};  // m_seed is already hashed
  RoughSolid(std::unique_ptr<Solid> base, Roughness roughness, std::uint64_t hashed_seed, Seeded)
      : m_base(std::move(base)), m_roughness(roughness), m_seed(hashed_seed) {}
  [[nodiscard]] double node(std::int64_t i, std::int64_t j, std::int64_t k) const {
    std::uint64_t h = splitmix64(m_seed ^ static_cast<std::uint64_t>(i));
    h = splitmix64(h ^ static_cast<std::uint64_t>(j));
    h = splitmix64(h ^ static_cast<std::uint64_t>(k));
    return static_cast<double>(h >> 11) * 0x1.0p-52 - 1.0;
  }
  [[nodiscard]] double noise(const Vec3& x) const {
    const Vec3 f = x.array().floor();
    const auto i = static_cast<std::int64_t>(f.x()), j = static_cast<std::int64_t>(f.y()),
               k = static_cast<std::int64_t>(f.z());
    Vec3 w = x - f;
    w = w.array() * w.array() * (3.0 - 2.0 * w.array());
    double v = 0;
    for (int c = 0; c < 8; ++c) {
      const int a = c & 1, b = (c >> 1) & 1, e = (c >> 2) & 1;
      v += (a ? w.x() : 1 - w.x()) * (b ? w.y() : 1 - w.y()) * (e ? w.z() : 1 - w.z()) * node(i + a, j + b, k + e);
    }
    return v;
  }

  std::unique_ptr<Solid> m_base;
  Roughness m_roughness;
  std::uint64_t m_seed;
};

}  // namespace

std::unique_ptr<Solid> make_part_solid(const WorldTruth& world) {
  if (!world.part) return nullptr;
  const PartSpec& part = *world.part;
  const Frame pose = part.pose.part_to_machine();
  std::unique_ptr<Solid> solid;
  if (const auto* tree = std::get_if<csg::Node>(&part.design))
    solid = std::make_unique<CsgSolid>(*tree, pose, part.deviations);
  else if (const auto& cad = std::get<CadDesign>(part.design); cad.faces)
    solid = std::make_unique<MeshSolid>(cad.mesh, pose, part.bumps, *cad.faces, cad.chord_tolerance_mm);
  else
    solid = std::make_unique<MeshSolid>(cad.mesh, pose, part.bumps);
  if (part.roughness.amplitude_mm > 0)
    solid = std::make_unique<RoughSolid>(std::move(solid), part.roughness, part.seed);
  return solid;
}

std::unique_ptr<Solid> make_reference_sphere_solid(const ReferenceSphereTruth& s) {
  csg::Node sphere;
  sphere.primitive = {"REFERENCE_SPHERE", csg::Sphere{s.true_centre_mm, s.true_diameter_mm}};
  csg::Node post;
  post.primitive = {"REFERENCE_POST",
                    csg::Cylinder{s.true_centre_mm, s.post_direction, s.post_diameter_mm, s.post_length_mm}};
  csg::Node rig;
  rig.op = csg::Node::Op::Union;
  rig.children = {sphere, post};
  return std::make_unique<CsgSolid>(rig, Frame::Identity());
}

std::unique_ptr<Solid> make_world_solid(const WorldTruth& world) {
  csg::Node table;
  table.primitive = {"TABLE", csg::HalfSpace{Vec3(0, 0, world.table_z_mm), Vec3::UnitZ()}};
  std::vector<std::unique_ptr<Solid>> solids;
  solids.push_back(std::make_unique<CsgSolid>(table, Frame::Identity()));
  solids.push_back(make_reference_sphere_solid(world.reference_sphere));
  solids.push_back(make_part_solid(world));
  return std::make_unique<SolidUnion>(std::move(solids));
}

}  // namespace metron::machine
