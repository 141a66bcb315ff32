// SPDX-License-Identifier: GPL-3.0-or-later
// The DMIS word vocabularies of the IR: one table per kind, for parsing (compiler) and printing
// (--emit-ir, messages); the conversions the words imply.
#include "metron/interpreter/ir/vocabulary.hpp"

#include <cmath>

namespace metron::interpreter::ir {
namespace {

// Feature types and tolerance kinds are spelled by the runtime (its outputs print them).
template <class E>
std::vector<WordEntry<E>> from_runtime(std::initializer_list<E> values) {
  std::vector<WordEntry<E>> rows;
  for (E v : values) rows.push_back({v, runtime::dmis_word(v)});
  return rows;
}

}  // namespace

template <>
const std::vector<WordEntry<runtime::FeatureType>>& vocabulary() {
  using T = runtime::FeatureType;
  static const auto rows =
      from_runtime({T::Point, T::Plane, T::Line, T::Circle, T::Arc, T::Sphere, T::Cylinder, T::Cone, T::ParallelPlanes,
                    T::GenericSurface, T::GenericCurve, T::ClosedSlot, T::Torus, T::Ellipse});
  return rows;
}

template <>
const std::vector<WordEntry<runtime::ToleranceKind>>& vocabulary() {
  using K = runtime::ToleranceKind;
  static const auto rows =
      from_runtime({K::Diam,   K::Rad,    K::DistB, K::Pos,   K::Flat,    K::Cirlty, K::Cylcty, K::Sphcty, K::Strght,
                    K::Perp,   K::Parlel, K::Anglb, K::Profs, K::DistWrt, K::AngWrt, K::Cortol, K::Concen, K::Coaxial,
                    K::Crnout, K::Totrun, K::Profl, K::Profp, K::Width,   K::Symmty, K::Angl,   K::Compos, K::Anglr});
  return rows;
}

template <>
const std::vector<WordEntry<FeedKind>>& vocabulary() {
  static const std::vector<WordEntry<FeedKind>> rows = {
      {FeedKind::Mesvel, "MESVEL"}, {FeedKind::Posvel, "POSVEL"}, {FeedKind::Scnvel, "SCNVEL"}};
  return rows;
}

template <>
const std::vector<WordEntry<FeedUnit>>& vocabulary() {
  static const std::vector<WordEntry<FeedUnit>> rows = {{FeedUnit::Mpm, "MPM"},     {FeedUnit::Mmps, "MMPS"},
                                                        {FeedUnit::Ipm, "IPM"},     {FeedUnit::Ips, "IPS"},
                                                        {FeedUnit::Pcent, "PCENT"}, {FeedUnit::Defalt, "DEFALT"}};
  return rows;
}

template <>
const std::vector<WordEntry<LengthUnit>>& vocabulary() {
  static const std::vector<WordEntry<LengthUnit>> rows = {{LengthUnit::Mm, "MM"},
                                                          {LengthUnit::Inch, "INCH"},
                                                          {LengthUnit::Cm, "CM"},
                                                          {LengthUnit::M, "M"},
                                                          {LengthUnit::Feet, "FEET"}};
  return rows;
}

template <>
const std::vector<WordEntry<AngleUnit>>& vocabulary() {
  static const std::vector<WordEntry<AngleUnit>> rows = {
      {AngleUnit::Angdec, "ANGDEC"}, {AngleUnit::Angrad, "ANGRAD"}, {AngleUnit::Angdms, "ANGDMS"}};
  return rows;
}

template <>
const std::vector<WordEntry<TemperatureUnit>>& vocabulary() {
  static const std::vector<WordEntry<TemperatureUnit>> rows = {{TemperatureUnit::Tempc, "TEMPC"},
                                                               {TemperatureUnit::Tempf, "TEMPF"}};
  return rows;
}

template <>
const std::vector<WordEntry<RunMode>>& vocabulary() {
  static const std::vector<WordEntry<RunMode>> rows = {
      {RunMode::Auto, "AUTO"}, {RunMode::ProgMan, "PROG MAN"}, {RunMode::Man, "MAN"}};
  return rows;
}

template <>
const std::vector<WordEntry<CoordinateForm>>& vocabulary() {
  static const std::vector<WordEntry<CoordinateForm>> rows = {
      {CoordinateForm::Cart, "CART"}, {CoordinateForm::Pol, "POL"}, {CoordinateForm::Incr, "INCR"}};
  return rows;
}

template <>
const std::vector<WordEntry<ConstructionMethod>>& vocabulary() {
  using M = ConstructionMethod;
  static const std::vector<WordEntry<M>> rows = {
      {M::Bf, "BF"},         {M::Intof, "INTOF"},   {M::Midpt, "MIDPT"},
      {M::Projpt, "PROJPT"}, {M::Projln, "PROJLN"}, {M::Projct, "PROJCT"},
      {M::Pierce, "PIERCE"}, {M::Movept, "MOVEPT"}, {M::Parto, "PARTO"},
      {M::Perpto, "PERPTO"}, {M::Cast, "CAST"},     {M::Midpl, "MIDPL"},
      {M::Midli, "MIDLI"},   {M::Copy, "COPY"},     {M::Vertex, "VERTEX"},
      {M::Extrem, "EXTREM"}, {M::Offset, "OFFSET"}, {M::Cone, "CONE"},
      {M::Tanto, "TANTO"},   {M::Projln, "PROJLI"}};  // PROJLI: Creo CMM's word for PROJLN
  return rows;
}

double millimetres_per(LengthUnit unit) {
  switch (unit) {
    case LengthUnit::Mm: return 1.0;
    case LengthUnit::Inch: return 25.4;
    case LengthUnit::Cm: return 10.0;
    case LengthUnit::M: return 1000.0;
    case LengthUnit::Feet: return 304.8;
  }
  return 1.0;
}

std::optional<double> feed_mm_s(double value, FeedUnit unit) {
  switch (unit) {
    case FeedUnit::Mpm: return value * 1000.0 / 60.0;
    case FeedUnit::Mmps: return value;
    case FeedUnit::Ipm: return value * 25.4 / 60.0;
    case FeedUnit::Ips: return value * 25.4;
    case FeedUnit::Pcent:
    case FeedUnit::Defalt: return std::nullopt;
  }
  return std::nullopt;
}

Vec3 position_mm(CoordinateForm form, double a, double b, double c, double length_mm, double degrees_per_unit) {
  if (form == CoordinateForm::Pol) {
    const double angle_rad = b * degrees_per_unit * 3.14159265358979323846 / 180.0;
    return Vec3(a * length_mm * std::cos(angle_rad), a * length_mm * std::sin(angle_rad), c * length_mm);
  }
  return Vec3(a * length_mm, b * length_mm, c * length_mm);
}

}  // namespace metron::interpreter::ir
