// SPDX-License-Identifier: GPL-3.0-or-later
// The one translation unit with CGAL's AABB tree, slicer and inside test (STYLE.md 9).
// Boost.Graph, which the slicer instantiates here, trips GCC 12's -Wmaybe-uninitialized with a
// false positive inside system headers.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <string>

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_halfedge_graph_segment_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_slicer.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

#include "metron/stdlib/geometry/mesh.hpp"

namespace metron::geometry {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using FaceIndex = SurfaceMesh::Face_index;
using FaceTree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>>>;
using EdgeTree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, CGAL::AABB_halfedge_graph_segment_primitive<SurfaceMesh>>>;
using Slicer = CGAL::Polygon_mesh_slicer<SurfaceMesh, Kernel>;
using Side = CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel, CGAL::Default, FaceTree>;

Point to_cgal(const Vec3& v) { return {v.x(), v.y(), v.z()}; }
Vec3 to_eigen(const Point& p) { return {p.x(), p.y(), p.z()}; }

}  // namespace

// Lives on the heap and never moves: the trees and the slicer point into `surface`.
struct Mesh::Impl {
  std::vector<Vec3> vertices;
  std::vector<Face> faces;
  std::vector<Vec3> normals;  // per face; zero for zero-area faces
  SurfaceMesh surface;        // face i of `faces` is FaceIndex(i)
  FaceTree tree;              // non-degenerate faces only
  std::optional<Side> side;   // closed meshes only
  Eigen::AlignedBox3d box;
  bool closed = false;
  double volume_mm3 = 0;

  // The slicer's edge tree is built on the first section() only.
  mutable std::once_flag slicer_once;
  mutable std::unique_ptr<Slicer> slicer;
};

tl::expected<Mesh, MeshError> Mesh::from_triangles(std::vector<Vec3> vertices, std::vector<Face> faces) {
  if (faces.empty()) return tl::unexpected(MeshError{"mesh has no faces"});
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (!vertices[i].allFinite()) return tl::unexpected(MeshError{"vertex " + std::to_string(i) + " is not finite"});
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const Face& f = faces[i];
    for (auto v : f)
      if (v >= vertices.size())
        return tl::unexpected(MeshError{"face " + std::to_string(i) + " refers to vertex " + std::to_string(v) +
                                        " but the mesh has " + std::to_string(vertices.size()) + " vertices"});
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
      return tl::unexpected(MeshError{"face " + std::to_string(i) + " repeats a vertex index"});
  }

  auto impl = std::make_shared<Impl>();
  impl->vertices = std::move(vertices);
  impl->faces = std::move(faces);
  SurfaceMesh& sm = impl->surface;
  sm.reserve(impl->vertices.size(), 3 * impl->faces.size() / 2, impl->faces.size());
  for (const Vec3& v : impl->vertices) sm.add_vertex(to_cgal(v));

  // Surface_mesh refuses non-manifold or inconsistently wound faces; such a face gets its own
  // copies of its vertices, so face indices still match and the mesh is reported open.
  bool split = false;
  impl->normals.reserve(impl->faces.size());
  std::vector<FaceIndex> solid_faces;
  solid_faces.reserve(impl->faces.size());
  for (const Face& f : impl->faces) {
    using V = SurfaceMesh::Vertex_index;
    FaceIndex fi = sm.add_face(V(f[0]), V(f[1]), V(f[2]));
    if (fi == SurfaceMesh::null_face()) {
      split = true;
      fi = sm.add_face(sm.add_vertex(to_cgal(impl->vertices[f[0]])), sm.add_vertex(to_cgal(impl->vertices[f[1]])),
                       sm.add_vertex(to_cgal(impl->vertices[f[2]])));
    }
    const Vec3& a = impl->vertices[f[0]];
    const Vec3 n = (impl->vertices[f[1]] - a).cross(impl->vertices[f[2]] - a);
    const bool degenerate = CGAL::collinear(to_cgal(a), to_cgal(impl->vertices[f[1]]), to_cgal(impl->vertices[f[2]]));
    impl->normals.push_back(degenerate ? Vec3::Zero() : Vec3(n.normalized()));
    if (!degenerate) solid_faces.push_back(fi);
    for (auto v : f) impl->box.extend(impl->vertices[v]);
  }
  if (solid_faces.empty()) return tl::unexpected(MeshError{"every face has zero area"});

  impl->tree.insert(solid_faces.begin(), solid_faces.end(), sm);
  impl->tree.build();
  impl->tree.accelerate_distance_queries();  // eager, so const queries never build lazily
  impl->closed = !split && CGAL::is_closed(sm);
  if (impl->closed) {
    impl->side.emplace(impl->tree);
    impl->volume_mm3 = CGAL::Polygon_mesh_processing::volume(sm);
  }
  return Mesh(std::move(impl));
}

std::size_t Mesh::vertex_count() const { return m_impl->vertices.size(); }
std::size_t Mesh::face_count() const { return m_impl->faces.size(); }
const std::vector<Vec3>& Mesh::vertices() const { return m_impl->vertices; }
const std::vector<Mesh::Face>& Mesh::faces() const { return m_impl->faces; }
const Vec3& Mesh::face_normal(std::uint32_t face) const { return m_impl->normals.at(face); }
Eigen::AlignedBox3d Mesh::bounds() const { return m_impl->box; }
bool Mesh::is_closed() const { return m_impl->closed; }
double Mesh::volume_mm3() const { return m_impl->volume_mm3; }

Mesh::Closest Mesh::closest(const Vec3& query) const {
  const auto [p, fi] = m_impl->tree.closest_point_and_primitive(to_cgal(query));
  Closest c{to_eigen(p), Vec3::Zero(), 0.0, static_cast<std::uint32_t>(fi.idx())};
  const Vec3 d = query - c.point;
  c.distance_mm = d.norm();
  const Vec3& n = m_impl->normals[c.face];
  c.normal = n;
  if (c.distance_mm > 0) {
    // Inside a face the query lies on the face normal; otherwise the closest point is on an
    // edge or vertex and the direction to the query is the (unique) contact normal.
    const Vec3 u = d / c.distance_mm;
    const double cos_angle = u.dot(n);
    if (std::abs(cos_angle) < 1 - 1e-9) c.normal = cos_angle < 0 ? Vec3(-u) : u;
  }
  return c;
}

std::optional<Mesh::Hit> Mesh::ray_cast(const Vec3& origin, const Vec3& unit_direction, double max_t) const {
  const Kernel::Ray_3 ray(to_cgal(origin),
                          Kernel::Vector_3(unit_direction.x(), unit_direction.y(), unit_direction.z()));
  const auto hit = m_impl->tree.first_intersection(ray);
  if (!hit) return std::nullopt;
  Vec3 p;
  if (const Point* point = boost::get<Point>(&hit->first)) {
    p = to_eigen(*point);
  } else {  // the ray runs inside a face's plane: take the segment's near end
    const auto& s = boost::get<Kernel::Segment_3>(hit->first);
    const Vec3 p0 = to_eigen(s.source()), p1 = to_eigen(s.target());
    p = (p0 - origin).dot(unit_direction) <= (p1 - origin).dot(unit_direction) ? p0 : p1;
  }
  const double t = std::max(0.0, (p - origin).dot(unit_direction));
  if (t > max_t) return std::nullopt;
  const auto face = static_cast<std::uint32_t>(hit->second.idx());
  return Hit{p, m_impl->normals[face], t, face};
}

std::optional<double> Mesh::first_ball_contact(const Vec3& a, const Vec3& b, double ball_radius_mm,
                                               double tol_mm) const {
  // With r = 0 the clearance never goes negative, so there would be no crossing to bracket.
  if (!(ball_radius_mm > 0)) throw std::invalid_argument("first_ball_contact: radius must be > 0");
  const Vec3 ab = b - a;
  const double length = ab.norm();
  const double r = ball_radius_mm;
  // Signed clearance between ball and surface at parameter s.
  auto clearance = [&](double s) { return std::sqrt(m_impl->tree.squared_distance(to_cgal(a + s * ab))) - r; };
  double s = 0, c = clearance(0);
  if (c <= 0) return 0.0;
  if (length == 0) return std::nullopt;
  const double min_step_mm = std::max({r / 16, tol_mm, 1e-12 * length});
  while (s < 1) {
    const double next = std::min(1.0, s + std::max(c, min_step_mm) / length);
    const double c_next = clearance(next);
    if (c_next <= 0) {
      double lo = s, hi = next;
      while ((hi - lo) * length > tol_mm / 2) {
        const double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) break;  // no double left between them
        (clearance(mid) <= 0 ? hi : lo) = mid;
      }
      return hi;
    }
    s = next;
    c = c_next;
  }
  return std::nullopt;
}

std::vector<std::vector<Vec3>> Mesh::section(const Vec3& plane_point, const Vec3& plane_normal) const {
  std::call_once(m_impl->slicer_once, [this] { m_impl->slicer = std::make_unique<Slicer>(m_impl->surface); });
  std::vector<std::vector<Point>> polylines;
  const Kernel::Plane_3 plane(to_cgal(plane_point),
                              Kernel::Vector_3(plane_normal.x(), plane_normal.y(), plane_normal.z()));
  (*m_impl->slicer)(plane, std::back_inserter(polylines));
  std::vector<std::vector<Vec3>> out;
  out.reserve(polylines.size());
  for (const auto& line : polylines) {
    auto& o = out.emplace_back();
    o.reserve(line.size());
    for (const Point& p : line) o.push_back(to_eigen(p));
  }
  return out;
}

bool Mesh::contains(const Vec3& p) const {
  return m_impl->side && (*m_impl->side)(to_cgal(p)) != CGAL::ON_UNBOUNDED_SIDE;
}

Mesh Mesh::transformed(const Frame& frame) const {
  std::vector<Vec3> vertices;
  vertices.reserve(m_impl->vertices.size());
  for (const Vec3& v : m_impl->vertices) vertices.push_back(frame * v);
  std::vector<Face> faces = m_impl->faces;
  if (frame.linear().determinant() < 0)
    for (Face& f : faces) std::swap(f[1], f[2]);
  // Cannot fail: the same indices were accepted before and rigid maps keep coordinates finite.
  return from_triangles(std::move(vertices), std::move(faces)).value();
}

}  // namespace metron::geometry
