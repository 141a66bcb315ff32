// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>

#include "metron/machine/contact.hpp"
#include "metron/machine/csg_solid.hpp"
#include "metron/machine/mesh_solid.hpp"
#include "metron/machine/world.hpp"
#include "metron/machine/world_solid.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

csg::Node leaf(
    std::string name,
    std::variant<csg::HalfSpace, csg::Cylinder, csg::Sphere, csg::Cone, csg::Torus, csg::EllipticCylinder> shape) {
  csg::Node n;
  n.primitive = {std::move(name), std::move(shape)};
  return n;
}

csg::Node op(csg::Node::Op o, std::vector<csg::Node> children) {
  csg::Node n;
  n.op = o;
  n.children = std::move(children);
  return n;
}

// Random points in a box, from a fixed seed (the failing point is printed by the EXPECT).
std::vector<Vec3> random_points(int n, const Vec3& lo, const Vec3& hi, std::uint64_t seed = 7) {
  std::mt19937_64 g(seed);
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) {
    Vec3 p;
    for (int k = 0; k < 3; ++k) p[k] = lo[k] + (hi[k] - lo[k]) * (static_cast<double>(g() >> 11) * 0x1.0p-53);
    out.push_back(p);
  }
  return out;
}

}  // namespace

TEST(Solid, PrimitiveDistancesAreExact) {
  const Frame id = Frame::Identity();
  const CsgSolid plane(leaf("P", csg::HalfSpace{{1, 2, 3}, Vec3(1, 1, 0).normalized()}), id);
  const CsgSolid sphere(leaf("S", csg::Sphere{{1, 2, 3}, 10}), id);
  const CsgSolid cylinder(leaf("C", csg::Cylinder{{1, 2, 3}, Vec3::UnitZ(), 10, std::nullopt}), id);
  const CsgSolid capped(leaf("K", csg::Cylinder{{0, 0, 0}, Vec3::UnitZ(), 10, 20.0}), id);
  const CsgSolid cone(leaf("N", csg::Cone{{0, 0, 0}, Vec3::UnitZ(), 30}), id);
  const double a = 30 * std::numbers::pi / 180;
  for (const Vec3& p : random_points(500, Vec3(-30, -30, -30), Vec3(30, 30, 30))) {
    EXPECT_NEAR(plane.signed_distance(p), (p - Vec3(1, 2, 3)).dot(Vec3(1, 1, 0).normalized()), 1e-12) << p.transpose();
    EXPECT_NEAR(sphere.signed_distance(p), (p - Vec3(1, 2, 3)).norm() - 5, 1e-12);
    EXPECT_NEAR(cylinder.signed_distance(p), std::hypot(p.x() - 1, p.y() - 2) - 5, 1e-12);
    // Capped cylinder: brute force over the boundary's three pieces.
    const double rho = std::hypot(p.x(), p.y());
    const bool inside = rho < 5 && p.z() > 0 && p.z() < 20;
    const double to_side = std::hypot(rho - 5, std::max({0.0, -p.z(), p.z() - 20}));
    const double to_caps =
        std::min(std::hypot(std::max(0.0, rho - 5), p.z()), std::hypot(std::max(0.0, rho - 5), p.z() - 20));
    EXPECT_NEAR(capped.signed_distance(p),
                inside ? -std::min({5 - rho, p.z(), 20 - p.z()}) : std::min(to_side, to_caps), 1e-12)
        << p.transpose();
    // Cone: distance to the generator in the point's half-plane, or to the apex.
    const double along = rho * std::sin(a) + p.z() * std::cos(a);
    EXPECT_NEAR(cone.signed_distance(p), along < 0 ? p.norm() : rho * std::cos(a) - p.z() * std::sin(a), 1e-12);
  }
}

TEST(Solid, TorusDistanceIsTheDistanceFromItsCentreCircleLessTheTube) {
  // A ring about a tilted axis; the oracle samples the centre circle densely (no closed form).
  const Vec3 centre(1, 2, 3), axis = Vec3(0.3, -0.2, 1).normalized();
  const CsgSolid ring(leaf("T", csg::Torus{centre, axis, 24, 6}), Frame::Identity());
  const Vec3 e1 = axis.cross(Vec3::UnitX()).normalized(), e2 = axis.cross(e1);
  for (const Vec3& p : random_points(200, Vec3(-25, -25, -25), Vec3(25, 25, 25))) {
    double nearest = 1e300;
    for (int i = 0; i < 200000; ++i) {
      const double u = 2 * std::numbers::pi * i / 200000;
      nearest = std::min(nearest, (p - centre - 12 * (std::cos(u) * e1 + std::sin(u) * e2)).norm());
    }
    EXPECT_NEAR(ring.signed_distance(p), nearest - 3, 1e-6) << p.transpose();
  }
}

TEST(Solid, EllipticCylinderDistanceIsTheDistanceFromItsSection) {
  // An elliptic boss, capped, on a tilted axis with its major axis along a chosen direction; the
  // oracle samples the section densely, and the caps as the capped cylinder's.
  const Vec3 point(1, 2, 3), axis = Vec3(0.2, -0.1, 1).normalized();
  const Vec3 major = axis.cross(Vec3::UnitY()).normalized(), minor = axis.cross(major);
  const CsgSolid boss(leaf("E", csg::EllipticCylinder{point, axis, major, 30, 16, 10.0}), Frame::Identity());
  const CsgSolid shaft(leaf("E", csg::EllipticCylinder{point, axis, major, 30, 16, std::nullopt}), Frame::Identity());
  for (const Vec3& p : random_points(200, Vec3(-25, -25, -20), Vec3(25, 25, 25))) {
    const Vec3 q = p - point;
    const double x = q.dot(major), y = q.dot(minor), z = q.dot(axis);
    double nearest = 1e300;
    for (int i = 0; i < 200000; ++i) {
      const double t = 2 * std::numbers::pi * i / 200000;
      nearest = std::min(nearest, std::hypot(x - 15 * std::cos(t), y - 8 * std::sin(t)));
    }
    const double section = (x / 15) * (x / 15) + (y / 8) * (y / 8) < 1 ? -nearest : nearest;
    EXPECT_NEAR(shaft.signed_distance(p), section, 1e-6) << p.transpose();
    const double dz = std::abs(z - 5) - 5;
    EXPECT_NEAR(boss.signed_distance(p),
                std::min(std::max(section, dz), 0.0) + std::hypot(std::max(section, 0.0), std::max(dz, 0.0)), 1e-6)
        << p.transpose();
  }
}

TEST(Solid, DefaultBlockDistancesNearFaces) {
  const auto part = make_part_solid(default_world().truth);
  const Vec3 o(300, 200, 0);                                                            // part origin in the machine
  EXPECT_NEAR(part->signed_distance(o + Vec3(20, 20, 42.5)), 2.5, 1e-12);               // above TOP
  EXPECT_NEAR(part->signed_distance(o + Vec3(-3, 50, 20)), 3, 1e-12);                   // left of LEFT
  EXPECT_NEAR(part->signed_distance(o + Vec3(40, 57, 30)), 3, 1e-12);                   // in BORE1, 3 mm from the wall
  EXPECT_NEAR(part->signed_distance(o + Vec3(40, 50, 17)), 2, 1e-12);                   // above BORE1's bottom
  EXPECT_NEAR(part->signed_distance(o + Vec3(75, 75, 61)), 3, 1e-12);                   // above SPHERE1
  EXPECT_NEAR(part->signed_distance(o + Vec3(120, 85, 50)), 3, 1e-12);                  // beside BOSS1
  EXPECT_NEAR(part->signed_distance(o + Vec3(120, 70, 56)), 1, 1e-12);                  // above BOSS1_TOP
  EXPECT_NEAR(part->signed_distance(o + Vec3(40, 20, 40)), 8 * std::sqrt(0.5), 1e-12);  // CONE1 axis at the top
  EXPECT_LT(part->signed_distance(o + Vec3(10, 10, 10)), 0);                            // material
  EXPECT_EQ(part->feature_at(o + Vec3(20, 20, 42.5)), "TOP");
  EXPECT_EQ(part->feature_at(o + Vec3(40, 57, 30)), "BORE1");
  EXPECT_EQ(part->feature_at(o + Vec3(75, 75, 61)), "SPHERE1");
  EXPECT_EQ(part->feature_at(o + Vec3(41, 21, 37)), "CONE1");
  const Vec3 n = part->normal(o + Vec3(20, 20, 42.5));
  EXPECT_NEAR((n - Vec3::UnitZ()).norm(), 0, 1e-8);
}

TEST(Solid, BallContactIsExactOnPlaneSphereBoreAndCone) {
  const auto part = make_part_solid(default_world().truth);
  const Vec3 o(300, 200, 0);
  const double r = 2;
  // TOP, straight down: the centre stops at z = 42.
  auto s = first_ball_contact(*part, o + Vec3(20, 20, 50), o + Vec3(20, 20, 30), r);
  ASSERT_TRUE(s);
  EXPECT_NEAR(50 - 20 * *s, 42, 1e-9);
  // SPHERE1 along an oblique ray through its centre: contact at distance 12 from the centre.
  const Vec3 c = o + Vec3(75, 75, 48), d = Vec3(1, 1, 1).normalized();
  s = first_ball_contact(*part, c + 30 * d, c, r);
  ASSERT_TRUE(s);
  EXPECT_NEAR(30 - 30 * *s, 12, 1e-9);
  // BORE1 from its axis outward: centre stops at radius 8.
  const Vec3 axis = o + Vec3(40, 50, 30), out = Vec3(std::cos(0.3), std::sin(0.3), 0);
  s = first_ball_contact(*part, axis, axis + 20 * out, r);
  ASSERT_TRUE(s);
  EXPECT_NEAR(20 * *s, 8, 1e-9);
  // CONE1 along the wall normal: the centre stops r from the wall.
  const Vec3 apex = o + Vec3(40, 20, 32);
  const Vec3 wall = apex + Vec3(4, 0, 4), air_normal = Vec3(-1, 0, 1).normalized();
  s = first_ball_contact(*part, wall + 3 * air_normal, wall, 1.0);
  ASSERT_TRUE(s);
  EXPECT_NEAR(3 - 3 * *s, 1.0, 1e-9);
  // A miss.
  EXPECT_FALSE(first_ball_contact(*part, o + Vec3(-10, -10, 100), o + Vec3(200, -10, 100), r));
}

TEST(Solid, ThinFeaturesAreNotTunnelled) {
  // A 0.1 mm wall crossed by a long move in one step.
  const auto wall = op(csg::Node::Op::Intersection, {leaf("A", csg::HalfSpace{{0, 0, 0.05}, Vec3::UnitX()}),
                                                     leaf("B", csg::HalfSpace{{-0.05, 0, 0}, -Vec3::UnitX()})});
  const CsgSolid solid(wall, Frame::Identity());
  const auto s = first_ball_contact(solid, Vec3(-500, 0, 0), Vec3(500, 0, 0), 0.5);
  ASSERT_TRUE(s);
  EXPECT_NEAR(-500 + 1000 * *s, -0.55, 1e-9);
}

TEST(Solid, StartingInContactIsFreeOnlyWhenMovingAway) {
  const CsgSolid plane(leaf("P", csg::HalfSpace{{0, 0, 0}, Vec3::UnitZ()}), Frame::Identity());
  // A deflected stylus 0.05 mm "into" the surface retracting: free, and no false contact.
  EXPECT_FALSE(first_ball_contact(plane, Vec3(0, 0, 1.95), Vec3(0, 0, 4), 2.0));
  // Pushing further in: contact at once.
  const auto s = first_ball_contact(plane, Vec3(0, 0, 1.95), Vec3(0, 0, 1.0), 2.0);
  ASSERT_TRUE(s);
  EXPECT_EQ(*s, 0.0);
  // Leaving and coming back down elsewhere is a new contact.
  const CsgSolid steps(op(csg::Node::Op::Union,
                          {leaf("P", csg::HalfSpace{{0, 0, 0}, Vec3::UnitZ()}), leaf("Q", csg::Sphere{{10, 0, 0}, 4})}),
                       Frame::Identity());
  EXPECT_TRUE(first_ball_contact(steps, Vec3(0, 0, 1.99), Vec3(10, 0, 3), 2.0));
}

TEST(Solid, DeviationsMoveResizeTiltAndShapePrimitives) {
  const World w = default_world();
  const csg::Node& design = std::get<csg::Node>(w.truth.part->design);
  const Frame pose = w.truth.part->pose.part_to_machine();
  const Vec3 o(300, 200, 0);
  const Vec3 in_bore = o + Vec3(40 + 7, 50, 30);  // 3 mm from the nominal wall at +x
  {
    csg::Deviation d;
    d.size_mm = 0.012;
    d.offset_mm = Vec3(0.03, 0, 0);
    const CsgSolid s(design, pose, {{"BORE1", d}});
    EXPECT_NEAR(s.signed_distance(in_bore), 3 + 0.006 + 0.03, 1e-12);
  }
  {
    csg::Deviation d;
    d.tilt_deg = Vec2(0.05, 0);  // about the part's x: the normal leans toward -y
    const CsgSolid s(design, pose, {{"TOP", d}});
    const Vec3 n = s.normal(o + Vec3(20, 20, 42));
    EXPECT_NEAR(n.y(), -std::sin(0.05 * std::numbers::pi / 180), 1e-9);
    // The pivot (80, 50, 40) stays: 1 mm above it is cos(tilt) from the tilted plane.
    EXPECT_NEAR(s.signed_distance(o + Vec3(80, 50, 41)), std::cos(0.05 * std::numbers::pi / 180), 1e-12);
  }
  {
    csg::Deviation d;
    d.lobing = csg::Lobing{3, 0.005, 0};
    const CsgSolid s(design, pose, {{"BOSS1", d}});
    // Outer cylinder radius 12: at azimuth 0 the material reaches 12.005, at 60 degrees 11.995.
    EXPECT_NEAR(s.signed_distance(o + Vec3(120 + 14, 70, 47)), 2 - 0.005, 1e-12);
    const Vec3 at60 = o + Vec3(120, 70, 47) + 14 * Vec3(0.5, std::sqrt(0.75), 0);
    EXPECT_NEAR(s.signed_distance(at60), 2 + 0.005, 1e-12);
    EXPECT_GT(s.lipschitz(), 1.0);
  }
  EXPECT_THROW(CsgSolid(design, pose, {{"NOPE", csg::Deviation{}}}), std::invalid_argument);
}

TEST(Solid, WorldSolidHasTableReferenceSphereAndPost) {
  const World w = default_world();
  const auto all = make_world_solid(w.truth);
  EXPECT_NEAR(all->signed_distance(Vec3(600, 600, 5)), 5, 1e-12);  // the table
  EXPECT_EQ(all->feature_at(Vec3(600, 600, 5)), "TABLE");
  EXPECT_NEAR(all->signed_distance(Vec3(900, 700, 120)), 7.5, 1e-12);  // the sphere's top
  EXPECT_EQ(all->feature_at(Vec3(900, 700, 120)), "REFERENCE_SPHERE");
  EXPECT_NEAR(all->signed_distance(Vec3(910, 700, 50)), 5, 1e-12);  // the post
  EXPECT_EQ(all->feature_at(Vec3(910, 700, 50)), "REFERENCE_POST");
}

TEST(Solid, RoughnessIsASmallFixedFieldPerSeed) {
  World w = default_world();
  const auto smooth = make_part_solid(w.truth);
  w.truth.part->roughness = Roughness{0.001, 0.5};
  const auto rough = make_part_solid(w.truth);
  const auto again = make_part_solid(w.truth);
  w.truth.part->seed = 2;
  const auto other = make_part_solid(w.truth);
  double largest = 0;
  bool differs = false;
  for (const Vec3& p : random_points(300, Vec3(300, 200, 38), Vec3(460, 300, 42))) {
    const double d = smooth->signed_distance(p) - rough->signed_distance(p);
    largest = std::max(largest, std::abs(d));
    EXPECT_LE(std::abs(d), 0.001);
    EXPECT_EQ(rough->signed_distance(p), again->signed_distance(p));
    differs = differs || rough->signed_distance(p) != other->signed_distance(p);
  }
  EXPECT_GT(largest, 0.0003);
  EXPECT_TRUE(differs);
  EXPECT_GT(rough->lipschitz(), 1.0);
}

// ---------------------------------------------------------------------------------------------
// Exact contact on CAD faces (docs/world.md): the NIST simple part against its analytic truth.

namespace {

const std::string simple_part_step = std::string(METRON_SHARED_DATA) + "/nist-simple-part/ipp_simple.stp";

// The simple part as designed: the block [0,100]^2 x [0,50] minus the bore of radius 25 about
// (50, 50) from z = 25 up. Brute force over its seven trimmed faces: the exact signed distance,
// and how much farther the second nearest face is (a margin that tells face interiors from edges).
struct Truth {
  double distance_mm;
  double margin_mm;
};
Truth simple_part_truth(const Vec3& p) {
  const double x = p.x(), y = p.y(), z = p.z(), rho = std::hypot(x - 50, y - 50);
  const auto out = [](double v, double lo, double hi) { return std::max({0.0, lo - v, v - hi}); };
  const double in_square = std::hypot(out(x, 0, 100), out(y, 0, 100));
  std::vector<double> faces = {
      std::hypot(in_square, z),                                                 // bottom
      std::hypot(x, out(y, 0, 100), out(z, 0, 50)),                             // x = 0
      std::hypot(x - 100, out(y, 0, 100), out(z, 0, 50)),                       // x = 100
      std::hypot(y, out(x, 0, 100), out(z, 0, 50)),                             // y = 0
      std::hypot(y - 100, out(x, 0, 100), out(z, 0, 50)),                       // y = 100
      std::hypot(in_square > 0 ? in_square : std::max(0.0, 25 - rho), z - 50),  // top, less the bore
      std::hypot(rho - 25, out(z, 25, 50)),                                     // bore wall
      std::hypot(std::max(0.0, rho - 25), z - 25),                              // bore bottom
  };
  std::sort(faces.begin(), faces.end());
  const bool inside = in_square == 0 && z > 0 && z < 50 && !(rho < 25 && z > 25);
  return {inside ? -faces[0] : faces[0], faces[1] - faces[0]};
}

// Points near the part: around the bore, its rims and bottom, and over the block's faces.
std::vector<Vec3> near_simple_part(int n) {
  auto pts = random_points(n, Vec3(20, 20, 20), Vec3(80, 80, 56), 11);
  for (const Vec3& p : random_points(n, Vec3(-4, -4, -4), Vec3(104, 104, 54), 12)) pts.push_back(p);
  return pts;
}

}  // namespace

TEST(Solid, StepFacesAreExactAndNeverFartherThanTheChordTolerance) {
  if (!std::filesystem::exists(simple_part_step)) GTEST_SKIP() << "shared data folder absent: " << METRON_SHARED_DATA;
  const World w = *load_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/nist_simple_part.json");
  const auto& cad = std::get<CadDesign>(w.truth.part->design);
  ASSERT_TRUE(cad.faces);
  const double chord = cad.chord_tolerance_mm;
  EXPECT_EQ(chord, 0.001);
  const MeshSolid exact(cad.mesh, Frame::Identity(), {}, *cad.faces, chord);
  const MeshSolid mesh_only(cad.mesh, Frame::Identity());
  EXPECT_EQ(exact.analytic_face_count(), cad.faces->size());  // planes and one cylinder
  double worst_interior = 0, worst_over = 0, worst_under = 0, worst_mesh_interior = 0;
  int interior = 0;
  for (const Vec3& p : near_simple_part(4000)) {
    const Truth t = simple_part_truth(p);
    const double v = exact.signed_distance(p);
    // Sphere tracing stays safe: never more than the chord tolerance above the truth.
    ASSERT_LE(v - t.distance_mm, chord + 1e-12) << p.transpose();
    // Below it only near edges, by at most the mesh's error plus the guard (1.5 chords).
    ASSERT_GE(v - t.distance_mm, -2.5 * chord - 1e-6) << p.transpose();
    worst_over = std::max(worst_over, v - t.distance_mm);
    worst_under = std::min(worst_under, v - t.distance_mm);
    if (t.margin_mm > 0.01 && std::abs(t.distance_mm) < 10) {  // the nearest face is clear
      ++interior;
      EXPECT_NEAR(v, t.distance_mm, 1e-9) << p.transpose();
      worst_interior = std::max(worst_interior, std::abs(v - t.distance_mm));
      worst_mesh_interior = std::max(worst_mesh_interior, std::abs(mesh_only.signed_distance(p) - t.distance_mm));
    }
  }
  EXPECT_GT(interior, 4000);
  std::printf("  simple part: %d face-interior points, error %.2g mm (mesh only %.2g mm); near edges %.2g to %.2g mm\n",
              interior, worst_interior, worst_mesh_interior, worst_under, worst_over);
  // Normals: the bore wall's is radial, toward the axis.
  const Vec3 q(50 + 20 * std::cos(0.1), 50 + 20 * std::sin(0.1), 40);
  EXPECT_NEAR((exact.normal(q) - Vec3(-std::cos(0.1), -std::sin(0.1), 0)).norm(), 0, 1e-12);
  EXPECT_NEAR((exact.normal(Vec3(10, 10, 53)) - Vec3::UnitZ()).norm(), 0, 1e-12);
}

TEST(Solid, BallContactOnAStepPartIsSafe) {
  if (!std::filesystem::exists(simple_part_step)) GTEST_SKIP() << "shared data folder absent: " << METRON_SHARED_DATA;
  const World w = *load_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/nist_simple_part.json");
  const auto part = make_part_solid(w.truth);
  const double r = 1.5, chord = 0.001;
  // Random moves from the air toward the part: at the contact the true gap is within the chord
  // tolerance of zero, and before it the ball never overlapped the true part by more than that.
  const auto from = random_points(300, Vec3(-10, -10, 52), Vec3(110, 110, 70), 21);
  const auto to = random_points(300, Vec3(10, 10, 0), Vec3(90, 90, 20), 22);  // in material
  int contacts = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const auto s = first_ball_contact(*part, from[i], to[i], r);
    ASSERT_TRUE(s) << from[i].transpose() << " -> " << to[i].transpose();
    ++contacts;
    const Vec3 d = to[i] - from[i];
    EXPECT_GE(simple_part_truth(from[i] + *s * d).distance_mm - r, -chord - 1e-9);
    EXPECT_LE(simple_part_truth(from[i] + *s * d).distance_mm - r, 2.5 * chord + 1e-6);
    for (int k = 0; k < 200; ++k) {
      const double sk = *s * k / 200;
      ASSERT_GE(simple_part_truth(from[i] + sk * d).distance_mm - r, -chord - 1e-9)
          << from[i].transpose() << " -> " << to[i].transpose() << " at " << sk;
    }
  }
  EXPECT_EQ(contacts, 300);
}
