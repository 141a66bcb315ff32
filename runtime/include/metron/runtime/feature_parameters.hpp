// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <vector>

#include "metron/runtime/feature.hpp"

namespace metron::runtime {

/// What a number of a feature statement measures (for conversion to program units).
enum class ParameterUnit {
  Length,  ///< mm (program length units in the program)
  Cosine,  ///< a direction cosine
  Angle,   ///< degrees
};

/// One number of a feature statement.
struct FeatureParameter {
  double value = 0;
  ParameterUnit unit = ParameterUnit::Length;
};

/// The numbers of `F(x)=FEAT/type,...` in DMIS order, after the words: the one layout that FEAT
/// takes, the DMIS output statement writes and OBTAIN/FA(x),n indexes (n counts the words first,
/// see feature_word_count).
///   POINT, PLANE  x,y,z,i,j,k            LINE BND  x1,y1,z1,x2,y2,z2,i2,j2,k2 (end point, then
///   CIRCLE  x,y,z,i,j,k,d                          the normal of the line's plane)
///   ARC  x,y,z,i,j,k,r,start,included    LINE UNBND  x,y,z,i,j,k,i2,j2,k2
///   SPHERE  x,y,z,d                      CYLNDR  x,y,z,i,j,k,d,len     CONE  x,y,z,i,j,k,angle
///   CPARLN  x,y,z,i1,j1,k1,i2,j2,k2,len,wid (centre, normal of its plane, long axis, length, width)
std::vector<FeatureParameter> feature_parameters(const Geometry& g);

/// The words before the numbers of a feature statement: the type, BND|UNBND (LINE), INNER|OUTER
/// (features of size), ROUND|FLAT (CPARLN) and CART.
std::size_t feature_word_count(FeatureType type);

/// Features of size carry a material side (INNER|OUTER) in their statements.
bool has_side(FeatureType type);

}  // namespace metron::runtime
