#include <gtest/gtest.h>
#include "metron/stdlib/geometry/cad_import.hpp"
#include <iostream>
TEST(Explore, Step) {
  auto m = metron::geometry::load_cad_model("/work/shared/data/nist-simple-part/ipp_simple.stp");
  ASSERT_TRUE(m) << m.error().message;
  auto b = m->mesh.bounds();
  std::cout << b.min().transpose() << " / " << b.max().transpose() << " closed " << m->mesh.is_closed() << " faces " << m->mesh.face_count() << "\n";
  for (auto& f : m->faces) std::cout << int(f.kind) << " o=" << f.origin.transpose() << " ax=" << f.axis.transpose() << " r=" << f.radius_mm << " inner=" << f.inner << "\n";
}
