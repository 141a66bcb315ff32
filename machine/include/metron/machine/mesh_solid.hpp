// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "metron/machine/solid.hpp"
#include "metron/machine/world.hpp"
#include "metron/stdlib/geometry/cad_import.hpp"
#include "metron/stdlib/geometry/mesh.hpp"

namespace metron::machine {

/// A closed triangle mesh (e.g. a tessellated STEP part) as a solid: distance to the closest
/// surface point, negative inside (geometry::Mesh::contains), minus a deviation field of
/// Gaussian bumps evaluated at the closest surface point.
///
/// Given the CAD faces the mesh was tessellated from, contact is exact on analytic faces: the
/// mesh only finds the closest triangle, and when that belongs to a plane, cylinder, cone, sphere
/// or torus the distance and normal are those of the surface itself (docs/world.md, "Exact
/// contact on CAD faces"). The value then exceeds the true distance by at most the chord
/// tolerance (twice that near an edge where a concave curved face meets a convex curved one),
/// plus the model's edge tolerance, which keeps sphere tracing safe to that depth.
class MeshSolid final : public Solid {
 public:
  /// `faces` index triangles of `mesh` (geometry::CadModel); `chord_tolerance_mm` is the
  /// tessellation's, the largest expected gap between a triangle and its face.
  MeshSolid(std::shared_ptr<const geometry::Mesh> mesh, const Frame& part_to_machine, std::vector<Bump> bumps = {},
            const std::vector<geometry::CadFace>& faces = {}, double chord_tolerance_mm = 0.001);
  [[nodiscard]] double signed_distance(const Vec3& p) const override;
  [[nodiscard]] Vec3 normal(const Vec3& p) const override;
  [[nodiscard]] double lipschitz() const override { return m_lipschitz; }
  /// "face N": the B-rep face (1-based, shape order) of a CAD design, else the triangle.
  [[nodiscard]] std::string feature_at(const Vec3& p) const override;
  /// How many CAD faces are evaluated analytically: those of a supported kind whose
  /// tessellation nodes lie on the surface (interior nodes to 1e-6 mm, boundary nodes to 10
  /// chord tolerances).
  [[nodiscard]] std::size_t analytic_face_count() const { return m_surfaces.size(); }
  /// The triangles within radius_mm of the centre, searched directly; a query whose closest
  /// point cannot be proven to lie among them goes to the whole mesh (the answer is exact).
  [[nodiscard]] std::unique_ptr<Solid> local_view(const Vec3& centre_mm, double radius_mm) const override;
  /// Whether local views reuse the candidate triangles of nearby earlier queries (default on;
  /// the answers are the same either way). Process-wide; for benchmarks and tests that compare.
  static void set_coherent_search(bool on);
  [[nodiscard]] static bool coherent_search_enabled();

 private:
  class Local;
  friend class Local;
  /// Uniform grid of the triangles (part coordinates), built on the first local_view.
  struct Grid;
  [[nodiscard]] const Grid& grid() const;
  /// An analytic face in part coordinates, oriented outward.
  struct Surface {
    geometry::CadFace::Kind kind = geometry::CadFace::Kind::Plane;
    Vec3 origin = Vec3::Zero();   ///< plane point; axis point; centre; cone apex
    Vec3 axis = Vec3::UnitZ();    ///< plane: outward normal; cone: the radius grows along it
    double radius_mm = 0;         ///< cylinder, sphere, torus (major)
    double minor_radius_mm = 0;   ///< torus
    double cos_a = 1, sin_a = 0;  ///< cone semi-angle
    bool inner = false;           ///< material outside the surface
  };
  /// The surface under a CAD face; nullopt for kinds evaluated on the mesh.
  [[nodiscard]] static std::optional<Surface> surface_of(const geometry::CadFace& face);
  /// Signed distance (> 0 on the outward side) and outward normal of the untrimmed surface;
  /// nullopt where the normal is undefined (on an axis, at a centre or apex).
  struct Exact {
    double distance_mm;
    Vec3 normal;
  };
  [[nodiscard]] static std::optional<Exact> exact(const Surface& s, const Vec3& q);
  /// The surface under the closest triangle when its distance is consistent with the mesh's.
  struct Contact {
    double distance_mm;  ///< signed, without bumps
    Vec3 normal;         ///< outward, part coordinates
    Vec3 point;          ///< closest surface point, part coordinates
  };
  [[nodiscard]] Contact contact(const Vec3& q, bool need_sign) const;
  /// contact() given the closest mesh point; `local` (may be null) decides the side at edges
  /// and vertices instead of the whole mesh's inside test.
  [[nodiscard]] Contact contact_from(const Vec3& q, const geometry::Mesh::Closest& c, bool need_sign,
                                     const Local* local) const;
  [[nodiscard]] double bump_height(const Vec3& surface_point) const;

  std::shared_ptr<const geometry::Mesh> m_mesh;
  Frame m_part_to_machine;
  Frame m_machine_to_part;
  std::vector<Bump> m_bumps;
  double m_lipschitz = 1;
  std::vector<Surface> m_surfaces;
  std::vector<std::int32_t> m_surface_of_triangle;  ///< index into m_surfaces; -1: mesh only
  std::vector<std::uint32_t> m_shape_of_triangle;   ///< B-rep face (1-based); empty: no CAD faces
  double m_guard_mm = 0;                            ///< largest accepted |exact - mesh| distance
  std::shared_ptr<std::once_flag> m_grid_once = std::make_shared<std::once_flag>();
  mutable std::shared_ptr<const Grid> m_grid;
};

}  // namespace metron::machine
