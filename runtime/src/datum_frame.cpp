// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/datum_frame.hpp"

#include "metron/runtime/alignment_ops.hpp"

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <numbers>

namespace metron::runtime {

namespace {

using Error = tl::unexpected<std::string>;

bool has_direction(FeatureType t) { return t != FeatureType::Point && t != FeatureType::Sphere; }

/// The translation directions a datum feature fixes (rows): a plane or PARPLN its normal; an axis (line,
/// circle, arc, cylinder) the two directions across it; a point, sphere centre or cone apex all three.
Eigen::MatrixXd fixed_translations(const Geometry& nominal) {
  const Vec3 n = nominal.direction.normalized();
  switch (nominal.type) {
    case FeatureType::Plane:
    case FeatureType::ParallelPlanes: return n.transpose();  // a PARPLN: its median plane
    case FeatureType::Line:
    case FeatureType::Circle:
    case FeatureType::Arc:
    case FeatureType::ClosedSlot:  // its centre, in its plane (its long axis orients: fit_datum_frame)
    case FeatureType::Cylinder: {
      const Vec3 u = n.unitOrthogonal();
      Eigen::MatrixXd rows(2, 3);
      rows.row(0) = u.transpose();
      rows.row(1) = n.cross(u).transpose();
      return rows;
    }
    default: return Eigen::Matrix3d::Identity();
  }
}

/// A rotation about the line through `pivot`, as a rigid motion.
Frame rotation_about(const Vec3& pivot, const Eigen::Matrix3d& rotation) {
  Frame motion = Frame::Identity();
  motion.linear() = rotation;
  motion.translation() = pivot - rotation * pivot;
  return motion;
}

/// `v` without its component along the unit `axis`.
Vec3 across(const Vec3& v, const Vec3& axis) { return v - v.dot(axis) * axis; }

/// A direction within 1 degree of the rotation axis does not orient the frame about it.
constexpr double k_min_sine = 0.0175;
/// A location within 1 um of the rotation axis does not orient the frame about it.
constexpr double k_min_offset_mm = 1e-3;

}  // namespace

tl::expected<DatumFrame, std::string> fit_datum_frame(const std::vector<const Datum*>& datums,
                                                      const Frame& feature_frame, DatumNominals nominals) {
  enum class Rotation { Free, AboutAxis, Fixed };
  DatumFrame frame;
  Frame& motion = frame.actual_to_nominal;
  Eigen::MatrixXd free_translations = Eigen::Matrix3d::Identity();  // columns span what is still free
  Rotation rotation = Rotation::Free;
  Vec3 axis = Vec3::UnitZ();
  Vec3 axis_point = Vec3::Zero();  // a point of the rotation axis that the datums so far hold
  bool axis_located = false;       // no translation across the axis is free any more
  Vec3 anchor = Vec3::Zero();      // the nominal position of the first datum that fixed a translation
  bool anchored = false;
  std::string labels;

  for (const Datum* datum : datums) {
    if (!datum) throw std::invalid_argument("fit_datum_frame: null datum");
    labels += (labels.empty() ? "" : "|") + datum->label;
    if (datum->geometry.type != datum->nominal.type)
      return Error(fmt::format("datum {}: its actual is {} and its nominal {}: they cannot be matched", datum->label,
                               dmis_word(datum->geometry.type), dmis_word(datum->nominal.type)));
    const Geometry nominal = nominals == DatumNominals::InFeaturesFrame
                                 ? to_machine(datum->nominal, feature_frame * datum->nominal_frame.inverse())
                                 : datum->nominal;
    Geometry actual = to_machine(datum->geometry, motion);
    const bool all_fixed_before = free_translations.cols() == 0;

    // Orientation: the datum's direction, then (about an axis already set) its location.
    bool oriented = false;
    if (has_direction(nominal.type)) {
      const Vec3 dn = nominal.direction.normalized();
      Vec3 da = actual.direction.normalized();
      if (da.dot(dn) < 0) da = -da;  // axes have no sense
      if (rotation == Rotation::Free) {
        const Eigen::Matrix3d r = Eigen::Quaterniond::FromTwoVectors(da, dn).toRotationMatrix();
        motion = rotation_about(anchored ? anchor : actual.position, r) * motion;
        rotation = Rotation::AboutAxis;
        axis = dn;
        frame.rotations_fixed += 2;
        oriented = true;
      } else if (rotation == Rotation::AboutAxis) {
        Vec3 pa = across(da, axis);
        Vec3 pn = across(dn, axis);
        if (nominal.type == FeatureType::ClosedSlot && (pa.norm() <= k_min_sine || pn.norm() <= k_min_sine)) {
          // A slot in the primary plane: its long axis (no sense, like an axis) turns the frame.
          const Vec3 sn = nominal.slot_axis.normalized();
          Vec3 sa = actual.slot_axis.normalized();
          if (sa.dot(sn) < 0) sa = -sa;
          pa = across(sa, axis);
          pn = across(sn, axis);
        }
        if (pa.norm() > k_min_sine && pn.norm() > k_min_sine) {
          const double angle = std::atan2(axis.dot(pa.cross(pn)), pa.dot(pn));
          motion = rotation_about(axis_point, Eigen::AngleAxisd(angle, axis).toRotationMatrix()) * motion;
          rotation = Rotation::Fixed;
          frame.rotations_fixed += 1;
          oriented = true;
        }
      }
    }
    if (!oriented && rotation == Rotation::AboutAxis && axis_located && nominal.type != FeatureType::Plane &&
        nominal.type != FeatureType::ParallelPlanes) {
      actual = to_machine(datum->geometry, motion);
      const Vec3 va = across(actual.position - axis_point, axis);
      const Vec3 vn = across(nominal.position - axis_point, axis);
      if (va.norm() > k_min_offset_mm && vn.norm() > k_min_offset_mm) {
        const double angle = std::atan2(axis.dot(va.cross(vn)), va.dot(vn));
        motion = rotation_about(axis_point, Eigen::AngleAxisd(angle, axis).toRotationMatrix()) * motion;
        rotation = Rotation::Fixed;
        frame.rotations_fixed += 1;
      }
    }

    // Location: the translation, within what is still free, that best puts the actual datum on
    // its nominal along the directions this datum fixes (least squares when they overlap).
    actual = to_machine(datum->geometry, motion);
    bool located_here = false;
    if (free_translations.cols() > 0) {
      const Eigen::MatrixXd rows = fixed_translations(nominal);
      const Eigen::MatrixXd a = rows * free_translations;
      const Eigen::VectorXd wanted = rows * (nominal.position - actual.position);
      const Eigen::VectorXd x = a.completeOrthogonalDecomposition().solve(wanted);
      Frame shift = Frame::Identity();
      shift.translation() = free_translations * x;
      motion = shift * motion;
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
      const auto& sv = svd.singularValues();
      int rank = 0;
      for (Eigen::Index i = 0; i < sv.size(); ++i)
        if (sv[i] > 1e-9) ++rank;
      const Eigen::Index left = free_translations.cols() - rank;
      free_translations = (free_translations * svd.matrixV().rightCols(left)).eval();
      frame.translations_fixed += rank;
      if (rank > 0 && !anchored) {
        anchor = nominal.position;
        anchored = true;
      }
      located_here = rank > 0;
    }
    if (rotation == Rotation::AboutAxis && !axis_located) {
      bool across_free = false;
      for (Eigen::Index c = 0; c < free_translations.cols(); ++c)
        if (across(free_translations.col(c), axis).norm() > 1e-9) across_free = true;
      if (!across_free) {
        axis_located = true;
        axis_point = (oriented && all_fixed_before) || !located_here ? anchor : nominal.position;
      } else if (oriented) {
        axis_point = nominal.position;  // on the primary plane: any line along its normal keeps it
      }
    }
  }

  const Eigen::AngleAxisd turn(motion.linear());
  frame.description = fmt::format(
      "datum reference frame {}: {} of 3 rotations and {} of 3 translations fixed, turned {:.4f} deg onto the "
      "datums' nominals",
      labels, frame.rotations_fixed, frame.translations_fixed, turn.angle() * 180.0 / std::numbers::pi);
  return frame;
}

}  // namespace metron::runtime
