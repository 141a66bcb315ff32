// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "metron/runtime/alignment.hpp"
#include "metron/runtime/feature.hpp"

namespace metron::runtime {

/// A part axis named by DMIS minor words (XDIR, YMINUS, XORIG, XAXIS ...).
enum class Axis { X = 0, Y = 1, Z = 2 };

/// One clause of DATSET: a datum feature and what it defines.
struct DatsetClause {
  Geometry datum;                 ///< the datum's geometry (MCS)
  std::optional<Axis> direction;  ///< XDIR/YDIR/ZDIR (or MINUS): the axis this datum orients
  bool minus = false;             ///< XMINUS/YMINUS/ZMINUS
  std::vector<Axis> origins;      ///< XORIG/YORIG/ZORIG: axes whose origin this datum fixes
};

/// DATSET: orients the first direction clause exactly, the second projected perpendicular to it,
/// completes a right-handed frame from the current one, then places the origins.
tl::expected<Frame, std::string> datset(const Frame& current, const std::vector<DatsetClause>& clauses);

/// TRANS/XORIG,v,...: moves the origin to the given current-frame coordinates (nullopt = keep).
Frame translate_origin(const Frame& current, const std::optional<double> (&origin)[3]);

/// ROTATE/axis,angle: rotates the frame about its own axis by `angle_deg` (counter-clockwise).
Frame rotate_about(const Frame& current, Axis axis, double angle_deg);

/// ROTATE/axis,FA(f),XDIR: rotates about `axis` so that the named frame axis points along the
/// projection of `direction` (MCS) onto the plane normal to `axis`.
tl::expected<Frame, std::string> rotate_to(const Frame& current, Axis about, const Vec3& direction, Axis align);

/// Expresses MCS geometry in the frame (part coordinates) and back.
Geometry to_frame(const Geometry& mcs, const Frame& part_to_machine);
Geometry to_machine(const Geometry& part, const Frame& part_to_machine);

}  // namespace metron::runtime
