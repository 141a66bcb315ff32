#include <gtest/gtest.h>
#include "metron/stdlib/geometry/cad_import.hpp"
TEST(Mesh, Placeholder) {}
