// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "metron/runtime/feature.hpp"
#include "metron/runtime/tolerance.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::interpreter::ir {

/// FEDRAT/kind: which feed a statement sets.
enum class FeedKind { Mesvel, Posvel, Scnvel };
/// FEDRAT units: metres per minute, mm per second, inches per minute or second, percent of the
/// machine's; DEFALT: back to the machine's own feed (no value).
enum class FeedUnit { Mpm, Mmps, Ipm, Ips, Pcent, Defalt };
/// UNITS length words.
enum class LengthUnit { Mm, Inch, Cm, M, Feet };
/// UNITS angle words (ANGDMS is read as decimal degrees).
enum class AngleUnit { Angdec, Angrad, Angdms };
/// UNITS temperature words (DMIS 5.x: the unit QTEMP answers in).
enum class TemperatureUnit { Tempc, Tempf };
/// MODE/AUTO, MODE/PROG,MAN, MODE/MAN.
enum class RunMode { Auto, ProgMan, Man };
/// How a statement gives its coordinates: CART x,y,z; POL radius,angle,height; GOTO/INCR distance,i,j,k.
enum class CoordinateForm { Cart, Pol, Incr };
/// CONST methods.
enum class ConstructionMethod {
  Bf,
  Intof,
  Midpt,
  Projpt,
  Projln,
  Projct,
  Pierce,  ///< a line-like feature through a surface: INTOF's point
  Movept,  ///< a feature's point moved by dx, dy, dz
  Parto,   ///< PARTO,FA(ref),THRU,FA(point): parallel to ref through the point
  Perpto,  ///< PERPTO,FA(ref),THRU,FA(point): perpendicular to ref through the point
  Cast,    ///< CAST,FA(x): x's geometry as another type (a cylinder's axis as a LINE ...)
  Midpl,   ///< MIDPL,FA(a),FA(b): the plane midway between two planes
  Midli,   ///< MIDLI,FA(a),FA(b): the line midway between two lines
  Copy,    ///< COPY,FA(x): x's geometry under another label
  Vertex,  ///< VERTEX,FA(cone): the cone's apex
  Extrem,  ///< EXTREM,[MIN|MAX,]FA(x),direction: x's measured point furthest along it
  Offset,  ///< OFFSET,FA(plane),d: the plane moved d along its normal
  Tanto,   ///< TANTO: a LINE tangent to two circles (or a circle and a point), a CIRCLE tangent to lines
  Cone
};  ///< CONE,FA(cone),DIAM|DIST,v: the cone's section of diameter v, or v from its vertex

/// One row of a vocabulary: an enumerator and its DMIS word.
template <class E>
struct WordEntry {
  E value;
  std::string_view word;
};

/// The vocabulary of a kind of word, in the order error messages list it (ir_vocabulary.cpp; the
/// feature type and tolerance words are the runtime's dmis_word()).
template <class E>
const std::vector<WordEntry<E>>& vocabulary();

template <>
const std::vector<WordEntry<runtime::FeatureType>>& vocabulary();
template <>
const std::vector<WordEntry<runtime::ToleranceKind>>& vocabulary();
template <>
const std::vector<WordEntry<FeedKind>>& vocabulary();
template <>
const std::vector<WordEntry<FeedUnit>>& vocabulary();
template <>
const std::vector<WordEntry<LengthUnit>>& vocabulary();
template <>
const std::vector<WordEntry<AngleUnit>>& vocabulary();
template <>
const std::vector<WordEntry<TemperatureUnit>>& vocabulary();
template <>
const std::vector<WordEntry<RunMode>>& vocabulary();
template <>
const std::vector<WordEntry<CoordinateForm>>& vocabulary();
template <>
const std::vector<WordEntry<ConstructionMethod>>& vocabulary();

/// The enumerator a DMIS word names, or nullopt.
template <class E>
std::optional<E> parse_word(std::string_view word) {
  for (const auto& row : vocabulary<E>())
    if (row.word == word) return row.value;
  return std::nullopt;
}

/// The DMIS word of an enumerator.
template <class E>
std::string_view word_of(E value) {
  for (const auto& row : vocabulary<E>())
    if (row.value == value) return row.word;
  return "?";
}

/// The words of a vocabulary joined with ", " (for messages: "MM, INCH, CM, M, FEET").
template <class E>
std::string word_list() {
  std::string out;
  for (const auto& row : vocabulary<E>()) out += (out.empty() ? "" : ", ") + std::string(row.word);
  return out;
}

/// Millimetres per program length unit.
double millimetres_per(LengthUnit unit);
/// A FEDRAT value in mm/s; nullopt for PCENT (relative to the machine's current feed).
std::optional<double> feed_mm_s(double value, FeedUnit unit);
/// A program position in mm: CART x,y,z or POL radius,angle,height (angle in degrees), each
/// length times `length_mm` (mm per program unit).
Vec3 position_mm(CoordinateForm form, double a, double b, double c, double length_mm, double degrees_per_unit);

}  // namespace metron::interpreter::ir
