// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/mesh_solid.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <unordered_map>

namespace metron::machine {
namespace {

using Kind = geometry::CadFace::Kind;

// Below this a direction from an axis or centre is undefined; the mesh's normal is used there.
constexpr double degenerate_mm = 1e-9;

}  // namespace

MeshSolid::MeshSolid(std::shared_ptr<const geometry::Mesh> mesh, const Frame& part_to_machine, std::vector<Bump> bumps,
                     const std::vector<geometry::CadFace>& faces, double chord_tolerance_mm)
    : m_mesh(std::move(mesh)),
      m_part_to_machine(part_to_machine),
      m_machine_to_part(part_to_machine.inverse(Eigen::Isometry)),
      m_bumps(std::move(bumps)) {
  if (!m_mesh) throw std::invalid_argument("MeshSolid needs a mesh");
  // A Gaussian's steepest slope is amplitude / sigma * exp(-1/2).
  for (const Bump& b : m_bumps) m_lipschitz += std::abs(b.amplitude_mm) / b.sigma_mm * std::exp(-0.5);
  if (faces.empty()) return;

  // Inside a face the closest triangle is at most a chord's sagitta from the surface, so the
  // exact and the mesh distance differ by about the chord tolerance there (1.2 um seen on the DCX
  // part, hence the margin); a larger difference means the closest point is at the face's
  // boundary, where the untrimmed surface can pass much nearer than the face (or on the wrong
  // side), and the mesh's answer is kept.
  m_guard_mm = 1.5 * chord_tolerance_mm + 1e-7;
  const std::size_t n_triangles = m_mesh->face_count();
  m_surface_of_triangle.assign(n_triangles, -1);
  m_shape_of_triangle.assign(n_triangles, 0);
  const auto& vertices = m_mesh->vertices();
  const auto& triangles = m_mesh->faces();
  // Nodes inside a face lie on its surface to rounding; nodes on its boundary come from the edge
  // curves and may be off by the model's edge tolerance (the DCX part: up to 0.94 um).
  constexpr std::uint32_t unowned = 0, shared = ~0u;
  std::vector<std::uint32_t> owner(vertices.size(), unowned);  // the one face using a node
  for (const geometry::CadFace& f : faces)
    for (std::uint32_t t : f.triangles)
      if (t < n_triangles)
        for (std::uint32_t v : triangles[t])
          owner[v] = owner[v] == unowned || owner[v] == f.shape_index ? f.shape_index : shared;
  const double interior_mm = 1e-6, boundary_mm = 10 * chord_tolerance_mm;
  for (const geometry::CadFace& f : faces) {
    for (std::uint32_t t : f.triangles)
      if (t < n_triangles) m_shape_of_triangle[t] = f.shape_index;
    auto surface = surface_of(f);
    if (!surface || f.triangles.empty()) continue;
    Surface& s = *surface;
    // Trust the description only if the face's triangles lie on it, and orient it like them
    // (a plane's normal and a curved face's side agree with the mesh's outward winding).
    bool on_surface = true;
    double facing = 0;
    for (std::uint32_t t : f.triangles) {
      if (t >= n_triangles) {
        on_surface = false;
        break;
      }
      const auto& tri = triangles[t];
      Vec3 centroid = Vec3::Zero();
      for (std::uint32_t v : tri) {
        const auto e = exact(s, vertices[v]);
        if (e && std::abs(e->distance_mm) > (owner[v] == f.shape_index ? interior_mm : boundary_mm)) on_surface = false;
        centroid += vertices[v] / 3;
      }
      if (!on_surface) break;
      if (const auto e = exact(s, centroid)) facing += e->normal.dot(m_mesh->face_normal(t));
    }
    if (!on_surface || facing == 0) continue;
    if (facing < 0) {
      if (s.kind == Kind::Plane)
        s.axis = -s.axis;
      else
        s.inner = !s.inner;
    }
    for (std::uint32_t t : f.triangles) m_surface_of_triangle[t] = static_cast<std::int32_t>(m_surfaces.size());
    m_surfaces.push_back(s);
  }
}

std::optional<MeshSolid::Surface> MeshSolid::surface_of(const geometry::CadFace& f) {
  Surface s;
  s.kind = f.kind;
  s.origin = f.origin;
  s.axis = f.axis.normalized();
  s.radius_mm = f.radius_mm;
  s.minor_radius_mm = f.minor_radius_mm;
  s.inner = f.inner;
  switch (f.kind) {
    case Kind::Plane:
    case Kind::Cylinder:
    case Kind::Sphere:
    case Kind::Torus: return s;
    case Kind::Cone:
      if (!(f.semi_angle_rad > 1e-9 && f.semi_angle_rad < std::numbers::pi / 2 - 1e-9)) return std::nullopt;
      s.cos_a = std::cos(f.semi_angle_rad);
      s.sin_a = std::sin(f.semi_angle_rad);
      s.origin = f.origin - f.radius_mm / std::tan(f.semi_angle_rad) * s.axis;  // the apex
      return s;
    case Kind::Other: break;
  }
  return std::nullopt;
}

std::optional<MeshSolid::Exact> MeshSolid::exact(const Surface& s, const Vec3& q) {
  const Vec3 r = q - s.origin;
  const double h = r.dot(s.axis);
  const Vec3 radial = r - h * s.axis;
  const double rho = radial.norm();
  Exact e{0, Vec3::Zero()};
  switch (s.kind) {
    case Kind::Plane: e = {h, s.axis}; break;
    case Kind::Cylinder:
      if (rho < degenerate_mm) return std::nullopt;
      e = {rho - s.radius_mm, radial / rho};
      break;
    case Kind::Sphere: {
      const double d = r.norm();
      if (d < degenerate_mm) return std::nullopt;
      e = {d - s.radius_mm, r / d};
      break;
    }
    case Kind::Cone: {
      // In the half-plane through the axis: the generator from the apex at the semi-angle, or
      // the apex itself behind it (one nappe, the one the face lies on).
      if (h * s.cos_a + rho * s.sin_a <= 0) {
        const double d = r.norm();
        if (d < degenerate_mm) return std::nullopt;
        e = {d, r / d};
      } else {
        if (rho < degenerate_mm) return std::nullopt;
        e = {rho * s.cos_a - h * s.sin_a, s.cos_a * radial / rho - s.sin_a * s.axis};
      }
      break;
    }
    case Kind::Torus: {
      if (rho < degenerate_mm) return std::nullopt;
      const Vec3 w = r - s.radius_mm / rho * radial;  // from the tube's centre circle
      const double d = w.norm();
      if (d < degenerate_mm) return std::nullopt;
      e = {d - s.minor_radius_mm, w / d};
      break;
    }
    case Kind::Other: return std::nullopt;
  }
  if (s.inner) e = {-e.distance_mm, -e.normal};
  return e;
}

namespace {
std::atomic<bool> coherent_search{true};
}  // namespace

void MeshSolid::set_coherent_search(bool on) { coherent_search.store(on, std::memory_order_relaxed); }
bool MeshSolid::coherent_search_enabled() { return coherent_search.load(std::memory_order_relaxed); }

// ---- local views ----------------------------------------------------------------------------

// Triangles binned by their boxes on a hierarchy of uniform grids (each level's cells 8 times
// the previous one's): a triangle sits on the first level where its box covers at most 4 cells
// along each axis, so big faces of a CAD tessellation cost no more than small ones.
struct MeshSolid::Grid {
  struct Entry {
    std::uint32_t face;
    Eigen::Vector3i lo;  ///< the first cell of its box: reported only from there (no repeats)
  };
  struct Level {
    double cell_mm = 1;
    std::unordered_map<std::uint64_t, std::vector<Entry>> cells;  ///< while building
    // Then an open-addressing table (linear probing, at most half full) of the occupied cells,
    // each a range of `entries`: a lookup of an empty cell, the usual case, is a probe or two.
    std::vector<std::uint64_t> slot_key;  ///< empty_key: free
    std::vector<std::uint32_t> slot_begin, slot_end;
    std::vector<Entry> entries;
    std::uint64_t mask = 0;
    int shift = 64;

    static constexpr std::uint64_t empty_key = ~std::uint64_t{0};
    [[nodiscard]] std::size_t slot_of(std::uint64_t k) const {
      return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ull) >> shift);
    }
    void freeze() {
      std::size_t n = 2;
      int bits = 1;
      while (n < 2 * cells.size()) n *= 2, ++bits;
      shift = 64 - bits;
      mask = n - 1;
      slot_key.assign(n, empty_key);
      slot_begin.assign(n, 0);
      slot_end.assign(n, 0);
      for (auto& [k, list] : cells) {
        std::size_t i = slot_of(k);
        while (slot_key[i] != empty_key) i = (i + 1) & mask;
        slot_key[i] = k;
        slot_begin[i] = static_cast<std::uint32_t>(entries.size());
        entries.insert(entries.end(), list.begin(), list.end());
        slot_end[i] = static_cast<std::uint32_t>(entries.size());
      }
      cells = {};
    }
    /// The cell's entries in the order they were added (empty if none).
    [[nodiscard]] std::pair<const Entry*, const Entry*> find(std::uint64_t k) const {
      for (std::size_t i = slot_of(k);; i = (i + 1) & mask) {
        if (slot_key[i] == k) return {entries.data() + slot_begin[i], entries.data() + slot_end[i]};
        if (slot_key[i] == empty_key) return {nullptr, nullptr};
      }
    }
  };
  Vec3 origin = Vec3::Zero();
  std::vector<Level> levels;

  [[nodiscard]] Eigen::Vector3i cell(const Level& l, const Vec3& p) const {
    return ((p - origin) / l.cell_mm).array().floor().cast<int>();
  }
  static std::uint64_t key(const Eigen::Vector3i& c) {
    const auto part = [](int v) {
      return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v + (1 << 20)) & 0x1fffff);
    };
    return part(c.x()) | part(c.y()) << 21 | part(c.z()) << 42;
  }
  /// Every triangle whose box meets the box [lo, hi], once each.
  template <class F>
  void visit(const Vec3& lo, const Vec3& hi, F&& f) const {
    for (const Level& l : levels) {
      const Eigen::Vector3i a = cell(l, lo), b = cell(l, hi);
      for (int x = a.x(); x <= b.x(); ++x)
        for (int y = a.y(); y <= b.y(); ++y)
          for (int z = a.z(); z <= b.z(); ++z) {
            const auto [first, last] = l.find(key({x, y, z}));
            for (const Entry* e = first; e != last; ++e)
              if (Eigen::Vector3i(x, y, z) == e->lo.cwiseMax(a)) f(e->face);
          }
    }
  }
};

const MeshSolid::Grid& MeshSolid::grid() const {
  std::call_once(*m_grid_once, [this] {
    auto g = std::make_shared<Grid>();
    const auto& v = m_mesh->vertices();
    const auto& f = m_mesh->faces();
    const Eigen::AlignedBox3d box = m_mesh->bounds();
    double extent = 0;
    for (const auto& t : f) {
      Eigen::AlignedBox3d b(v[t[0]]);
      b.extend(v[t[1]]).extend(v[t[2]]);
      extent += b.sizes().maxCoeff();
    }
    // The finest level: about two typical triangles across a cell; coarser levels up to the box.
    double cell = std::max(
        {2 * extent / static_cast<double>(std::max<std::size_t>(1, f.size())), box.sizes().maxCoeff() / 4000, 1e-3});
    g->origin = box.min();
    do {
      g->levels.emplace_back().cell_mm = cell;
      cell *= 8;
    } while (g->levels.back().cell_mm < box.sizes().maxCoeff());
    for (std::uint32_t i = 0; i < f.size(); ++i) {
      if (m_mesh->face_normal(i).isZero()) continue;  // zero-area: never an answer
      Eigen::AlignedBox3d b(v[f[i][0]]);
      b.extend(v[f[i][1]]).extend(v[f[i][2]]);
      for (std::size_t k = 0; k < g->levels.size(); ++k) {
        Grid::Level& l = g->levels[k];
        const Eigen::Vector3i lo = g->cell(l, b.min()), hi = g->cell(l, b.max());
        if ((hi - lo).maxCoeff() > 3 && k + 1 < g->levels.size()) continue;
        for (int x = lo.x(); x <= hi.x(); ++x)
          for (int y = lo.y(); y <= hi.y(); ++y)
            for (int z = lo.z(); z <= hi.z(); ++z) l.cells[Grid::key({x, y, z})].push_back({i, lo});
        break;
      }
    }
    for (Grid::Level& l : g->levels) l.freeze();
    m_grid = std::move(g);
  });
  return *m_grid;
}

namespace {

// The point of triangle abc closest to p, by the Voronoi regions of its vertices, edges and face
// (C. Ericson, "Real-Time Collision Detection", 2005, section 5.1.5).
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

}  // namespace

// The triangles that can be closest to a query near the centre. Exactness: every other
// triangle's box misses the ball of radius `reach` about the centre, so a candidate closer to q
// than reach - |q - centre| is the mesh's closest; otherwise the whole mesh is asked.
class MeshSolid::Local final : public Solid {
 public:
  Local(const MeshSolid& solid, const Vec3& centre_mm, double radius_mm)
      : m_solid(solid), m_centre(solid.m_machine_to_part * centre_mm) {
    const geometry::Mesh& mesh = *solid.m_mesh;
    m_reach = radius_mm;
    const Vec3 r = Vec3::Constant(m_reach);
    const auto& v = mesh.vertices();
    m_tris.reserve(256);
    solid.grid().visit(m_centre - r, m_centre + r, [&](std::uint32_t i) {
      const auto& f = mesh.faces()[i];
      Eigen::AlignedBox3d b(v[f[0]]);
      b.extend(v[f[1]]).extend(v[f[2]]);
      if (b.squaredExteriorDistance(m_centre) > m_reach * m_reach) return;
      Tri& t = m_tris.emplace_back(Tri{v[f[0]], v[f[1]], v[f[2]], Vec3::Zero(), 0, mesh.face_normal(i), f, i});
      t.centroid = (t.a + t.b + t.c) / 3;
      // sqrt is monotonic and correctly rounded: the same as the largest of the three norms.
      t.radius = std::sqrt(std::max(
          {(t.a - t.centroid).squaredNorm(), (t.b - t.centroid).squaredNorm(), (t.c - t.centroid).squaredNorm()}));
    });
  }

  [[nodiscard]] double signed_distance(const Vec3& p) const override {
    const Vec3 q = m_solid.m_machine_to_part * p;
    const Contact c = m_solid.contact_from(q, closest(q), true, this);
    return c.distance_mm - m_solid.bump_height(c.point);
  }
  [[nodiscard]] Vec3 normal(const Vec3& p) const override {
    const Vec3 q = m_solid.m_machine_to_part * p;
    return m_solid.m_part_to_machine.linear() * m_solid.contact_from(q, closest(q), false, this).normal;
  }
  [[nodiscard]] double lipschitz() const override { return m_solid.lipschitz(); }
  [[nodiscard]] std::string feature_at(const Vec3& p) const override { return m_solid.feature_at(p); }

  // Inside test at an edge or vertex by the angle-weighted pseudo-normal, exact for a closed
  // mesh (J. A. Baerentzen, H. Aanaes, "Signed distance computation using the angle weighted
  // pseudonormal", IEEE TVCG 11(3), 2005); the faces around the closest point are all local.
  [[nodiscard]] bool inside(const Vec3& q, const geometry::Mesh::Closest& c) const {
    // The side cannot change within the distance of the last query decided here: the ball of
    // that radius about it holds no surface.
    const bool coherent = coherent_search_enabled();
    if (coherent && m_side_radius > 0 && (q - m_side_point).norm() + anchor_slack_mm < m_side_radius)
      return m_side_inside;
    const bool in = inside_by_pseudo_normal(q, c);
    if (coherent) m_side_point = q, m_side_radius = c.distance_mm, m_side_inside = in;
    return in;
  }

  [[nodiscard]] bool inside_by_pseudo_normal(const Vec3& q, const geometry::Mesh::Closest& c) const {
    const auto& mesh = *m_solid.m_mesh;
    const auto& f = mesh.faces()[c.face];
    const auto& v = mesh.vertices();
    const double tol = 1e-9 * (1 + c.point.cwiseAbs().maxCoeff());
    Vec3 pn = Vec3::Zero();
    int vertex = -1;
    for (int k = 0; k < 3; ++k)
      if ((v[f[k]] - c.point).norm() <= tol) vertex = static_cast<int>(f[k]);
    // Every triangle through the closest point is as near q as it is, so it is among the last
    // search's candidates; the others add nothing, so the sums are the same as over all.
    if (vertex >= 0) {
      each_candidate([&](const Tri& t) {
        for (int k = 0; k < 3; ++k)
          if (static_cast<int>(t.v[k]) == vertex) {
            const Vec3 e1 = (v[t.v[(k + 1) % 3]] - v[t.v[k]]).normalized(),
                       e2 = (v[t.v[(k + 2) % 3]] - v[t.v[k]]).normalized();
            pn += std::acos(std::clamp(e1.dot(e2), -1.0, 1.0)) * mesh.face_normal(t.face);
          }
      });
    } else {
      pn = mesh.face_normal(c.face);  // inside the face: its own side (rounding missed the normal line)
      for (int k = 0; k < 3; ++k) {
        const Vec3 a = v[f[k]], b = v[f[(k + 1) % 3]];
        const double s = std::clamp((c.point - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
        if ((a + s * (b - a) - c.point).norm() > tol) continue;
        pn = Vec3::Zero();
        each_candidate([&](const Tri& t) {
          const auto has = [&](std::uint32_t x) { return t.v[0] == x || t.v[1] == x || t.v[2] == x; };
          if (has(f[k]) && has(f[(k + 1) % 3])) pn += mesh.face_normal(t.face);
        });
        break;
      }
    }
    if (pn.norm() < 1e-12) return mesh.contains(q);
    return (q - c.point).dot(pn) < 0;
  }

 private:
  struct Tri {
    Vec3 a, b, c;
    Vec3 centroid;
    double radius;  ///< of the bounding sphere (and circle) about the centroid
    Vec3 normal;    ///< unit, of its plane
    geometry::Mesh::Face v;
    std::uint32_t face;
  };

  [[nodiscard]] geometry::Mesh::Closest closest(const Vec3& q) const {
    if (m_last && q == m_last_query) return *m_last;  // a distance and a normal at one point
    m_last_query = q;
    m_last = search(q);
    return *m_last;
  }

  // An anchor: the view's triangles within `limit` of its point, sorted by their distance from
  // it. Exactness: a query q at delta from the point needs only those whose key - delta is below
  // the best distance found (a triangle's distance from q is at least key - delta), and the
  // answer holds if it is below limit - delta (every triangle left out is farther). Ties go as
  // in the full search, to the hint, else to the first in m_tris order, so both give the same.
  struct Anchor {
    Vec3 point = Vec3::Zero();
    double limit = 0;
    std::vector<std::pair<double, std::uint32_t>> tris;  ///< (distance from point, index into m_tris)
    std::uint64_t used = 0;                              ///< last use (0: empty), for replacing the oldest
  };
  static constexpr double anchor_margin_mm = 0.15;  // limit - distance at the point (tuned by instruction count)
  // Covers rounding in the distances (1e-13 mm) and inside()'s vertex tolerance (1e-9 relative).
  static constexpr double anchor_slack_mm = 1e-5;

  template <class F>
  void each_candidate(F&& f) const {
    if (!m_last_anchor) {
      for (const Tri& t : m_tris) f(t);
      return;
    }
    // The anchored search's candidates in m_tris order, so sums run in the full search's order.
    m_scratch.clear();
    for (std::size_t k = 0; k < m_last_visited; ++k) m_scratch.push_back(m_last_anchor->tris[k].second);
    std::sort(m_scratch.begin(), m_scratch.end());
    for (std::uint32_t i : m_scratch) f(m_tris[i]);
  }

  [[nodiscard]] geometry::Mesh::Closest search(const Vec3& q) const {
    m_last_anchor = nullptr;
    if (m_tris.empty()) return m_solid.m_mesh->closest(q);
    // Start from the previous answer's triangle (the probe moves um per query): its distance
    // prunes almost every other triangle by its bounding sphere, without a square root.
    const std::size_t hint = std::min(m_hint, m_tris.size() - 1);
    std::size_t best = hint;
    Vec3 point = closest_on_triangle(q, m_tris[hint].a, m_tris[hint].b, m_tris[hint].c);
    double best_d = (q - point).norm();
    const double off_centre = (q - m_centre).norm();
    bool done = false;
    // The search over an anchor's candidates for q at delta from its point; false (and the start
    // restored) when its answer is not provable there.
    const auto anchored = [&](Anchor& anchor, double delta) {
      std::size_t k = 0;
      for (; k < anchor.tris.size(); ++k) {
        const auto [key, i] = anchor.tris[k];
        if (key - delta > best_d + anchor_slack_mm) break;
        const Tri& t = m_tris[i];
        // The full search's tests, with ties let through.
        const Vec3 w = q - t.centroid;
        const double reach = best_d + t.radius, dc2 = w.squaredNorm();
        if (dc2 > reach * reach) continue;
        const double h = w.dot(t.normal), h2 = h * h, best2 = best_d * best_d;
        if (h2 > best2) continue;
        const double e = std::sqrt(std::max(0.0, dc2 - h2)) - t.radius;
        if (e > 0 && h2 + e * e > best2) continue;
        const Vec3 p = closest_on_triangle(q, t.a, t.b, t.c);
        const double d = (q - p).norm();
        if (d < best_d || (d == best_d && best != hint && i < best)) best_d = d, best = i, point = p;
      }
      if (best_d + anchor_slack_mm < anchor.limit - delta) {
        m_last_anchor = &anchor;
        m_last_visited = k;
        anchor.used = ++m_clock;
        return true;
      }
      best = hint;
      point = closest_on_triangle(q, m_tris[hint].a, m_tris[hint].b, m_tris[hint].c);
      best_d = (q - point).norm();
      return false;
    };
    if (coherent_search_enabled()) {
      // The nearest anchor, if any; else (or if it cannot prove the answer) a new one at q, whose
      // limit is set from the start's distance, an upper bound of q's.
      Anchor* anchor = nullptr;
      double delta2 = 0;
      for (Anchor& a : m_anchors)
        if (a.used > 0)
          if (const double dl2 = (q - a.point).squaredNorm(); !anchor || dl2 < delta2) anchor = &a, delta2 = dl2;
      const double delta = std::sqrt(delta2);
      if (anchor && best_d + delta < anchor->limit) done = anchored(*anchor, delta);
      // The first query of a view starts from an arbitrary triangle: a full search first.
      if (!done && m_clock > 0)
        if (Anchor* fresh = add_anchor(q, best_d, off_centre)) done = anchored(*fresh, 0);
    }
    if (!done)
      for (std::size_t i = 0; i < m_tris.size(); ++i) {
        const Tri& t = m_tris[i];
        const Vec3 w = q - t.centroid;
        const double reach = best_d + t.radius, dc2 = w.squaredNorm();
        if (dc2 >= reach * reach) continue;  // its bounding sphere
        // Its plane, then the plane distance with the in-plane distance to its bounding circle.
        const double h = w.dot(t.normal), h2 = h * h, best2 = best_d * best_d;
        if (h2 >= best2) continue;
        const double e = std::sqrt(std::max(0.0, dc2 - h2)) - t.radius;
        if (e > 0 && h2 + e * e >= best2) continue;
        const Vec3 p = closest_on_triangle(q, t.a, t.b, t.c);
        const double d = (q - p).norm();
        if (d < best_d) best_d = d, best = i, point = p;
      }
    m_hint = best;
    const double d = best_d;
    if (d + off_centre > m_reach) {
      m_last_anchor = nullptr;
      return m_solid.m_mesh->closest(q);
    }
    if (!done && m_clock == 0 && coherent_search_enabled()) (void)add_anchor(q, d, off_centre);
    // The same normal as geometry::Mesh::closest gives.
    const Tri& bt = m_tris[best];
    geometry::Mesh::Closest c{point, m_solid.m_mesh->face_normal(bt.face), d, bt.face};
    if (d > 0) {
      const Vec3 u = (q - point) / d;
      const double cos_angle = u.dot(c.normal);
      if (std::abs(cos_angle) < 1 - 1e-9) c.normal = cos_angle < 0 ? Vec3(-u) : u;
    }
    return c;
  }

  // An anchor at q, where the mesh is at most d_max away, in place of the least recently used
  // one; its limit stays where the view holds every triangle (within m_reach of the centre).
  Anchor* add_anchor(const Vec3& q, double d_max, double off_centre) const {
    const double limit = std::min(d_max + anchor_margin_mm, m_reach - off_centre);
    if (!(limit > d_max + 2 * anchor_slack_mm)) return nullptr;
    Anchor* slot = &m_anchors[0];
    for (Anchor& a : m_anchors)
      if (a.used < slot->used) slot = &a;
    slot->point = q;
    slot->limit = limit;
    slot->used = ++m_clock;
    slot->tris.clear();
    for (std::size_t i = 0; i < m_tris.size(); ++i) {
      const Tri& t = m_tris[i];
      const double reach = limit + t.radius;
      if ((q - t.centroid).squaredNorm() > reach * reach) continue;
      const double dt = (q - closest_on_triangle(q, t.a, t.b, t.c)).norm();
      if (dt <= limit) slot->tris.emplace_back(dt, static_cast<std::uint32_t>(i));
    }
    std::sort(slot->tris.begin(), slot->tris.end());
    return slot;
  }

  const MeshSolid& m_solid;
  Vec3 m_centre;       ///< part coordinates
  double m_reach = 0;  ///< every triangle outside the candidates is farther than this from the centre
  std::vector<Tri> m_tris;
  mutable std::size_t m_hint = 0;           ///< index of the last answer's triangle
  mutable std::array<Anchor, 3> m_anchors;  ///< for the head and the ball centre, and one spare
  mutable std::uint64_t m_clock = 0;
  mutable const Anchor* m_last_anchor = nullptr;  ///< the last search's; null: it went over all
  mutable std::size_t m_last_visited = 0;         ///< how many of its triangles it visited
  mutable std::vector<std::uint32_t> m_scratch;
  mutable Vec3 m_side_point = Vec3::Zero();  ///< the last query whose side inside() decided
  mutable double m_side_radius = 0;          ///< its distance from the mesh (0: none yet)
  mutable bool m_side_inside = false;
  mutable Vec3 m_last_query = Vec3::Zero();
  mutable std::optional<geometry::Mesh::Closest> m_last;
};

MeshSolid::Contact MeshSolid::contact(const Vec3& q, bool need_sign) const {
  return contact_from(q, m_mesh->closest(q), need_sign, nullptr);
}

MeshSolid::Contact MeshSolid::contact_from(const Vec3& q, const geometry::Mesh::Closest& c, bool need_sign,
                                           const Local* local) const {
  // When the closest point is inside a triangle, the query lies on its normal line and the side
  // is the sign of the offset; at edges and vertices the face normal does not decide it.
  const double along = (q - c.point).dot(m_mesh->face_normal(c.face));
  const bool on_normal_line =
      c.distance_mm > 1e-9 && std::abs(std::abs(along) - c.distance_mm) < 1e-12 * (1 + c.distance_mm);
  const std::int32_t si = m_surface_of_triangle.empty() ? -1 : m_surface_of_triangle[c.face];
  if (si >= 0) {
    if (const auto e = exact(m_surfaces[static_cast<std::size_t>(si)], q)) {
      // Consistent with the mesh distance of either sign unless the side is known; near the
      // surface (both within the guard) the exact side is the better one.
      const double outside = c.distance_mm, inside = -c.distance_mm;
      const bool match = on_normal_line ? std::abs(e->distance_mm - (along < 0 ? inside : outside)) <= m_guard_mm
                                        : std::min(std::abs(e->distance_mm - outside),
                                                   std::abs(e->distance_mm - inside)) <= m_guard_mm;
      if (match) return {e->distance_mm, e->normal, q - e->distance_mm * e->normal};
    }
  }
  double d = c.distance_mm;
  if (need_sign && (on_normal_line ? along < 0 : local ? local->inside(q, c) : m_mesh->contains(q))) d = -d;
  return {d, c.normal, c.point};
}

double MeshSolid::bump_height(const Vec3& surface_point) const {
  double h = 0;
  for (const Bump& b : m_bumps)
    h += b.amplitude_mm * std::exp(-(surface_point - b.centre_mm).squaredNorm() / (2 * b.sigma_mm * b.sigma_mm));
  return h;
}

double MeshSolid::signed_distance(const Vec3& p) const {
  const Contact c = contact(m_machine_to_part * p, true);
  return c.distance_mm - bump_height(c.point);
}

Vec3 MeshSolid::normal(const Vec3& p) const {
  // The surface's (or the mesh's contact) normal; the bumps' slope is neglected.
  return m_part_to_machine.linear() * contact(m_machine_to_part * p, false).normal;
}

std::string MeshSolid::feature_at(const Vec3& p) const {
  const std::uint32_t t = m_mesh->closest(m_machine_to_part * p).face;
  if (!m_shape_of_triangle.empty() && m_shape_of_triangle[t] != 0)
    return "face " + std::to_string(m_shape_of_triangle[t]);
  return "face " + std::to_string(t);
}

std::unique_ptr<Solid> MeshSolid::local_view(const Vec3& centre_mm, double radius_mm) const {
  return std::make_unique<Local>(*this, centre_mm, radius_mm);
}

}  // namespace metron::machine
