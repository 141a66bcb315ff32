// SPDX-License-Identifier: GPL-3.0-or-later
// The one translation unit with OpenCASCADE (STYLE.md 9): STEP/IGES in, tessellated mesh out.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <regex>
#include <string>
#include <unordered_map>
#include <vector>

#include <Adaptor3d_Curve.hxx>
#include <BRepAdaptor_Surface.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <GeomAdaptor_Surface.hxx>
#include <GeomLib_IsPlanarSurface.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <IMeshTools_Parameters.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_Printer.hxx>
#include <Message_PrinterOStream.hxx>
#include <Poly_Triangulation.hxx>
#include <STEPControl_Reader.hxx>
#include <ShapeFix_Solid.hxx>
#include <Standard_Failure.hxx>
#include <TCollection_AsciiString.hxx>
#include <TopAbs.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>
#include <TopoDS_Shell.hxx>
#include <TopoDS_Solid.hxx>
#include <gp_Ax3.hxx>
#include <gp_Circ.hxx>
#include <gp_Cone.hxx>
#include <gp_Cylinder.hxx>
#include <gp_Lin.hxx>
#include <gp_Pln.hxx>
#include <gp_Sphere.hxx>
#include <gp_Torus.hxx>

#include "metron/stdlib/file_access.hpp"
#include "metron/stdlib/geometry/cad_import.hpp"

namespace metron::geometry {
namespace {

MeshError file_error(const std::string& path, const std::string& what) {
  // OCCT's failure texts carry object addresses ("0x55d4c3a1b2c0"): noise to a user, and they
  // make the message differ from run to run (issue 15).
  static const std::regex address("0x[0-9a-fA-F]{6,}");
  return MeshError{"'" + path + "': " + std::regex_replace(what, address, "<address>")};
}

Vec3 to_eigen(const gp_XYZ& p) { return {p.X(), p.Y(), p.Z()}; }

// Welds nodes closer than `tol` into one vertex, searching the grid cells that the box
// [p - tol, p + tol] overlaps (one cell but for nodes within tol of a cell wall). OCCT's
// Poly_MergeNodesTool hashes float coordinates for display, too coarse for measuring.
class Welder {
 public:
  explicit Welder(double tol) : m_tol(tol), m_cell(std::max(1e-5, 2 * tol)) {}

  std::uint32_t add(const Vec3& p) {
    const Cell lo = cell_of(p - Vec3::Constant(m_tol)), hi = cell_of(p + Vec3::Constant(m_tol));
    for (auto x = lo[0]; x <= hi[0]; ++x)
      for (auto y = lo[1]; y <= hi[1]; ++y)
        for (auto z = lo[2]; z <= hi[2]; ++z) {
          const auto it = m_grid.find(Cell{x, y, z});
          if (it == m_grid.end()) continue;
          for (std::uint32_t i : it->second)
            if ((m_points[i] - p).squaredNorm() <= m_tol * m_tol) return i;
        }
    const auto index = static_cast<std::uint32_t>(m_points.size());
    m_points.push_back(p);
    m_grid[cell_of(p)].push_back(index);
    return index;
  }
  std::vector<Vec3> take_points() { return std::move(m_points); }

 private:
  using Cell = std::array<std::int64_t, 3>;
  struct CellHash {
    std::size_t operator()(const Cell& c) const {
      std::size_t h = 0;
      for (auto v : c) h = h * 0x9E3779B97F4A7C15ull + static_cast<std::size_t>(v);
      return h;
    }
  };
  Cell cell_of(const Vec3& p) const {
    return {static_cast<std::int64_t>(std::floor(p.x() / m_cell)),
            static_cast<std::int64_t>(std::floor(p.y() / m_cell)),
            static_cast<std::int64_t>(std::floor(p.z() / m_cell))};
  }
  double m_tol, m_cell;
  std::vector<Vec3> m_points;
  std::unordered_map<Cell, std::vector<std::uint32_t>, CellHash> m_grid;
};

// What kind of analytic surface a face lies on. STEP names it; IGES mostly carries surfaces of
// revolution or extrusion and B-splines, which are recognised when they are exactly analytic.
void recognise(const GeomAdaptor_Surface& s, CadFace& out) {
  using Kind = CadFace::Kind;
  auto set = [&](Kind kind, const Vec3& origin, const Vec3& axis, double radius = 0, double minor = 0,
                 double semi_angle = 0) {
    out.kind = kind;
    out.origin = origin;
    out.axis = axis;
    out.radius_mm = radius;
    out.minor_radius_mm = minor;
    out.semi_angle_rad = semi_angle;
  };
  auto set_axis = [&](Kind kind, const gp_Ax3& ax) {
    set(kind, to_eigen(ax.Location().XYZ()), to_eigen(ax.Direction().XYZ()));
  };
  constexpr double tol = 1e-7;
  switch (s.GetType()) {
    case GeomAbs_Plane: set_axis(Kind::Plane, s.Plane().Position()); return;
    case GeomAbs_Cylinder:
      set_axis(Kind::Cylinder, s.Cylinder().Position());
      out.radius_mm = s.Cylinder().Radius();
      return;
    case GeomAbs_Cone:
      set_axis(Kind::Cone, s.Cone().Position());
      out.radius_mm = s.Cone().RefRadius();
      out.semi_angle_rad = s.Cone().SemiAngle();
      return;
    case GeomAbs_Sphere:
      set_axis(Kind::Sphere, s.Sphere().Position());
      out.radius_mm = s.Sphere().Radius();
      return;
    case GeomAbs_Torus:
      set_axis(Kind::Torus, s.Torus().Position());
      out.radius_mm = s.Torus().MajorRadius();
      out.minor_radius_mm = s.Torus().MinorRadius();
      return;
    case GeomAbs_SurfaceOfRevolution: {
      const gp_Ax1 ax = s.AxeOfRevolution();
      const Vec3 o = to_eigen(ax.Location().XYZ()), a = to_eigen(ax.Direction().XYZ());
      const Handle(Adaptor3d_Curve) c = s.BasisCurve();
      auto foot = [&](const Vec3& p) -> Vec3 { return o + (p - o).dot(a) * a; };
      if (c->GetType() == GeomAbs_Line) {
        const Vec3 p = to_eigen(c->Line().Location().XYZ());
        const Vec3 d = to_eigen(c->Line().Direction().XYZ());
        const Vec3 f = foot(p);
        const double radius = (p - f).norm();
        const double along = d.dot(a);
        if (a.cross(d).norm() < tol) {
          set(Kind::Cylinder, f, a, radius);
        } else if (std::abs(along) > tol && std::abs((p - f).cross(a).dot(d)) < tol) {
          // a line meeting the axis sweeps a cone; orient the axis so the radius grows along it
          const Vec3 radial = (p - f).normalized();
          const Vec3 axis = (d.dot(radial) / along > 0) ? a : Vec3(-a);
          const double angle = std::atan2(d.cross(a).norm(), std::abs(along));
          set(Kind::Cone, f, axis, radius, 0, angle);
        }
      } else if (c->GetType() == GeomAbs_Circle) {
        const gp_Circ circle = c->Circle();
        const Vec3 centre = to_eigen(circle.Location().XYZ());
        const Vec3 f = foot(centre);
        const double offset = (centre - f).norm();
        const bool meridian = std::abs(to_eigen(circle.Axis().Direction().XYZ()).dot(a)) < tol;
        if (offset < tol) {
          set(Kind::Sphere, f, a, circle.Radius());
        } else if (meridian) {
          set(Kind::Torus, f, a, offset, circle.Radius());
        }
      }
      return;
    }
    case GeomAbs_SurfaceOfExtrusion: {
      const Vec3 d = to_eigen(s.Direction().XYZ());
      const Handle(Adaptor3d_Curve) c = s.BasisCurve();
      if (c->GetType() == GeomAbs_Line) {
        const Vec3 n = to_eigen(c->Line().Direction().XYZ()).cross(d);
        if (n.norm() > tol) set(Kind::Plane, to_eigen(c->Line().Location().XYZ()), n.normalized());
      } else if (c->GetType() == GeomAbs_Circle) {
        const gp_Circ circle = c->Circle();
        const Vec3 a = to_eigen(circle.Axis().Direction().XYZ());
        if (a.cross(d).norm() < tol) set(Kind::Cylinder, to_eigen(circle.Location().XYZ()), a, circle.Radius());
      }
      return;
    }
    case GeomAbs_BezierSurface:
    case GeomAbs_BSplineSurface: {
      const GeomLib_IsPlanarSurface planar(s.Surface(), tol);
      if (planar.IsPlanar()) set_axis(Kind::Plane, planar.Plan().Position());
      return;
    }
    default: return;
  }
}

// Orients the description by the face's own outward normal at a sample point: a plane's axis
// becomes its outward normal; a curved face is `inner` when that normal points toward the axis
// (or centre, or tube centre line).
void orient(const TopoDS_Face& face, CadFace& out) {
  if (out.kind == CadFace::Kind::Other) return;
  const BRepAdaptor_Surface s(face, Standard_True);
  gp_Pnt p;
  gp_Vec du, dv;
  Vec3 n = Vec3::Zero();
  for (const double w : {0.5, 0.3, 0.7}) {  // avoid a pole or apex at the centre of the box
    s.D1(s.FirstUParameter() + w * (s.LastUParameter() - s.FirstUParameter()),
         s.FirstVParameter() + (1 - w) * (s.LastVParameter() - s.FirstVParameter()), p, du, dv);
    n = to_eigen(du.Crossed(dv).XYZ());
    if (n.norm() > 1e-12) break;
  }
  if (face.Orientation() == TopAbs_REVERSED) n = -n;
  const Vec3 q = to_eigen(p.XYZ()) - out.origin;
  Vec3 radial = q - q.dot(out.axis) * out.axis;
  switch (out.kind) {
    case CadFace::Kind::Plane:
      if (n.dot(out.axis) < 0) out.axis = -out.axis;
      return;
    case CadFace::Kind::Sphere: radial = q; break;
    case CadFace::Kind::Torus: radial -= out.radius_mm * radial.normalized(); break;
    default: break;
  }
  out.inner = n.dot(radial) < 0;
  if (out.kind == CadFace::Kind::Cone && out.semi_angle_rad < 0) {  // radius grows along +axis
    out.axis = -out.axis;
    out.semi_angle_rad = -out.semi_angle_rad;
  }
}

CadFace describe(const TopoDS_Face& face) {
  CadFace out;
  recognise(GeomAdaptor_Surface(BRep_Tool::Surface(face)), out);  // location already applied
  orient(face, out);
  return out;
}

// OCCT's readers report through the process-wide default messenger, which prints to stdout
// ("Total number of loaded entities", parser errors). metron uses OCCT only here, so that
// printer is replaced once by one that keeps the failures of the file being read on this
// thread, which then end up in the MeshError.
class FailureCollector : public Message_Printer {
 public:
  static inline thread_local std::string* sink = nullptr;

 protected:
  void send(const TCollection_AsciiString& text, const Message_Gravity gravity) const override {
    if (sink == nullptr || gravity < Message_Fail) return;
    std::string line = text.ToCString();
    const auto keep = [](unsigned char c) { return !std::isspace(c) && c != '*'; };
    line.erase(line.begin(), std::find_if(line.begin(), line.end(), keep));
    line.erase(std::find_if(line.rbegin(), line.rend(), keep).base(), line.end());
    if (line.empty() || sink->find(line) != std::string::npos) return;
    if (!sink->empty()) *sink += "; ";
    *sink += line;
  }
};

void redirect_occt_messages() {
  static std::once_flag once;
  std::call_once(once, [] {
    const Handle(Message_Messenger)& messenger = Message::DefaultMessenger();
    messenger->RemovePrinters(STANDARD_TYPE(Message_PrinterOStream));
    messenger->AddPrinter(new FailureCollector());
  });
}

tl::expected<TopoDS_Shape, MeshError> read_shape(const std::string& path, const std::string& ext) {
  const bool step = ext == ".step" || ext == ".stp";
  IFSelect_ReturnStatus status = IFSelect_RetVoid;
  TopoDS_Shape shape;
  std::string failures;
  FailureCollector::sink = &failures;
  struct Reset {
    ~Reset() { FailureCollector::sink = nullptr; }
  } reset;
  if (step) {
    STEPControl_Reader reader;
    status = reader.ReadFile(path.c_str());
    if (status == IFSelect_RetDone) {
      reader.TransferRoots();
      shape = reader.OneShape();
    }
  } else {
    IGESControl_Reader reader;
    status = reader.ReadFile(path.c_str());
    if (status == IFSelect_RetDone) {
      reader.TransferRoots();
      shape = reader.OneShape();
    }
  }
  if (status != IFSelect_RetDone)
    return tl::unexpected(file_error(path, std::string("could not be parsed as ") + (step ? "STEP" : "IGES") +
                                               (failures.empty() ? "" : ": " + failures)));
  if (shape.IsNull() || !TopExp_Explorer(shape, TopAbs_FACE).More())
    return tl::unexpected(file_error(path, "contains no surfaces"));
  if (TopExp_Explorer(shape, TopAbs_SOLID).More()) return shape;
  // IGES usually carries loose trimmed surfaces (STEP may too). Faces that share no edges are
  // tessellated independently and leave cracks, so sew them into shells, then turn each closed
  // shell into a solid, which ShapeFix orients outward.
  BRepBuilderAPI_Sewing sewing(0.01);
  sewing.Load(shape);
  sewing.Perform();
  if (sewing.SewedShape().IsNull()) return shape;
  TopoDS_Compound parts;
  BRep_Builder builder;
  builder.MakeCompound(parts);
  for (TopExp_Explorer e(sewing.SewedShape(), TopAbs_SHELL); e.More(); e.Next()) {
    const TopoDS_Shell& shell = TopoDS::Shell(e.Current());
    if (BRep_Tool::IsClosed(shell))
      builder.Add(parts, ShapeFix_Solid().SolidFromShell(shell));
    else
      builder.Add(parts, shell);
  }
  for (TopExp_Explorer e(sewing.SewedShape(), TopAbs_FACE, TopAbs_SHELL); e.More(); e.Next())
    builder.Add(parts, e.Current());  // faces left outside any shell
  return TopoDS_Shape(parts);
}

tl::expected<CadModel, MeshError> tessellate(const std::string& path, const TopoDS_Shape& shape,
                                             const TessellationOptions& options) {
  IMeshTools_Parameters parameters;
  parameters.Deflection = options.chord_tolerance_mm;
  parameters.Angle = options.angular_tolerance_rad;
  parameters.Relative = Standard_False;
  parameters.InParallel = options.parallel;
  BRepMesh_IncrementalMesh mesher(shape, parameters);

  TopTools_IndexedMapOfShape face_map;
  TopExp::MapShapes(shape, TopAbs_FACE, face_map);
  // Nodes on an edge shared by two faces come from the edge's one discretisation, so they
  // coincide exactly; the weld tolerance only absorbs rounding in location transforms. (A
  // looser one, 1e-6 mm, already fuses distinct nodes of the DCX IGES into non-manifold fans.)
  Welder welder(1e-9);
  std::vector<Mesh::Face> triangles;
  std::vector<CadFace> faces;
  faces.reserve(static_cast<std::size_t>(face_map.Extent()));
  for (int i = 1; i <= face_map.Extent(); ++i) {
    const TopoDS_Face& face = TopoDS::Face(face_map(i));
    CadFace& info = faces.emplace_back(describe(face));
    info.shape_index = static_cast<std::uint32_t>(i);
    TopLoc_Location location;
    const Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(face, location);
    if (tri.IsNull() || tri->NbTriangles() == 0)
      return tl::unexpected(file_error(path, "BRepMesh produced no triangles for face " + std::to_string(i) + " of " +
                                                 std::to_string(face_map.Extent())));
    const gp_Trsf trsf = location.Transformation();
    std::vector<std::uint32_t> node_index(static_cast<std::size_t>(tri->NbNodes()) + 1);
    for (int n = 1; n <= tri->NbNodes(); ++n)
      node_index[static_cast<std::size_t>(n)] = welder.add(to_eigen(tri->Node(n).Transformed(trsf).XYZ()));
    const bool reversed = face.Orientation() == TopAbs_REVERSED;
    for (int t = 1; t <= tri->NbTriangles(); ++t) {
      int n1 = 0, n2 = 0, n3 = 0;
      tri->Triangle(t).Get(n1, n2, n3);
      if (reversed) std::swap(n2, n3);
      const Mesh::Face f{node_index[static_cast<std::size_t>(n1)], node_index[static_cast<std::size_t>(n2)],
                         node_index[static_cast<std::size_t>(n3)]};
      if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;  // collapsed by the weld
      info.triangles.push_back(static_cast<std::uint32_t>(triangles.size()));
      triangles.push_back(f);
    }
  }
  auto mesh = Mesh::from_triangles(welder.take_points(), std::move(triangles));
  if (!mesh) return tl::unexpected(file_error(path, mesh.error().message));
  return CadModel{std::move(*mesh), std::move(faces)};
}

}  // namespace

tl::expected<CadModel, MeshError> load_cad_model(const std::string& path, const TessellationOptions& options) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext != ".step" && ext != ".stp" && ext != ".iges" && ext != ".igs")
    return tl::unexpected(
        file_error(path, "unsupported CAD format '" + ext + "' (expected .step, .stp, .iges or .igs)"));
  if (!std::ifstream(path)) return tl::unexpected(file_error(path, "cannot open file"));
  // A device named like a mesh (/dev/zero as part.stl) would never end: regular files within the
  // input cap only (docs/security.md).
  if (auto refused = refuse_input_file(path)) return tl::unexpected(MeshError{*refused});
  if (!(options.chord_tolerance_mm > 0) || !(options.angular_tolerance_rad > 0))
    return tl::unexpected(file_error(path, "tessellation tolerances must be positive"));
  redirect_occt_messages();
  try {
    auto shape = read_shape(path, ext);
    if (!shape) return tl::unexpected(shape.error());
    return tessellate(path, *shape, options);
  } catch (const Standard_Failure& e) {  // OCCT reports malformed input by throwing
    return tl::unexpected(file_error(path, std::string("OpenCASCADE failed: ") + e.GetMessageString()));
  }
}

tl::expected<Mesh, MeshError> load_cad(const std::string& path, const TessellationOptions& options) {
  auto model = load_cad_model(path, options);
  if (!model) return tl::unexpected(model.error());
  return std::move(model->mesh);
}

}  // namespace metron::geometry
