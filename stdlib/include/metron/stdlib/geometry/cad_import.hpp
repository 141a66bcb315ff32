// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/geometry/vec.hpp"

// Facade over OpenCASCADE (STEP/IGES readers, BRepMesh): no OCCT type appears here, see
// STYLE.md 9. Implemented in src/geometry/cad_import.cpp.
namespace metron::geometry {

/// How finely B-rep faces are tessellated (BRepMesh_IncrementalMesh parameters).
struct TessellationOptions {
  double chord_tolerance_mm = 0.001;   ///< max distance between a triangle and its face
  double angular_tolerance_rad = 0.1;  ///< max angle between normals of neighbouring triangles
  bool parallel = true;                ///< tessellate faces on several threads
};

/// The analytic surface under one B-rep face, as the CAD file defines it.
struct CadFace {
  enum class Kind {
    Plane,     ///< origin on the plane, axis = outward normal
    Cylinder,  ///< origin on the axis, radius_mm
    Cone,      ///< origin on the axis where the radius is radius_mm; semi_angle_rad
    Sphere,    ///< origin = centre, radius_mm
    Torus,     ///< origin = centre, axis, radius_mm = major, minor_radius_mm
    Other      ///< B-spline, revolved, extruded, offset ... surfaces
  };
  Kind kind = Kind::Other;
  Vec3 origin = Vec3::Zero();            ///< see `Kind`; in the model's coordinates, mm
  Vec3 axis = Vec3::UnitZ();             ///< unit; plane: outward normal; others: the surface's axis
  double radius_mm = 0;                  ///< cylinder, cone (at origin), sphere, torus (major)
  double minor_radius_mm = 0;            ///< torus only
  double semi_angle_rad = 0;             ///< cone only; the radius grows along +axis when positive
  bool inner = false;                    ///< material outside the surface (a hole), i.e. DMIS INNER
  std::uint32_t shape_index = 0;         ///< 1-based face index in the shape (TopExp::MapShapes order)
  std::vector<std::uint32_t> triangles;  ///< indices into `CadModel::mesh.faces()`
};

/// A tessellated CAD part: the closed mesh and what each B-rep face is analytically.
struct CadModel {
  Mesh mesh;
  std::vector<CadFace> faces;  ///< one per B-rep face, in shape order
};

/// Reads a STEP (.step/.stp) or IGES (.iges/.igs) file, chosen by extension (case-insensitive),
/// in millimetres; tessellates every face with BRepMesh respecting face orientation and
/// location, and welds coincident nodes so a valid solid gives a closed, outward mesh.
tl::expected<CadModel, MeshError> load_cad_model(const std::string& path, const TessellationOptions& options = {});

/// `load_cad_model(path, options)->mesh`.
tl::expected<Mesh, MeshError> load_cad(const std::string& path, const TessellationOptions& options = {});

}  // namespace metron::geometry
