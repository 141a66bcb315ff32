// SPDX-License-Identifier: GPL-3.0-or-later
// The results file of `metron calibrate wavefront` (docs/wavefront.md "Results file").
#include <nlohmann/json.hpp>

#include "metron/runtime/wavefront/calibration.hpp"

namespace metron::runtime::wavefront {
namespace {

using nlohmann::json;

json v2(const Vec2& v) { return json::array({v.x(), v.y()}); }
json v3(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

json pom_json(const PartOnMountResult& r) {
  json j;
  j["element"] = r.sphere ? "sphere" : "flat";
  j["unit"] = r.sphere ? "mm" : "rad";
  j["angles_deg"] = r.angles_deg;
  json t = json::array();
  for (const auto& p : r.tilts) t.push_back(v2(p));
  j["tilts"] = t;
  j["centre"] = v2(r.circle.centre);
  j["radius_vector"] = v2(r.circle.radius_vector);
  j["radius"] = r.circle.radius_vector.norm();
  j["residual_rms"] = r.circle.residual_rms;
  j["sense"] = r.circle.sense;
  if (r.geometric) j["geometric_fit"] = {{"centre", v2(r.geometric->centre)}, {"radius", r.geometric->radius}};
  if (r.centroid_circle)
    j["centroid_circle"] = {{"centre_mm", v2(r.centroid_circle->centre)},
                            {"radius_mm", r.centroid_circle->radius_vector.norm()}};
  j["gauge_to_spindle_rad"] = v2(r.gauge_to_spindle_rad);
  j["spindle_to_part_rad"] = v2(r.spindle_to_part_rad);
  j["steps"] = v3(r.steps);
  j["maps"] = r.maps;
  return j;
}

}  // namespace

nlohmann::json to_json(const CalibrationReport& r) {
  json j;
  j["kind"] = "wavefront-calibration";
  j["maps"] = r.maps;
  if (r.part_on_mount) j["part_on_mount"] = pom_json(*r.part_on_mount);
  if (r.gauge_frame) {
    const auto& g = *r.gauge_frame;
    j["gauge_frame"] = {{"gauge_to_a_rad", v2(g.gauge_to_a_rad)},
                        {"a_axis_in_gauge_mm", v2(g.a_axis_in_gauge_mm)},
                        {"residual_rad", v2(g.residual_rad)},
                        {"part_on_mount", pom_json(g.before)},
                        {"maps", g.maps}};
  }
  if (r.axis_response) {
    const auto& a = *r.axis_response;
    j["axis_response"] = {{"step_mm", v3(a.step_mm)},
                          {"gauge_clocking_rad", a.gauge_clocking_rad},
                          {"gauge_axis_to_z_rad", v2(a.gauge_axis_to_z_rad)},
                          {"maps", a.maps}};
  }
  if (r.focus) {
    const auto& f = *r.focus;
    j["focus"] = {{"cat_eye_z_steps", f.cat_eye_z_steps}, {"focus_table_z_steps", f.focus_table_z_steps},
                  {"focus_to_a_mm", v2(f.focus_to_a_mm)}, {"a_through_focus_steps", v2(f.a_through_focus_steps)},
                  {"residual_mm", v2(f.residual_mm)},     {"maps", f.maps}};
  }
  if (r.a_to_z) {
    json its = json::array();
    for (const auto& it : r.a_to_z->iterations) {
      json pts = json::array();
      for (std::size_t i = 0; i < it.z_mm.size(); ++i)
        pts.push_back({{"z_mm", it.z_mm[i]}, {"a_offset_mm", v2(it.a_offset_mm[i])}});
      its.push_back({{"points", pts}, {"angle_rad", v2(it.angle_rad)}, {"correction_deg", v2(it.correction_deg)}});
    }
    j["a_to_z"] = {{"iterations", its}, {"converged", r.a_to_z->converged}, {"maps", r.a_to_z->maps}};
  }
  // The stitched form's basis, x and y over the part's clear radius (form_stitching.hpp).
  const json form_terms = {"x2-y2", "2xy", "x3-3xy2", "3x2y-y3", "x r2", "y r2", "r4"};
  if (r.b_rotation) {
    const auto& b = *r.b_rotation;
    json nulls = json::array();
    for (std::size_t i = 0; i < b.b_deg.size(); ++i) {
      nulls.push_back({{"b_deg", b.b_deg[i]}, {"steps", v3(b.null_steps[i])}});
      if (i < b.raw_null_steps.size()) nulls.back()["raw_steps"] = v3(b.raw_null_steps[i]);
    }
    j["b_rotation"] = {{"nulls", nulls},
                       {"P_steps", b.p_steps},
                       {"Q", b.q},
                       {"R", b.r},
                       {"S", b.s},
                       {"eccentricity_mm", b.eccentricity_mm},
                       {"xb_mm", b.xb_mm},
                       {"zf_mm", b.zf_mm},
                       {"dz_mm", b.dz_mm},
                       {"b_axis_tilt_rad", b.b_axis_tilt_rad},
                       {"residual_rms_steps", b.residual_rms_steps},
                       {"maps", b.maps}};
    if (!b.form_height_nm.empty())
      j["b_rotation"]["form"] = {
          {"terms", form_terms}, {"height_nm", b.form_height_nm}, {"residual_rms_nm", b.form_residual_rms_nm}};
  }
  if (r.c_rotation) {
    const auto& c = *r.c_rotation;
    json nulls = json::array();
    for (std::size_t i = 0; i < c.c_deg.size(); ++i) {
      nulls.push_back({{"c_deg", c.c_deg[i]}, {"steps", v3(c.null_steps[i])}});
      if (i < c.raw_null_steps.size()) nulls.back()["raw_steps"] = v3(c.raw_null_steps[i]);
    }
    j["c_rotation"] = {{"nulls", nulls},
                       {"P_steps", c.p_steps},
                       {"Q", c.q},
                       {"R", c.r},
                       {"S", c.s},
                       {"yc_mm", c.yc_mm},
                       {"zf_minus_zc_mm", c.zf_minus_zc_mm},
                       {"residual_rms_steps", c.residual_rms_steps},
                       {"maps", c.maps}};
    if (c.zc_mm) j["c_rotation"]["zc_mm"] = *c.zc_mm;
    if (!c.form_height_nm.empty())
      j["c_rotation"]["form"] = {
          {"terms", form_terms}, {"height_nm", c.form_height_nm}, {"residual_rms_nm", c.form_residual_rms_nm}};
  }
  if (r.reversal) {
    const auto& v = *r.reversal;
    j["reversal"] = {{"part", v2(v.part_rad)},   {"table", v2(v.table_rad)},     {"unit", v.at_0.sphere ? "mm" : "rad"},
                     {"at_0", pom_json(v.at_0)}, {"at_180", pom_json(v.at_180)}, {"maps", v.maps}};
  }
  const auto& k = r.knowledge;
  j["knowledge"] = {{"step_mm", v3(k.step_mm)},
                    {"gauge_clocking_rad", k.gauge_clocking_rad},
                    {"az_correction_deg", v2(k.az_correction_deg)}};
  if (k.focus_table_z_steps) j["knowledge"]["focus_table_z_steps"] = *k.focus_table_z_steps;
  if (k.a_through_focus_steps) j["knowledge"]["a_through_focus_steps"] = v2(*k.a_through_focus_steps);
  return j;
}

}  // namespace metron::runtime::wavefront
