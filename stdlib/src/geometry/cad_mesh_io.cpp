// SPDX-License-Identifier: GPL-3.0-or-later
// The one translation unit with CGAL's polygon soup I/O and soup repair (STYLE.md 9).
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/triangulate_faces.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

#include "metron/stdlib/file_access.hpp"
#include "metron/stdlib/geometry/cad_import.hpp"
#include "metron/stdlib/geometry/mesh.hpp"

namespace metron::geometry {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using Polygon = std::vector<std::size_t>;

std::string lowercase_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

MeshError file_error(const std::string& path, const std::string& what) { return MeshError{"'" + path + "': " + what}; }

// CGAL's readers only say "failed"; for a binary STL the byte count says which record broke.
std::string diagnose_stl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char header[84];
  if (!in.read(header, sizeof header)) return "could not be read as STL (shorter than a header)";
  if (std::strncmp(header, "solid", 5) == 0 && std::isspace(static_cast<unsigned char>(header[5])))
    return "could not be parsed as ASCII STL (expected 'facet normal', 'outer loop', 3 "
           "'vertex' lines, 'endloop', 'endfacet' ... 'endsolid')";
  std::uint32_t count = 0;
  std::memcpy(&count, header + 80, sizeof count);  // STL is little-endian, as is every target
  const auto size = std::filesystem::file_size(path);
  const std::uintmax_t expected = 84 + 50ull * count;
  if (size < expected)
    return "truncated binary STL: the header declares " + std::to_string(count) + " triangles (" +
           std::to_string(expected) + " bytes) but the file has " + std::to_string(size) + " bytes, so triangle " +
           std::to_string((size - 84) / 50) + " (0-based) is incomplete";
  return "could not be read as STL";
}

}  // namespace

tl::expected<Mesh, MeshError> load_mesh(const std::string& path) {
  const std::string ext = lowercase_extension(path);
  if (ext == ".step" || ext == ".stp" || ext == ".iges" || ext == ".igs") return load_cad(path);
  if (ext != ".stl" && ext != ".off" && ext != ".obj" && ext != ".ply")
    return tl::unexpected(file_error(
        path, "unsupported mesh format '" + ext + "' (expected .stl, .off, .obj, .ply, .step, .stp, .iges or .igs)"));
  if (!std::ifstream(path)) return tl::unexpected(file_error(path, "cannot open file"));
  // A device named like a mesh (/dev/zero as part.stl) would never end: regular files within the
  // input cap only (docs/security.md).
  if (auto refused = refuse_input_file(path)) return tl::unexpected(MeshError{*refused});

  std::vector<Point> points;
  std::vector<Polygon> polygons;
  if (!CGAL::IO::read_polygon_soup(path, points, polygons, CGAL::parameters::verbose(false))) {
    std::string format = ext.substr(1);
    std::transform(format.begin(), format.end(), format.begin(),
                   [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
    const std::string what = ext == ".stl" ? diagnose_stl(path) : "could not be parsed as " + format;
    return tl::unexpected(file_error(path, what));
  }
  for (std::size_t i = 0; i < polygons.size(); ++i)
    for (std::size_t v : polygons[i])
      if (v >= points.size())
        return tl::unexpected(
            file_error(path, "polygon " + std::to_string(i) + " refers to a missing vertex " + std::to_string(v)));
  if (polygons.empty()) return tl::unexpected(file_error(path, "contains no polygons"));

  // Merge duplicate points, drop degenerate and duplicate polygons, orient consistently,
  // split polygons into triangles and turn a closed surface outward.
  PMP::repair_polygon_soup(points, polygons);
  PMP::orient_polygon_soup(points, polygons);
  if (polygons.empty()) return tl::unexpected(file_error(path, "every polygon is degenerate"));
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, sm);
  if (!PMP::triangulate_faces(sm)) return tl::unexpected(file_error(path, "has a polygon that cannot be triangulated"));
  if (CGAL::is_closed(sm) && !PMP::is_outward_oriented(sm)) PMP::reverse_face_orientations(sm);

  std::vector<Vec3> vertices;
  vertices.reserve(sm.number_of_vertices());
  for (auto v : sm.vertices()) {
    const Point& p = sm.point(v);
    vertices.emplace_back(p.x(), p.y(), p.z());
  }
  std::vector<Mesh::Face> faces;
  faces.reserve(sm.number_of_faces());
  for (auto f : sm.faces()) {
    Mesh::Face& out = faces.emplace_back();
    std::size_t k = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm))
      if (k < 3) out[k++] = static_cast<std::uint32_t>(v.idx());
  }
  auto mesh = Mesh::from_triangles(std::move(vertices), std::move(faces));
  if (!mesh) return tl::unexpected(file_error(path, mesh.error().message));
  return mesh;
}

tl::expected<void, MeshError> save_mesh(const Mesh& mesh, const std::string& path) {
  const std::string ext = lowercase_extension(path);
  if (ext != ".stl" && ext != ".off" && ext != ".obj" && ext != ".ply")
    return tl::unexpected(
        file_error(path, "cannot write mesh format '" + ext + "' (expected .stl, .off, .obj or .ply)"));
  std::vector<Point> points;
  points.reserve(mesh.vertex_count());
  for (const Vec3& v : mesh.vertices()) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::array<std::size_t, 3>> triangles;
  triangles.reserve(mesh.face_count());
  for (const auto& f : mesh.faces()) triangles.push_back({f[0], f[1], f[2]});
  if (!CGAL::IO::write_polygon_soup(path, points, triangles, CGAL::parameters::stream_precision(17)))
    return tl::unexpected(file_error(path, "could not be written"));
  return {};
}

}  // namespace metron::geometry
