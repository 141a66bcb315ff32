// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <tl/expected.hpp>

#include "metron/stdlib/geometry/vec.hpp"

// Facade over CGAL (AABB tree, Polygon_mesh_slicer, Side_of_triangle_mesh, polygon soup I/O):
// no CGAL type appears here, see STYLE.md 9. Implemented in src/geometry/cad_mesh*.cpp.
namespace metron::geometry {

/// Why a mesh could not be built, read or written.
struct MeshError {
  std::string message;  ///< names the file and, when known, the record or line
};

/// An immutable triangle mesh with an AABB tree for distance, ray and inside queries.
/// Copies are cheap and share the tree; const queries are safe from several threads.
class Mesh {
 public:
  /// Vertex indices of a triangle, counterclockwise seen from outside.
  using Face = std::array<std::uint32_t, 3>;

  /// Builds the mesh and its tree. Fails on no faces, an index out of range, a repeated index
  /// in one face or a non-finite coordinate. Winding is kept as given; zero-area faces are kept
  /// in `faces()` but never returned by queries.
  static tl::expected<Mesh, MeshError> from_triangles(std::vector<Vec3> vertices, std::vector<Face> faces);

  [[nodiscard]] std::size_t vertex_count() const;
  [[nodiscard]] std::size_t face_count() const;

  /// The closest surface point to a query.
  struct Closest {
    Vec3 point;          ///< closest point on the surface
    Vec3 normal;         ///< outward unit normal there, see `closest`
    double distance_mm;  ///< |query - point|
    std::uint32_t face;  ///< index into `faces()`
  };
  /// Closest surface point. `normal` is the outward face normal when the point lies inside the
  /// face (or the query is on the surface); when it lies on an edge or vertex it is the unit
  /// direction between point and query, signed to agree with the face normal, i.e. the contact
  /// normal of a ball centred at the query.
  [[nodiscard]] Closest closest(const Vec3& query) const;

  /// A ray's first intersection with the surface.
  struct Hit {
    Vec3 point;          ///< where the ray meets the surface
    Vec3 normal;         ///< outward unit normal of the hit face
    double t;            ///< distance from the origin along the unit direction, mm
    std::uint32_t face;  ///< index into `faces()`
  };
  /// First hit with t <= max_t (an origin on the surface hits at t = 0); nullopt if none.
  [[nodiscard]] std::optional<Hit> ray_cast(const Vec3& origin, const Vec3& unit_direction,
                                            double max_t = std::numeric_limits<double>::infinity()) const;

  /// First parameter s in [0,1] along a->b at which a ball of radius r centred at a+s(b-a)
  /// touches the surface (distance == r), to within tol_mm along the path; 0 if it touches at a;
  /// nullopt if it never comes within r.
  ///
  /// Method: march along the segment with step max(distance - r, r/16): a step of distance - r
  /// cannot cross the surface (the distance field is 1-Lipschitz), so long free moves take few
  /// queries and thin walls cannot be tunnelled through; the r/16 floor near the surface bounds
  /// the work and can miss only grazing contacts shallower than r/2048. The first sample with
  /// distance <= r brackets the first crossing, which is bisected to tol_mm / 2. The returned s
  /// is the touching end of the bracket: the ball there touches or penetrates by at most tol_mm.
  /// Throws std::invalid_argument unless ball_radius_mm > 0 (use ray_cast for a point).
  [[nodiscard]] std::optional<double> first_ball_contact(const Vec3& a, const Vec3& b, double ball_radius_mm,
                                                         double tol_mm = 1e-7) const;

  /// Plane section (CGAL::Polygon_mesh_slicer): polylines where the plane cuts the surface; a
  /// closed polyline repeats its first point at the end. (Outward face normal, direction of
  /// travel, plane normal) is right-handed, so seen from the side the plane normal points to,
  /// outer boundaries of a closed outward mesh run counterclockwise and holes clockwise.
  [[nodiscard]] std::vector<std::vector<Vec3>> section(const Vec3& plane_point, const Vec3& plane_normal) const;

  /// Axis-aligned bounds of the vertices used by faces.
  [[nodiscard]] Eigen::AlignedBox3d bounds() const;
  /// True if every edge has exactly two faces with consistent winding (watertight).
  [[nodiscard]] bool is_closed() const;
  /// True if p is inside or on a closed mesh (CGAL::Side_of_triangle_mesh); false if not closed.
  [[nodiscard]] bool contains(const Vec3& p) const;
  /// Enclosed volume in mm^3 (positive for outward winding); 0 if not closed.
  [[nodiscard]] double volume_mm3() const;
  /// The mesh with every vertex mapped by `frame`; winding is flipped if frame mirrors.
  [[nodiscard]] Mesh transformed(const Frame& frame) const;

  [[nodiscard]] const std::vector<Vec3>& vertices() const;
  [[nodiscard]] const std::vector<Face>& faces() const;
  /// Outward unit normal of a face from its winding (zero for a zero-area face).
  [[nodiscard]] const Vec3& face_normal(std::uint32_t face) const;

 private:
  struct Impl;  // defined in src/geometry/cad_mesh.cpp only
  explicit Mesh(std::shared_ptr<const Impl> impl) : m_impl(std::move(impl)) {}
  std::shared_ptr<const Impl> m_impl;
};

/// Reads a mesh, dispatching on the extension (case-insensitive): .stl (ASCII or binary), .off,
/// .obj, .ply through CGAL's polygon soup reader, then repaired, consistently oriented,
/// triangulated and turned outward if closed; .step/.stp/.iges/.igs through `load_cad`.
tl::expected<Mesh, MeshError> load_mesh(const std::string& path);

/// Writes a mesh as .stl (binary), .off, .obj or .ply, chosen by extension (for inspection).
tl::expected<void, MeshError> save_mesh(const Mesh& mesh, const std::string& path);

}  // namespace metron::geometry
