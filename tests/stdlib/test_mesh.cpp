// SPDX-License-Identifier: GPL-3.0-or-later
// Oracle tests for the CGAL/OCCT geometry facade: synthetic meshes against analytic answers,
// file round trips, and the NIST CAD parts against facts read independently from the DMIS
// programs that inspect them.
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <unistd.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

#include "metron/stdlib/geometry/cad_import.hpp"
#include "metron/stdlib/geometry/mesh.hpp"

namespace {

using metron::Frame;
using metron::Vec3;
using metron::geometry::CadFace;
using metron::geometry::CadModel;
using metron::geometry::Mesh;
namespace fs = std::filesystem;

Mesh make(std::vector<Vec3> v, std::vector<Mesh::Face> f) {
  auto mesh = Mesh::from_triangles(std::move(v), std::move(f));
  if (!mesh) throw std::runtime_error(mesh.error().message);
  return std::move(*mesh);
}

// Axis-aligned box as 12 outward triangles.
Mesh box(const Vec3& lo, const Vec3& hi) {
  std::vector<Vec3> v;
  for (int i = 0; i < 8; ++i) v.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  return make(v, {{0, 2, 1},
                  {1, 2, 3},
                  {4, 5, 6},
                  {5, 7, 6},
                  {0, 1, 4},
                  {1, 5, 4},
                  {2, 6, 3},
                  {3, 6, 7},
                  {0, 4, 2},
                  {2, 4, 6},
                  {1, 3, 5},
                  {3, 7, 5}});
}
Mesh unit_cube() { return box(Vec3::Zero(), Vec3::Ones()); }

// Icosahedron subdivided `levels` times and pushed onto a sphere of radius r at the origin.
Mesh icosphere(double r, int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Mesh::Face> f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                               {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                               {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      auto key = std::minmax(a, b);
      auto [it, fresh] = mid.try_emplace({key.first, key.second}, 0);
      if (fresh) {
        it->second = static_cast<std::uint32_t>(v.size());
        v.push_back((v[a] + v[b]) / 2);
      }
      return it->second;
    };
    std::vector<Mesh::Face> g;
    for (auto [a, b, c] : f) {
      const auto ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      g.insert(g.end(), {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}});
    }
    f = std::move(g);
  }
  for (Vec3& p : v) p = r * p.normalized();
  return make(v, f);
}

// Largest gap between a convex mesh inscribed in a sphere of radius r and the sphere.
double sagitta(const Mesh& m, double r) {
  double inradius = r;
  for (const auto& f : m.faces())
    inradius = std::min(
        inradius, std::abs(m.vertices()[f[0]].dot(m.face_normal(static_cast<std::uint32_t>(&f - m.faces().data())))));
  return r - inradius;
}

// ---------------------------------------------------------------------------------------------
// Building

TEST(Mesh, FromTrianglesRejectsBadInput) {
  const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_FALSE(Mesh::from_triangles(v, {}));
  auto out_of_range = Mesh::from_triangles(v, {{0, 1, 3}});
  ASSERT_FALSE(out_of_range);
  EXPECT_NE(out_of_range.error().message.find("face 0 refers to vertex 3"), std::string::npos)
      << out_of_range.error().message;
  EXPECT_FALSE(Mesh::from_triangles(v, {{0, 1, 1}}));
  EXPECT_FALSE(Mesh::from_triangles({{0, 0, 0}, {1, 0, 0}, {NAN, 1, 0}}, {{0, 1, 2}}));
}

TEST(Mesh, CubeBasics) {
  const Mesh cube = unit_cube();
  EXPECT_EQ(cube.vertex_count(), 8u);
  EXPECT_EQ(cube.face_count(), 12u);
  EXPECT_TRUE(cube.is_closed());
  EXPECT_NEAR(cube.volume_mm3(), 1.0, 1e-12);
  EXPECT_TRUE(cube.bounds().min().isApprox(Vec3::Zero()));
  EXPECT_TRUE(cube.bounds().max().isApprox(Vec3::Ones()));
  const Mesh copy = cube;  // copies share the tree
  EXPECT_EQ(&copy.vertices(), &cube.vertices());
}

TEST(Mesh, OpenMeshIsNotClosedAndContainsNothing) {
  const Mesh cube = unit_cube();
  std::vector<Mesh::Face> f(cube.faces().begin() + 2, cube.faces().end());  // drop z = 0
  const Mesh open = make(cube.vertices(), f);
  EXPECT_FALSE(open.is_closed());
  EXPECT_FALSE(open.contains({0.5, 0.5, 0.5}));
  EXPECT_EQ(open.volume_mm3(), 0.0);
  // Non-manifold input (a face used twice) is kept, reported open, and still queryable.
  f = cube.faces();
  f.push_back(f[0]);
  const Mesh twice = make(cube.vertices(), f);
  EXPECT_FALSE(twice.is_closed());
  EXPECT_NEAR(twice.closest({0.5, 0.5, 3}).distance_mm, 2.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Closest point

TEST(Mesh, CubeClosestPointAndNormal) {
  const Mesh cube = unit_cube();
  struct Case {
    Vec3 query, point, normal;
  };
  const double s2 = 1 / std::sqrt(2.0), s3 = 1 / std::sqrt(3.0);
  const Case cases[] = {
      {{0.5, 0.5, 2}, {0.5, 0.5, 1}, {0, 0, 1}},         // above a face
      {{0.3, 0.6, -0.5}, {0.3, 0.6, 0}, {0, 0, -1}},     // below
      {{0.5, 0.5, 0.9}, {0.5, 0.5, 1}, {0, 0, 1}},       // inside: still the outward normal
      {{0.3, 0.7, 1}, {0.3, 0.7, 1}, {0, 0, 1}},         // on the surface
      {{2, 2, 0.5}, {1, 1, 0.5}, {s2, s2, 0}},           // nearest an edge
      {{2, 2, 2}, {1, 1, 1}, {s3, s3, s3}},              // nearest a corner
      {{-1, 0.5, -1}, {0, 0.5, 0}, {-s2, 0, -s2}},       // another edge
      {{0.5, 0.5, 1 + 1e-9}, {0.5, 0.5, 1}, {0, 0, 1}},  // just above
  };
  for (const auto& c : cases) {
    const auto r = cube.closest(c.query);
    EXPECT_LT((r.point - c.point).norm(), 1e-12) << c.query.transpose();
    EXPECT_LT((r.normal - c.normal).norm(), 1e-9) << c.query.transpose();
    EXPECT_NEAR(r.distance_mm, (c.query - c.point).norm(), 1e-12);
    EXPECT_NEAR(r.normal.norm(), 1.0, 1e-12);
    ASSERT_LT(r.face, cube.face_count());
  }
}

TEST(Mesh, SphereClosestPointMatchesAnalyticWithinSagitta) {
  const double radius = 10;
  const Mesh sphere = icosphere(radius, 4);
  ASSERT_TRUE(sphere.is_closed());
  const double sag = sagitta(sphere, radius);
  EXPECT_LT(sag, 0.05);
  EXPECT_NEAR(sphere.volume_mm3(), 4.0 / 3 * std::numbers::pi * std::pow(radius, 3),
              4 * std::numbers::pi * radius * radius * sag);
  std::mt19937 rng(42);
  std::normal_distribution<double> gauss;
  for (int i = 0; i < 200; ++i) {
    const Vec3 dir = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
    const double rho = std::uniform_real_distribution<double>(2, 30)(rng);
    const Vec3 q = rho * dir;
    const auto c = sphere.closest(q);
    // The polyhedron lies inside the sphere and outside the sphere of radius r - sag.
    const double d_sphere = std::abs(rho - radius);
    EXPECT_GE(c.distance_mm, d_sphere - sag - 1e-9) << "query " << q.transpose();
    EXPECT_LE(c.distance_mm, d_sphere + sag + 1e-9) << "query " << q.transpose();
    EXPECT_GT(c.normal.dot(dir), std::cos(5 * std::numbers::pi / 180)) << "query " << q.transpose();
    EXPECT_NEAR(c.point.norm(), radius, sag + 1e-9);
  }
}

// ---------------------------------------------------------------------------------------------
// Ray casting

TEST(Mesh, RayCastHitsTheFirstFace) {
  const Mesh cube = unit_cube();
  auto hit = cube.ray_cast({0.5, 0.5, 5}, {0, 0, -1});
  ASSERT_TRUE(hit);
  EXPECT_LT((hit->point - Vec3(0.5, 0.5, 1)).norm(), 1e-12);
  EXPECT_NEAR(hit->t, 4, 1e-12);
  EXPECT_LT((hit->normal - Vec3::UnitZ()).norm(), 1e-12);
  EXPECT_FALSE(cube.ray_cast({0.5, 0.5, 5}, {0, 0, -1}, 3.9));
  EXPECT_FALSE(cube.ray_cast({0.5, 0.5, 5}, {0, 0, 1}));  // pointing away
  EXPECT_FALSE(cube.ray_cast({2, 0.5, 5}, {0, 0, -1}));   // passes beside
  hit = cube.ray_cast({0.5, 0.25, 0.5}, {1, 0, 0});       // from inside
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->t, 0.5, 1e-12);
  EXPECT_LT((hit->normal - Vec3::UnitX()).norm(), 1e-12);
  const Vec3 d = Vec3(-1, -2, -3).normalized();  // oblique, from outside through (0.9,0.8,1)
  const Vec3 target(0.9, 0.8, 1);
  hit = cube.ray_cast(target - 7 * d, d);
  ASSERT_TRUE(hit);
  EXPECT_LT((hit->point - target).norm(), 1e-12);
  EXPECT_NEAR(hit->t, 7, 1e-12);
}

TEST(Mesh, RayCastOnSphere) {
  const double radius = 10;
  const Mesh sphere = icosphere(radius, 4);
  const double sag = sagitta(sphere, radius);
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss;
  for (int i = 0; i < 100; ++i) {
    const Vec3 dir = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
    const auto out = sphere.ray_cast(Vec3::Zero(), dir);  // from the centre outward
    ASSERT_TRUE(out);
    EXPECT_GE(out->t, radius - sag - 1e-9);
    EXPECT_LE(out->t, radius + 1e-9);
    const auto in = sphere.ray_cast(50 * dir, -dir);  // from outside inward
    ASSERT_TRUE(in);
    EXPECT_GE(in->t, 40 - 1e-9);
    EXPECT_LE(in->t, 40 + sag + 1e-9);
    EXPECT_GT(in->normal.dot(dir), std::cos(5 * std::numbers::pi / 180));
  }
}

// ---------------------------------------------------------------------------------------------
// Ball sweeps

TEST(Mesh, BallContactAgainstAFaceIsAnalytic) {
  const Mesh cube = unit_cube();
  const double r = 0.25;
  // Straight down onto the top face: the centre stops at z = 1 + r.
  const Vec3 a(0.5, 0.4, 3), b(0.5, 0.4, -3);
  const double length = (b - a).norm();
  auto s = cube.first_ball_contact(a, b, r);
  ASSERT_TRUE(s);
  const double exact = (3 - (1 + r)) / length;
  EXPECT_LE(std::abs(*s - exact) * length, 1e-7) << "off by " << (*s - exact) * length << " mm";
  EXPECT_GE(*s, exact - 1e-15);  // the returned point touches (or penetrates by < tol)
  // Diagonally at the edge (x = 1, z = 1): the centre stops sqrt(2)/2 r past it on the diagonal.
  s = cube.first_ball_contact({3, 0.5, 3}, {0, 0.5, 0}, r);
  ASSERT_TRUE(s);
  const double x = 1 + r / std::sqrt(2.0);
  EXPECT_LE(std::abs(*s - (3 - x) / 3) * std::sqrt(18.0), 1e-7);
  // Already touching at the start, and a tighter tolerance.
  EXPECT_EQ(cube.first_ball_contact({0.5, 0.5, 1.1}, {0.5, 0.5, 5}, r), 0.0);
  s = cube.first_ball_contact(a, b, r, 1e-10);
  ASSERT_TRUE(s);
  EXPECT_LE(std::abs(*s - exact) * length, 1e-10);
  // Never within r.
  EXPECT_FALSE(cube.first_ball_contact({1.3, -5, 0.5}, {1.3, 5, 0.5}, r));
  EXPECT_FALSE(cube.first_ball_contact({0.5, 0.5, 5}, {0.5, 0.5, 5}, r));
  EXPECT_THROW((void)cube.first_ball_contact(a, b, 0), std::invalid_argument);
}

TEST(Mesh, BallContactOnSphere) {
  const double radius = 10, r = 2;
  const Mesh sphere = icosphere(radius, 4);
  const double sag = sagitta(sphere, radius);
  const Vec3 a(30, 1, -2), b(-30, 1, -2);  // off-centre, so the contact is not at a vertex
  const auto s = sphere.first_ball_contact(a, b, r);
  ASSERT_TRUE(s);
  const Vec3 centre = a + *s * (b - a);
  EXPECT_NEAR(centre.norm(), radius + r, sag + 1e-7);
}

TEST(Mesh, BallDoesNotTunnelThroughAThinSlab) {
  // 0.2 mm slab, ball radius 1, 2 m move: a sampler stepping 2.2 mm or more would pass through.
  const Mesh slab = box({-50, -50, -0.1}, {50, 50, 0.1});
  const double r = 1;
  const Vec3 a(0, 0, -1000), b(0, 0, 1000);
  auto s = slab.first_ball_contact(a, b, r);
  ASSERT_TRUE(s);
  EXPECT_LE(std::abs(*s * 2000 - (1000 - 1.1)), 1e-7);
  // Grazing the slab's edge: the segment passes 0.9 mm from the edge x = 50, so the ball meets
  // the edge line first where sqrt(0.9^2 + (z + 0.1)^2) = 1.
  s = slab.first_ball_contact({50.9, 0, -1000}, {50.9, 0, 1000}, r);
  ASSERT_TRUE(s);
  const double z = -0.1 - std::sqrt(1 - 0.81);
  EXPECT_LE(std::abs(*s * 2000 - 1000 - z), 1e-7);
  // 1.1 mm beside the edge: no contact.
  EXPECT_FALSE(slab.first_ball_contact({51.1, 0, -1000}, {51.1, 0, 1000}, r));
  // Fast and oblique through the slab, crossing it within one r-sized step.
  s = slab.first_ball_contact({-400, 3, -700}, {400, -3, 700}, r);
  ASSERT_TRUE(s);
  const Vec3 hit = Vec3(-400, 3, -700) + *s * Vec3(800, -6, 1400);
  EXPECT_NEAR(hit.z(), -1.1, 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Sections, inside test, transforms

TEST(Mesh, CubeSectionIsASquare) {
  const Mesh cube = unit_cube();
  const auto lines = cube.section({0, 0, 0.5}, {0, 0, 1});
  ASSERT_EQ(lines.size(), 1u);
  const auto& l = lines[0];
  ASSERT_GE(l.size(), 5u);
  EXPECT_LT((l.front() - l.back()).norm(), 1e-12);  // closed
  double perimeter = 0, area = 0;
  for (std::size_t i = 0; i + 1 < l.size(); ++i) {
    perimeter += (l[i + 1] - l[i]).norm();
    area += l[i].x() * l[i + 1].y() - l[i + 1].x() * l[i].y();
  }
  for (const Vec3& p : l) {
    EXPECT_NEAR(p.z(), 0.5, 1e-12);
    const double to_edge = std::min({std::abs(p.x()), std::abs(p.x() - 1), std::abs(p.y()), std::abs(p.y() - 1)});
    EXPECT_LT(to_edge, 1e-12) << p.transpose();
  }
  EXPECT_NEAR(perimeter, 4, 1e-12);
  EXPECT_NEAR(area / 2, 1, 1e-12);  // counterclockwise seen from the plane normal
  // A tilted plane through the centre and a plane that misses.
  const auto tilted = cube.section({0.5, 0.5, 0.5}, {1, 1, 0});
  ASSERT_EQ(tilted.size(), 1u);
  double len = 0;
  for (std::size_t i = 0; i + 1 < tilted[0].size(); ++i) len += (tilted[0][i + 1] - tilted[0][i]).norm();
  EXPECT_NEAR(len, 2 * std::sqrt(2.0) + 2, 1e-12);  // a sqrt(2) x 1 rectangle
  EXPECT_TRUE(cube.section({0, 0, 2}, {0, 0, 1}).empty());
}

TEST(Mesh, SphereSectionIsACircle) {
  const double radius = 10;
  const Mesh sphere = icosphere(radius, 4);
  const double sag = sagitta(sphere, radius);
  const auto lines = sphere.section({0, 0, 6}, {0, 0, 1});
  ASSERT_EQ(lines.size(), 1u);
  for (const Vec3& p : lines[0]) EXPECT_NEAR(Vec3(p.x(), p.y(), 0).norm(), 8, 2 * sag);
}

TEST(Mesh, Contains) {
  const Mesh cube = unit_cube();
  EXPECT_TRUE(cube.contains({0.5, 0.5, 0.5}));
  EXPECT_TRUE(cube.contains({0.999, 0.001, 0.5}));
  EXPECT_TRUE(cube.contains({0.5, 0.5, 1}));  // on the boundary
  EXPECT_FALSE(cube.contains({1.5, 0.5, 0.5}));
  EXPECT_FALSE(cube.contains({0.5, 0.5, -1e-6}));
  const Mesh sphere = icosphere(10, 3);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-12, 12);
  const double sag = sagitta(sphere, 10);
  for (int i = 0; i < 300; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    if (std::abs(p.norm() - 10) < sag + 1e-6) continue;  // between polyhedron and sphere
    EXPECT_EQ(sphere.contains(p), p.norm() < 10) << p.transpose();
  }
}

TEST(Mesh, TransformedMovesTheQueries) {
  Frame f = Frame::Identity();
  f.translate(Vec3(10, -5, 2)).rotate(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  const Mesh moved = unit_cube().transformed(f);
  EXPECT_TRUE(moved.is_closed());
  EXPECT_NEAR(moved.volume_mm3(), 1, 1e-12);
  const auto c = moved.closest(f * Vec3(0.5, 0.5, 2));
  EXPECT_LT((c.point - f * Vec3(0.5, 0.5, 1)).norm(), 1e-12);
  EXPECT_LT((c.normal - f.linear() * Vec3::UnitZ()).norm(), 1e-12);
  EXPECT_TRUE(moved.contains(f * Vec3(0.5, 0.5, 0.5)));
  Frame mirror = Frame::Identity();
  mirror.linear() = Vec3(-1, 1, 1).asDiagonal();
  const Mesh mirrored = unit_cube().transformed(mirror);
  EXPECT_NEAR(mirrored.volume_mm3(), 1, 1e-12);  // winding flipped, still outward
  EXPECT_LT((mirrored.closest({-0.5, 0.5, 2}).normal - Vec3::UnitZ()).norm(), 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Files

class MeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    m_dir = metron::test_support::scratch_root("metron_test_mesh");
    fs::create_directories(m_dir);
  }
  void TearDown() override { fs::remove_all(m_dir); }
  std::string path(const std::string& name) const { return (m_dir / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }
  fs::path m_dir;
};

std::string ascii_stl_of(const Mesh& m) {
  std::string s = "solid cube\n";
  char line[200];
  for (std::size_t i = 0; i < m.face_count(); ++i) {
    const Vec3 n = m.face_normal(static_cast<std::uint32_t>(i));
    std::snprintf(line, sizeof line, "  facet normal %g %g %g\n    outer loop\n", n.x(), n.y(), n.z());
    s += line;
    for (auto v : m.faces()[i]) {
      const Vec3& p = m.vertices()[v];
      std::snprintf(line, sizeof line, "      vertex %.17g %.17g %.17g\n", p.x(), p.y(), p.z());
      s += line;
    }
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid cube\n";
}

TEST_F(MeshFiles, AsciiStlRoundTrip) {
  const auto file = write("cube.stl", ascii_stl_of(unit_cube()));
  auto m = metron::geometry::load_mesh(file);
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->face_count(), 12u);
  EXPECT_EQ(m->vertex_count(), 8u);  // STL repeats corners; they are merged
  EXPECT_TRUE(m->is_closed());
  EXPECT_NEAR(m->volume_mm3(), 1, 1e-12);
  // Upper-case extension.
  fs::copy_file(file, path("CUBE.STL"));
  EXPECT_TRUE(metron::geometry::load_mesh(path("CUBE.STL")));
}

TEST_F(MeshFiles, OffWithQuadsAndInwardWinding) {
  // A 2 x 1 x 1 box written as six quads, all wound inward: loaded triangulated and outward.
  const auto file = write("box.off",
                          "OFF\n8 6 0\n"
                          "0 0 0\n2 0 0\n0 1 0\n2 1 0\n0 0 1\n2 0 1\n0 1 1\n2 1 1\n"
                          "4 0 1 3 2\n4 4 6 7 5\n4 0 4 5 1\n4 2 3 7 6\n4 0 2 6 4\n4 1 5 7 3\n");
  auto m = metron::geometry::load_mesh(file);
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->face_count(), 12u);
  EXPECT_TRUE(m->is_closed());
  EXPECT_NEAR(m->volume_mm3(), 2, 1e-12);
  EXPECT_LT((m->closest({1, 0.5, 3}).normal - Vec3::UnitZ()).norm(), 1e-12);
}

TEST_F(MeshFiles, SaveAndLoadEveryFormat) {
  const Mesh sphere = icosphere(5, 2);
  for (const char* name : {"s.stl", "s.off", "s.obj", "s.ply"}) {
    ASSERT_TRUE(metron::geometry::save_mesh(sphere, path(name))) << name;
    auto m = metron::geometry::load_mesh(path(name));
    ASSERT_TRUE(m) << m.error().message;
    EXPECT_EQ(m->face_count(), sphere.face_count()) << name;
    EXPECT_TRUE(m->is_closed()) << name;
    // binary STL stores floats
    EXPECT_NEAR(m->volume_mm3(), sphere.volume_mm3(), 1e-4 * sphere.volume_mm3()) << name;
  }
  EXPECT_FALSE(metron::geometry::save_mesh(sphere, path("s.xyz")));
}

TEST_F(MeshFiles, CorruptFilesGiveErrorsThatNameTheFile) {
  ASSERT_TRUE(metron::geometry::save_mesh(unit_cube(), path("good.stl")));  // binary
  const auto size = fs::file_size(path("good.stl"));
  fs::copy_file(path("good.stl"), path("truncated.stl"));
  fs::resize_file(path("truncated.stl"), size - 70);
  auto m = metron::geometry::load_mesh(path("truncated.stl"));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find(path("truncated.stl")), std::string::npos);
  EXPECT_NE(m.error().message.find("triangle 10"), std::string::npos) << m.error().message;

  std::string text = ascii_stl_of(unit_cube());
  text.resize(text.size() / 2);  // cut mid-facet
  const auto cut = write("cut.stl", text);
  m = metron::geometry::load_mesh(cut);
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find(cut), std::string::npos) << m.error().message;

  const auto garbage = write("garbage.stl", "solid x\n facet normal banana\nendsolid\n");
  m = metron::geometry::load_mesh(garbage);
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find(garbage), std::string::npos);

  const auto off = write("short.off", "OFF\n8 6 0\n0 0 0\n1 0 0\n0 1 0\n");
  m = metron::geometry::load_mesh(off);
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find(off), std::string::npos) << m.error().message;

  const auto bad_index = write("index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  m = metron::geometry::load_mesh(bad_index);
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find(bad_index), std::string::npos) << m.error().message;

  for (const char* name : {"empty.stl", "empty.obj"}) {
    m = metron::geometry::load_mesh(write(name, ""));
    ASSERT_FALSE(m) << name;
    EXPECT_NE(m.error().message.find(name), std::string::npos) << m.error().message;
  }

  m = metron::geometry::load_mesh(path("missing.stl"));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("cannot open"), std::string::npos);
  m = metron::geometry::load_mesh(write("cube.dxf", "0\nSECTION\n"));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("unsupported"), std::string::npos);

  const auto step = write("broken.step", "ISO-10303-21;\nHEADER;\nthis is not STEP\n");
  auto cad = metron::geometry::load_cad_model(step);
  ASSERT_FALSE(cad);
  EXPECT_NE(cad.error().message.find(step), std::string::npos) << cad.error().message;
  const auto iges = write("broken.igs", std::string(80, 'x') + "\n" + std::string(80, 'y'));
  cad = metron::geometry::load_cad_model(iges);
  ASSERT_FALSE(cad);
  EXPECT_NE(cad.error().message.find(iges), std::string::npos) << cad.error().message;
}

// ---------------------------------------------------------------------------------------------
// The NIST parts. Facts come from the DMIS programs beside the CAD, not from the CAD itself.

const std::string data_dir = METRON_SHARED_DATA;

#define SKIP_WITHOUT(file) \
  if (!fs::exists(file)) GTEST_SKIP() << "reference data not found: " << (file) << " (see /work/shared/data/README.md)"

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

const char* kind_name(CadFace::Kind k) {
  static const char* names[] = {"plane", "cylinder", "cone", "sphere", "torus", "other"};
  return names[static_cast<int>(k)];
}

// Distance from p to the line through o along unit a.
double to_axis(const Vec3& p, const Vec3& o, const Vec3& a) {
  const Vec3 d = p - o;
  return (d - d.dot(a) * a).norm();
}

// Distance from p to the analytic surface of a CAD face (0 for Kind::Other).
double off_surface(const CadFace& f, const Vec3& p) {
  const Vec3 q = p - f.origin;
  const double h = q.dot(f.axis);
  const Vec3 radial = q - h * f.axis;
  switch (f.kind) {
    case CadFace::Kind::Plane: return std::abs(h);
    case CadFace::Kind::Cylinder: return std::abs(radial.norm() - f.radius_mm);
    case CadFace::Kind::Sphere: return std::abs(q.norm() - f.radius_mm);
    case CadFace::Kind::Torus: return std::abs((q - f.radius_mm * radial.normalized()).norm() - f.minor_radius_mm);
    case CadFace::Kind::Cone:
      return std::abs(radial.norm() - (f.radius_mm + h * std::tan(f.semi_angle_rad))) * std::cos(f.semi_angle_rad);
    default: return 0;
  }
}

// Largest distances of the face's triangle vertices and centroids from its analytic surface,
// over all faces of the model: checks the face-to-triangle map, orientation-independent.
std::pair<double, double> tessellation_error(const CadModel& model) {
  double vertex = 0, centroid = 0;
  const auto& v = model.mesh.vertices();
  for (const CadFace& f : model.faces)
    for (auto t : f.triangles) {
      const auto& tri = model.mesh.faces()[t];
      for (auto i : tri) vertex = std::max(vertex, off_surface(f, v[i]));
      centroid = std::max(centroid, off_surface(f, (v[tri[0]] + v[tri[1]] + v[tri[2]]) / 3));
    }
  return {vertex, centroid};
}

// A DMIS PTMEAS nominal: surface point and the outward normal (approach along -normal).
struct Touch {
  Vec3 point, normal;
};

// The surface point lies on the mesh (to the chord tolerance) with the outward normal given.
void expect_on_surface(const Mesh& m, const Touch& t, double tol_mm, const std::string& what) {
  const auto c = m.closest(t.point);
  EXPECT_LE(c.distance_mm, tol_mm) << what << " at " << t.point.transpose();
  EXPECT_GT(c.normal.dot(t.normal), std::cos(1.5 * std::numbers::pi / 180))
      << what << " at " << t.point.transpose() << ": normal " << c.normal.transpose();
  EXPECT_FALSE(m.contains(t.point + 0.05 * t.normal)) << what << ": outside is material";
  EXPECT_TRUE(m.contains(t.point - 0.05 * t.normal)) << what << ": inside is not material";
}

std::string fmt_vec(const Vec3& v) {
  char b[96];
  std::snprintf(b, sizeof b, "(%.3f, %.3f, %.3f)", v.x(), v.y(), v.z());
  return b;
}

// Flies a ball of radius r through a DMIS program: GOTO targets and PTMEAS touches with the
// given approach and retract distances. Returns the number of unexpected collisions; each
// touch must stop where the ball centre is r off the nominal point (to tol_mm, which covers the
// tessellation: chords of a concave surface stop the ball early by up to the chord tolerance).
struct Move {
  bool touch;
  Vec3 p, n;
};
int fly(const Mesh& m, const std::vector<Move>& moves, double r, double approach, double retract, double tol_mm,
        bool verbose) {
  int collisions = 0;
  Vec3 at = moves.front().p;
  auto free_move = [&](const Vec3& to, const char* what) {
    if (auto s = m.first_ball_contact(at, to, r)) {
      ++collisions;
      if (verbose)
        std::printf("    collision on %s move %s -> %s at %s\n", what, fmt_vec(at).c_str(), fmt_vec(to).c_str(),
                    fmt_vec(at + *s * (to - at)).c_str());
    }
    at = to;
  };
  for (const auto& mv : moves) {
    if (!mv.touch) {
      free_move(mv.p, "goto");
      continue;
    }
    const Vec3 start = mv.p + (r + approach) * mv.n, centre = mv.p + r * mv.n;
    free_move(start, "approach");
    const Vec3 end = mv.p - 9 * mv.n;  // SNSET/SEARCH,9
    const auto s = m.first_ball_contact(start, end, r);
    const Vec3 contact = s ? Vec3(start + *s * (end - start)) : end;
    if (!s || (contact - centre).norm() > tol_mm) {
      ++collisions;
      if (verbose) std::printf("    touch at %s missed its nominal\n", fmt_vec(mv.p).c_str());
    }
    at = contact + 1e-6 * mv.n;  // lift off the contact before retracting
    free_move(mv.p + (r + retract) * mv.n, "retract");
  }
  return collisions;
}

Touch touch(double x, double y, double z, double i, double j, double k) {
  return {{x, y, z}, Vec3(i, j, k).normalized()};
}
Move go(double x, double y, double z) { return {false, {x, y, z}, Vec3::Zero()}; }
Move meas(const Touch& t) { return {true, t.point, t.normal}; }

}  // namespace

// nist-simple-part/simple_in.dms: "An edge of the part should be on the positive machine
// X-axis. Another edge ... on the positive machine Y-axis. The normal pointing away from
// material at the bottom of the hole should be parallel to the positive Z-axis." and a circle
// "diameter 50, center at (50,50,40), axis parallel to z-axis ... 10 mm below the top".
// Finding: ipp_simple.stp is already in the program's coordinates (identity): a 100 x 100 x 50
// block on [0,100] x [0,100] x [0,50] with a 50 mm hole at (50,50) from z = 25 (flat bottom,
// normal +z) to the top z = 50. ipp_simple.igs is the same part shifted by -50 in z.
TEST(CadSimplePart, StepIsInTheDmisProgramsCoordinates) {
  const std::string file = data_dir + "/nist-simple-part/ipp_simple.stp";
  SKIP_WITHOUT(file);
  const auto t0 = std::chrono::steady_clock::now();
  auto model = metron::geometry::load_cad_model(file);
  const double load_s = seconds_since(t0);
  ASSERT_TRUE(model) << model.error().message;
  const Mesh& m = model->mesh;
  const auto b = m.bounds();
  std::printf("  ipp_simple.stp: %.3f s, %zu vertices, %zu triangles, %zu faces, bounds %s - %s\n", load_s,
              m.vertex_count(), m.face_count(), model->faces.size(), fmt_vec(b.min()).c_str(),
              fmt_vec(b.max()).c_str());
  EXPECT_TRUE(m.is_closed());
  EXPECT_LT((b.min() - Vec3(0, 0, 0)).norm(), 1e-6);
  EXPECT_LT((b.max() - Vec3(100, 100, 50)).norm(), 1e-6);
  // The tessellated hole is an inscribed polygon: at most perimeter x chord x depth too full.
  const double nominal = 100.0 * 100 * 50 - std::numbers::pi * 25 * 25 * 25;
  EXPECT_GE(m.volume_mm3(), nominal - 1e-6);
  EXPECT_LE(m.volume_mm3(), nominal + 2 * std::numbers::pi * 25 * 0.001 * 25);

  int holes = 0, bottoms = 0;
  for (const CadFace& f : model->faces) {
    if (f.kind == CadFace::Kind::Cylinder && std::abs(f.radius_mm - 25) < 1e-9 &&
        std::abs(std::abs(f.axis.z()) - 1) < 1e-12 && to_axis({50, 50, 40}, f.origin, f.axis) < 1e-9) {
      ++holes;
      EXPECT_TRUE(f.inner);
    }
    if (f.kind == CadFace::Kind::Plane && (f.axis - Vec3::UnitZ()).norm() < 1e-12 && std::abs(f.origin.z() - 25) < 1e-9)
      ++bottoms;
  }
  EXPECT_GE(holes, 1);
  EXPECT_EQ(bottoms, 1);
  const auto [vertex_error, chord_error] = tessellation_error(*model);
  EXPECT_LT(vertex_error, 1e-9);
  EXPECT_LE(chord_error, 0.001);
  const Touch circle[] = {touch(75, 50, 40, -1, 0, 0), touch(25, 50, 40, 1, 0, 0), touch(50, 75, 40, 0, -1, 0),
                          touch(50, 25, 40, 0, 1, 0)};
  for (const auto& t : circle) expect_on_surface(m, t, 0.001 + 1e-9, "A_CIRCLE");
  // The program's moves with its probe (SNSDEF diameter 4), APPRCH 10, RETRCT 10.
  std::vector<Move> moves = {go(50, 50, 175), go(50, 50, 75), go(50, 50, 40)};
  for (const auto& t : circle) moves.push_back(meas(t));
  moves.insert(moves.end(), {go(50, 50, 40), go(50, 50, 100)});
  EXPECT_EQ(fly(m, moves, 2, 10, 10, 0.002, true), 0);
}

TEST(CadSimplePart, IgesIsTheStepPartShiftedDown50) {
  const std::string step = data_dir + "/nist-simple-part/ipp_simple.stp";
  const std::string iges = data_dir + "/nist-simple-part/ipp_simple.igs";
  SKIP_WITHOUT(iges);
  const auto t0 = std::chrono::steady_clock::now();
  auto model = metron::geometry::load_cad_model(iges);
  const double load_s = seconds_since(t0);
  ASSERT_TRUE(model) << model.error().message;
  auto reference = metron::geometry::load_cad(step);
  ASSERT_TRUE(reference) << reference.error().message;
  const auto b = model->mesh.bounds();
  std::printf("  ipp_simple.igs: %.3f s, %zu triangles, bounds %s - %s\n", load_s, model->mesh.face_count(),
              fmt_vec(b.min()).c_str(), fmt_vec(b.max()).c_str());
  EXPECT_TRUE(model->mesh.is_closed());
  EXPECT_NEAR(model->mesh.volume_mm3(), reference->volume_mm3(), 1e-6 * reference->volume_mm3());
  Frame up = Frame::Identity();
  up.translate(Vec3(0, 0, 50));
  const Mesh moved = model->mesh.transformed(up);
  EXPECT_TRUE(moved.bounds().isApprox(reference->bounds(), 1e-9));
  for (const Vec3& v : moved.vertices()) ASSERT_LT(reference->closest(v).distance_mm, 0.002);
  // IGES has no analytic faces, only surfaces of revolution and B-splines; they are recognised.
  int holes = 0, planes = 0;
  for (const CadFace& f : model->faces) {
    planes += f.kind == CadFace::Kind::Plane;
    if (f.kind == CadFace::Kind::Cylinder) {
      ++holes;
      EXPECT_NEAR(f.radius_mm, 25, 1e-9);
      EXPECT_LT(to_axis({50, 50, 0}, f.origin, f.axis), 1e-9);
      EXPECT_TRUE(f.inner);
    }
  }
  EXPECT_EQ(planes, 7);
  EXPECT_GE(holes, 1);
}

// The DCX part, loaded once at the default tessellation for all DCX tests.
//
// Findings about its frames (nist-dcx-part/IMTS_M_clean.dmi against the STEP file):
//  - The STEP (AP203 and AP214) coordinates are the coordinates of the program's final
//    alignment D(CALN1), in which CYL1 (dia 31, axis z, z 14..26) and CYL2 (dia 12.5, through
//    hole z 0..14) sit on the z axis. The datum planes are measured earlier in D(PARTX), which
//    is the STEP frame turned 180 degrees about z:  p_PARTX = Rz(180) p_STEP = (-x, -y, z).
//    So PLN1 z = 30 (+z) is STEP z = 30; PLN2 y = -52 (-y) is STEP y = +52 (+y); PLN3 x = -86
//    (-x) is STEP x = +86 (+x); CPNT1 (-86,-52,30) is the STEP corner (86,52,30).
//  - Evidence: (1) the alignment D(CALN1) = datums, ROTATE/ZAXIS,-180, TRANS -86,-52,-30 maps
//    PARTX exactly onto (-x,-y,z) (checked below); (2) "the end with the two spheres is on the
//    positive X side" of the machine, and the two large spheres (R 12.5) are at STEP x = -68;
//    (3) every touch and move of the program fits the STEP part under this map. The part is
//    nearly symmetric, so the touches fit the identity map too: only (1) and (2) decide.
//  - Placing it: machine = Rz(180) p_STEP + (355, 91, -80) with the program's D(PARTX)
//    (the bottom face z = 0 on the table; DCXpart.prg was run with the PARTX origin at the
//    machine origin).
//  - The IGES file is in the same frame as the STEP files, but OpenCASCADE 7.6 trims its nine
//    spherical faces to the complementary region (domes become sockets, volume -47,000 mm^3).
//    Use the STEP files.
class DcxPart : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string file = data_dir + "/nist-dcx-part/DaimlerChryslerTestPartAP203.stp";
    if (!fs::exists(file) || s_model) return;
    const auto t0 = std::chrono::steady_clock::now();
    auto model = metron::geometry::load_cad_model(file);
    s_load_s = seconds_since(t0);
    if (model)
      s_model = std::move(*model);
    else
      s_error = model.error().message;
  }
  void SetUp() override {
    SKIP_WITHOUT(data_dir + "/nist-dcx-part/DaimlerChryslerTestPartAP203.stp");
    ASSERT_TRUE(s_model) << s_error;
  }
  static const Mesh& mesh() { return s_model->mesh; }
  static inline std::optional<CadModel> s_model;
  static inline std::string s_error;
  static inline double s_load_s = 0;
};

// p_STEP from p_PARTX (and back: the map is its own inverse).
Vec3 from_partx(const Vec3& p) { return {-p.x(), -p.y(), p.z()}; }
Touch from_partx(const Touch& t) { return {from_partx(t.point), from_partx(t.normal)}; }

const Touch pln1[] = {touch(-43, 15, 30, 0, 0, 1), touch(43, 15, 30, 0, 0, 1), touch(43, -35, 30, 0, 0, 1),
                      touch(-50, -25, 30, 0, 0, 1)};
const Touch pln2[] = {touch(19, -52, 23, 0, -1, 0), touch(19, -52, 7, 0, -1, 0), touch(-19, -52, 7, 0, -1, 0),
                      touch(-19, -52, 23, 0, -1, 0)};
const Touch pln3[] = {touch(-86, -14, 23, -1, 0, 0), touch(-86, -29, 23, -1, 0, 0), touch(-86, -29, 7, -1, 0, 0),
                      touch(-86, -14, 7, -1, 0, 0)};
const Touch cyl1[] = {touch(0, -15.5, 23, 0, 1, 0), touch(-15.5, 0, 23, 1, 0, 0), touch(0, 15.5, 23, 0, -1, 0),
                      touch(15.5, 0, 23, -1, 0, 0), touch(15.5, 0, 17, -1, 0, 0), touch(0, 15.5, 17, 0, -1, 0),
                      touch(-15.5, 0, 17, 1, 0, 0), touch(0, -15.5, 17, 0, 1, 0)};
const Touch cyl2[] = {touch(0, 6.25, 3, 0, -1, 0),  touch(-6.25, 0, 3, 1, 0, 0),  touch(0, -6.25, 3, 0, 1, 0),
                      touch(6.25, 0, 3, -1, 0, 0),  touch(6.25, 0, 11, -1, 0, 0), touch(0, -6.25, 11, 0, 1, 0),
                      touch(-6.25, 0, 11, 1, 0, 0), touch(0, 6.25, 11, 0, -1, 0)};

TEST_F(DcxPart, LoadsClosedAtTheDefaultTessellation) {
  const auto b = mesh().bounds();
  std::printf(
      "  DaimlerChryslerTestPartAP203.stp (chord 0.001 mm): %.2f s, %zu vertices, %zu "
      "triangles, %zu B-rep faces, volume %.1f mm^3\n  bounds %s - %s\n",
      s_load_s, mesh().vertex_count(), mesh().face_count(), s_model->faces.size(), mesh().volume_mm3(),
      fmt_vec(b.min()).c_str(), fmt_vec(b.max()).c_str());
  EXPECT_TRUE(mesh().is_closed());
  EXPECT_EQ(s_model->faces.size(), 140u);
  // DMIS: PLN3 at x = -86 (and x = +86 in STEP), the part on the table at z = 0, PLN2 y = -52.
  EXPECT_NEAR(b.min().x(), -86, 1e-6);
  EXPECT_NEAR(b.max().x(), 86, 1e-6);
  EXPECT_NEAR(b.min().z(), 0, 1e-6);
  EXPECT_NEAR(b.max().y(), 52, 1e-6);
  std::size_t triangles = 0;
  for (const CadFace& f : s_model->faces) {
    EXPECT_FALSE(f.triangles.empty()) << "face " << f.shape_index;
    triangles += f.triangles.size();
  }
  EXPECT_EQ(triangles, mesh().face_count());
  // Nodes on B-rep edges lie within the edge tolerance of the surfaces, and a few triangles
  // along edges (the R 4.75 spheres') exceed the chord tolerance by up to ~2 um.
  const auto [vertex_error, chord_error] = tessellation_error(*s_model);
  std::printf("  distance to the analytic surfaces: vertices <= %.2g mm, centroids <= %.2g mm\n", vertex_error,
              chord_error);
  EXPECT_LT(vertex_error, 0.001);
  EXPECT_LT(chord_error, 0.003);
}

TEST_F(DcxPart, CylindersOfTheCadModel) {
  std::printf("  cylinders (origin on axis, axis, radius, inner/outer, B-rep face):\n");
  bool big_hole = false, small_hole = false;
  for (const CadFace& f : s_model->faces) {
    if (f.kind != CadFace::Kind::Cylinder) continue;
    std::printf("    %s %s r %.3f %s face %u\n", fmt_vec(f.origin).c_str(), fmt_vec(f.axis).c_str(), f.radius_mm,
                f.inner ? "inner" : "outer", f.shape_index);
    const bool on_z_axis = std::abs(std::abs(f.axis.z()) - 1) < 1e-12 && to_axis(Vec3::Zero(), f.origin, f.axis) < 1e-9;
    big_hole |= on_z_axis && f.inner && std::abs(f.radius_mm - 15.5) < 1e-9;
    small_hole |= on_z_axis && f.inner && std::abs(f.radius_mm - 6.25) < 1e-9;
  }
  EXPECT_TRUE(big_hole) << "no inner cylinder of diameter 31 on the z axis";
  EXPECT_TRUE(small_hole) << "no inner cylinder of diameter 12.5 on the z axis";
  // The same seen in the mesh alone: sections at the CYL1 and CYL2 touch heights contain a
  // circle of the nominal radius around the z axis (vertices on it, chords inside it).
  for (const auto& [z, radius] : {std::pair{20.0, 15.5}, std::pair{7.0, 6.25}}) {
    bool found = false;
    for (const auto& line : mesh().section({0, 0, z}, Vec3::UnitZ())) {
      double lo = 1e9, hi = 0;
      for (const Vec3& p : line) {
        lo = std::min(lo, Vec3(p.x(), p.y(), 0).norm());
        hi = std::max(hi, Vec3(p.x(), p.y(), 0).norm());
      }
      found |= hi - radius < 1e-6 && radius - lo < 0.0011;
    }
    EXPECT_TRUE(found) << "no circle of radius " << radius << " at z = " << z;
  }
}

TEST_F(DcxPart, DmisFactsHoldInStepCoordinatesAfterTurningPartxByRz180) {
  // The program's alignment chain, D(CALN1_a) .. D(CALN1): datums give origin CPNT1 and axes
  // (x along CLIN1 = n(PLN1) x n(PLN2) = +x, z = +z); ROTATE/ZAXIS,-180; TRANS/XORIG,-86,
  // YORIG,-52, ZORIG,-30 move the origin to the point with those current coordinates.
  const Vec3 corner(-86, -52, 30);
  const Vec3 clin1 = Vec3::UnitZ().cross(-Vec3::UnitY());
  ASSERT_LT((clin1 - Vec3::UnitX()).norm(), 1e-15);
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(-std::numbers::pi, Vec3::UnitZ()).toRotationMatrix();
  auto caln1 = [&](const Vec3& p) { return Vec3(turn * (p - corner) - Vec3(-86, -52, -30)); };
  for (const Vec3& p : {Vec3(0, 0, 0), Vec3(1, 2, 3), Vec3(-86, -52, 30)})
    EXPECT_LT((caln1(p) - from_partx(p)).norm(), 1e-12) << p.transpose();

  // Datum planes (nominals in PARTX) and their touches.
  struct Datum {
    const char* name;
    Vec3 point, normal;
    const Touch* touches;
  };
  const Datum datums[] = {{"PLN1", {0, 0, 30}, {0, 0, 1}, pln1},
                          {"PLN2", {0, -52, 15}, {0, -1, 0}, pln2},
                          {"PLN3", {-86, -20, 15}, {-1, 0, 0}, pln3}};
  for (const auto& d : datums) {
    const Vec3 p = from_partx(d.point), n = from_partx(d.normal);
    bool face = false;
    for (const CadFace& f : s_model->faces)
      face |= f.kind == CadFace::Kind::Plane && (f.axis - n).norm() < 1e-9 && std::abs((f.origin - p).dot(n)) < 1e-9;
    EXPECT_TRUE(face) << d.name << " has no CAD plane at " << p.transpose();
    for (int i = 0; i < 4; ++i) expect_on_surface(mesh(), from_partx(d.touches[i]), 1e-6, d.name);
  }
  // Cylinder touches are in D(CALN1), which is the STEP frame.
  for (const auto& t : cyl1) expect_on_surface(mesh(), t, 0.001 + 1e-9, "CYL1");
  for (const auto& t : cyl2) expect_on_surface(mesh(), t, 0.001 + 1e-9, "CYL2");

  // "the end with the two spheres is on the positive X side": the large spheres.
  int spheres_at_step_minus_x = 0, spheres = 0;
  for (const CadFace& f : s_model->faces) {
    if (f.kind != CadFace::Kind::Sphere || std::abs(f.radius_mm - 12.5) > 1e-9) continue;
    ++spheres;
    spheres_at_step_minus_x += f.origin.x() < 0;
  }
  EXPECT_EQ(spheres, 6);  // three domes, each split into two faces
  EXPECT_EQ(spheres_at_step_minus_x, 4);
  EXPECT_GT(from_partx(Vec3(-68, 0, 0)).x(), 0);  // ... which PARTX puts on the +X side
}

TEST_F(DcxPart, TheInspectionFliesWithoutCollisions) {
  // IMTS_M_clean.dmi with its probe: SNSDEF diameter 4, APPRCH 4, RETRCT 5, SEARCH 9. Moves
  // up to SAVE/DA(CALN1) are in PARTX, the rest in CALN1 (= STEP).
  auto program = [](auto datum_map) {
    std::vector<Move> m;
    auto add = [&](const Touch* t, int n) {
      for (int i = 0; i < n; ++i) m.push_back(meas(datum_map(t[i])));
    };
    auto goto_ = [&](double x, double y, double z) {
      const Vec3 p = datum_map(Touch{{x, y, z}, Vec3::UnitZ()}).point;
      m.push_back(go(p.x(), p.y(), p.z()));
    };
    goto_(-43, 15, 100), goto_(-43, 15, 55);
    add(pln1, 4);
    goto_(-50, -35, 100), goto_(21, -62, 100), goto_(19, -62, 23);
    add(pln2, 4);
    goto_(-19, -62, 100), goto_(-96, -14, 100), goto_(-96, -14, 23);
    add(pln3, 4);
    goto_(-96, -14, 100);
    m.push_back(go(0, -9.5, 51));
    for (const auto& t : cyl1) m.push_back(meas(t));
    m.insert(m.end(), {go(0, -10.5, 46), go(0, 0.25, 39)});
    for (const auto& t : cyl2) m.push_back(meas(t));
    m.insert(m.end(), {go(0, 1.25, 34), go(0, 1.25, 200), go(-200, -62, 200)});
    return m;
  };
  const auto turned = program([](const Touch& t) { return from_partx(t); });
  EXPECT_EQ(fly(mesh(), turned, 2, 4, 5, 0.002, true), 0);
  const auto same = program([](const Touch& t) { return t; });
  std::printf("  with PARTX = STEP instead: %d collisions or missed touches\n",
              fly(mesh(), same, 2, 4, 5, 0.002, false));
}

TEST_F(DcxPart, Ap214IsTheSamePart) {
  const std::string file = data_dir + "/nist-dcx-part/DaimlerChryslerTestPartAP214.stp";
  SKIP_WITHOUT(file);
  metron::geometry::TessellationOptions coarse;
  coarse.chord_tolerance_mm = 0.01;
  const auto t0 = std::chrono::steady_clock::now();
  auto model = metron::geometry::load_cad_model(file, coarse);
  const double load_s = seconds_since(t0);
  ASSERT_TRUE(model) << model.error().message;
  std::printf("  AP214 (chord 0.01 mm): %.2f s, %zu triangles\n", load_s, model->mesh.face_count());
  EXPECT_TRUE(model->mesh.is_closed());
  ASSERT_EQ(model->faces.size(), s_model->faces.size());
  for (std::size_t i = 0; i < model->faces.size(); ++i) {
    EXPECT_EQ(model->faces[i].kind, s_model->faces[i].kind) << "face " << i + 1;
    EXPECT_NEAR(model->faces[i].radius_mm, s_model->faces[i].radius_mm, 1e-9);
  }
  EXPECT_LT((model->mesh.bounds().min() - mesh().bounds().min()).norm(), 0.011);
  EXPECT_LT((model->mesh.bounds().max() - mesh().bounds().max()).norm(), 0.011);
  for (std::size_t i = 0; i < model->mesh.vertex_count(); i += 7)
    ASSERT_LT(mesh().closest(model->mesh.vertices()[i]).distance_mm, 0.011);
}

TEST_F(DcxPart, IgesMatchesStepExceptItsSpheres) {
  const std::string file = data_dir + "/nist-dcx-part/DaimlerChryslerTestPart.igs";
  SKIP_WITHOUT(file);
  metron::geometry::TessellationOptions coarse;
  coarse.chord_tolerance_mm = 0.01;
  const auto t0 = std::chrono::steady_clock::now();
  auto model = metron::geometry::load_cad_model(file, coarse);
  const double load_s = seconds_since(t0);
  ASSERT_TRUE(model) << model.error().message;
  const Mesh& m = model->mesh;
  std::printf(
      "  IGES (chord 0.01 mm): %.2f s, %zu triangles, closed %d, volume %.1f mm^3 "
      "(STEP %.1f)\n",
      load_s, m.face_count(), m.is_closed(), m.volume_mm3(), mesh().volume_mm3());
  EXPECT_TRUE(m.is_closed());
  EXPECT_LT((m.bounds().min() - mesh().bounds().min()).norm(), 0.011);
  EXPECT_LT((m.bounds().max() - mesh().bounds().max()).norm(), 0.011);
  std::map<CadFace::Kind, int> kinds, step_kinds;
  for (const CadFace& f : model->faces) ++kinds[f.kind];
  for (const CadFace& f : s_model->faces) ++step_kinds[f.kind];
  EXPECT_EQ(kinds, step_kinds);  // every analytic face recognised from IGES surfaces
  int off_faces = 0;
  for (const CadFace& f : model->faces) {
    double worst = 0;
    for (auto t : f.triangles) {
      const auto& tri = m.faces()[t];
      const Vec3 c = (m.vertices()[tri[0]] + m.vertices()[tri[1]] + m.vertices()[tri[2]]) / 3;
      worst = std::max(worst, mesh().closest(c).distance_mm);
    }
    if (worst < 0.011) continue;
    ++off_faces;
    std::printf("    IGES face %u (%s r %.2f at %s) is up to %.2f mm off the STEP part\n", f.shape_index,
                kind_name(f.kind), f.radius_mm, fmt_vec(f.origin).c_str(), worst);
    EXPECT_EQ(f.kind, CadFace::Kind::Sphere) << "face " << f.shape_index;
  }
  EXPECT_LE(off_faces, 18);
}
