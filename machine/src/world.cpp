// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/world.hpp"

#include "metron/machine/machine_errors/error_model.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <set>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/stdlib/file_access.hpp"
#include "metron/stdlib/json_reader.hpp"

namespace metron::machine {
namespace {

using nlohmann::json;

namespace sj = strict_json;
using sj::fail;
using sj::number;
using sj::Object;
using sj::positive;
using sj::string;
using sj::unit;
using sj::vec3;

// One axis law, exactly one of its three forms in `o` (an axis record or its braking); a
// constant-rate law's missing limits stay -1 (the path limits, filled in later).
void parse_ramp_law(Object& o, RampLaw& law) {
  const json* rate = o.find("constant_rate");
  const json* time = o.find("constant_time");
  const json* table = o.find("tabulated");
  if ((rate != nullptr) + (time != nullptr) + (table != nullptr) != 1)
    fail(o.pointer(), "expected exactly one of 'constant_rate', 'constant_time' or 'tabulated'");
  if (rate) {
    Object r(*rate, o.at("constant_rate"));
    law.mode = RampLaw::Mode::ConstantRate;
    r.positive("acceleration_mm_s2", law.acceleration_mm_s2);
    r.positive("jerk_mm_s3", law.jerk_mm_s3);
    r.finish();
  } else if (time) {
    Object t(*time, o.at("constant_time"));
    law.mode = RampLaw::Mode::ConstantTime;
    t.positive("time_s", law.time_s);
    t.finish();
  } else {
    // {"feed_mm_s": [v0, v1, ...], "ramp_time_s": [t0, t1, ...]}: feeds strictly increasing.
    Object t(*table, o.at("tabulated"));
    law.mode = RampLaw::Mode::Tabulated;
    const std::vector<double> feeds = sj::numbers(t.required("feed_mm_s"), t.at("feed_mm_s"));
    const std::vector<double> times = sj::numbers(t.required("ramp_time_s"), t.at("ramp_time_s"));
    if (feeds.size() < 2) fail(t.at("feed_mm_s"), "expected at least two feeds");
    if (times.size() != feeds.size())
      fail(t.at("ramp_time_s"), fmt::format("expected {} ramp times, one per feed", feeds.size()));
    for (std::size_t k = 0; k < feeds.size(); ++k) {
      const std::string fp = t.at("feed_mm_s") + "/" + std::to_string(k),
                        tp = t.at("ramp_time_s") + "/" + std::to_string(k);
      if (!(feeds[k] > 0)) fail(fp, "expected a positive feed");
      if (k > 0 && !(feeds[k] > feeds[k - 1])) fail(fp, "expected feeds in increasing order");
      // A ramp of over a minute is a typo (a time in ms), and would stall every move.
      if (!(times[k] > 0 && times[k] <= 60)) fail(tp, "expected a ramp time from 0 to 60 s");
      law.table.push_back({feeds[k], times[k]});
    }
    t.finish();
  }
}

void parse_machine(const json& j, const std::string& ptr, MachineConfig& m, WorldTruth& truth) {
  Object o(j, ptr);
  o.read("travel_mm", [&](const json& tj, const std::string& tp) {
    Object t(tj, tp);
    const char* names[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) {
      t.read(names[i], [&](const json& aj, const std::string& ap) {
        if (!aj.is_array() || aj.size() != 2) fail(ap, "expected [min, max]");
        const double lo = number(aj[0], ap + "/0"), hi = number(aj[1], ap + "/1");
        if (!(lo < hi)) fail(ap, "expected min < max");
        m.travel[i] = {lo, hi};
      });
    }
    t.finish();
  });
  o.positive("max_speed_mm_s", m.max_speed_mm_s);
  o.positive("max_acceleration_mm_s2", m.max_acceleration_mm_s2);
  o.positive("max_jerk_mm_s3", m.max_jerk_mm_s3);
  o.read("dt_s", [&](const json& dj, const std::string& dp) {
    // A step of 1e-12 s made every move take 1e9 steps and never finish (issue 15).
    m.dt_s = number(dj, dp);
    if (!(m.dt_s >= 1e-5 && m.dt_s <= 0.1)) fail(dp, "expected a time step from 1e-05 to 0.1 s");
  });
  o.positive("positioning_feed_mm_s", m.positioning_feed_mm_s);
  o.positive("measuring_feed_mm_s", m.measuring_feed_mm_s);
  o.read("skip", [&](const json& sj, const std::string& sp) {
    Object s(sj, sp);
    const json* latched = s.find("latched");
    const json* scanned = s.find("scanned");
    if ((latched != nullptr) == (scanned != nullptr)) fail(sp, "expected exactly one of 'latched' or 'scanned'");
    if (latched) {
      m.skip.kind = SkipInput::Kind::Latched;
      Object l(*latched, s.at("latched"));
      l.non_negative("latency_s", m.skip.latency_s);
      l.finish();
    } else {
      m.skip.kind = SkipInput::Kind::Scanned;
      Object c(*scanned, s.at("scanned"));
      c.positive("period_s", m.skip.period_s);
      c.finish();
    }
    s.finish();
  });
  o.read("axes", [&](const json& aj, const std::string& ap) {
    // Axes not named keep the path limits (constant rate), read after them whatever the key order.
    std::array<AxisDynamics, 3> axes;
    for (auto& x : axes) x.acceleration_mm_s2 = x.jerk_mm_s3 = -1;  // -1: the path limit
    Object a(aj, ap);
    const char* names[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i)
      a.read(names[i], [&](const json& xj, const std::string& xp) {
        Object x(xj, xp);
        parse_ramp_law(x, axes[i]);
        x.read("braking", [&](const json& bj, const std::string& bp) {
          RampLaw braking;
          braking.acceleration_mm_s2 = braking.jerk_mm_s3 = -1;
          Object b(bj, bp);
          parse_ramp_law(b, braking);
          b.finish();
          axes[i].braking = braking;
        });
        x.finish();
      });
    a.finish();
    truth.axes = axes;
  });
  o.vec3("home_mm", m.home_mm);
  o.number("table_z_mm", truth.table_z_mm);
  // The machine's geometry and thermal errors: hidden truth (docs/error-space.md, "Machine errors").
  o.read("errors", [&](const json& ej, const std::string& ep) {
    auto errors = parse_machine_errors(ej, ep);
    if (!errors) fail(errors.error().pointer, errors.error().message);
    truth.errors = std::move(*errors);
  });
  o.finish();
  if (truth.axes)
    for (auto& a : *truth.axes)
      for (RampLaw* law : {static_cast<RampLaw*>(&a), a.braking ? &*a.braking : nullptr}) {
        if (!law || law->mode != RampLaw::Mode::ConstantRate) continue;
        if (law->acceleration_mm_s2 < 0) law->acceleration_mm_s2 = m.max_acceleration_mm_s2;
        if (law->jerk_mm_s3 < 0) law->jerk_mm_s3 = m.max_jerk_mm_s3;
      }
  for (int i = 0; i < 3; ++i) {
    if (m.home_mm[i] < m.travel[i].min_mm || m.home_mm[i] > m.travel[i].max_mm)
      fail(o.at("home_mm"), "outside the axis travel");
  }
  if (m.positioning_feed_mm_s > m.max_speed_mm_s || m.measuring_feed_mm_s > m.max_speed_mm_s)
    fail(ptr, "a default feed exceeds max_speed_mm_s");
}

ProbeSpec parse_probe(const json& j, const std::string& ptr) {
  ProbeSpec p;
  Object o(j, ptr);
  o.number("ball_radius_error_mm", p.ball_radius_error_mm);
  o.read("pre_travel", [&](const json& tj, const std::string& tp) {
    Object t(tj, tp);
    t.non_negative("horizontal_mm", p.pre_travel.horizontal_mm);
    t.non_negative("vertical_mm", p.pre_travel.vertical_mm);
    t.read("lobes", [&](const json& lj, const std::string& lp) {
      p.pre_travel.lobes = static_cast<int>(sj::integer(lj, lp, 0));
    });
    t.non_negative("lobe_amplitude_mm", p.pre_travel.lobe_amplitude_mm);
    t.number("lobe_phase_deg", p.pre_travel.lobe_phase_deg);
    t.finish();
  });
  o.non_negative("filter_delay_s", p.filter_delay_s);
  o.non_negative("transmission_delay_s", p.transmission_delay_s);
  o.positive("over_travel_mm", p.over_travel_mm);
  o.non_negative("repeatability_mm", p.repeatability_mm);
  o.finish();
  return p;
}

// The certificate goes to the controller's configuration, the sphere as it is to the truth
// (by default exactly as certified).
void parse_reference_sphere(const json& j, const std::string& ptr, ReferenceSphereConfig& known,
                            ReferenceSphereTruth& r) {
  Object o(j, ptr);
  known = {};
  r = {};
  o.vec3("nominal_centre_mm", known.nominal_centre_mm);
  o.positive("certified_diameter_mm", known.certified_diameter_mm);
  r.true_centre_mm = known.nominal_centre_mm;
  r.true_diameter_mm = known.certified_diameter_mm;
  o.vec3("true_centre_mm", r.true_centre_mm);
  o.positive("true_diameter_mm", r.true_diameter_mm);
  o.read("post", [&](const json& pj, const std::string& pp) {
    Object post(pj, pp);
    post.positive("diameter_mm", r.post_diameter_mm);
    post.unit("direction", r.post_direction);
    post.positive("length_mm", r.post_length_mm);
    post.finish();
    if (r.post_diameter_mm >= r.true_diameter_mm)
      fail(post.at("diameter_mm"), "the post must be thinner than the sphere");
  });
  o.finish();
}

csg::Node parse_node(const json& j, const std::string& ptr);

csg::Node parse_boolean(Object& o, const std::string& key, csg::Node::Op op) {
  const json& arr = o.required(key);
  const std::string p = o.at(key);
  if (!arr.is_array() || arr.empty()) fail(p, "expected a non-empty array of nodes");
  csg::Node n;
  n.op = op;
  for (std::size_t i = 0; i < arr.size(); ++i) n.children.push_back(parse_node(arr[i], p + "/" + std::to_string(i)));
  o.finish();
  return n;
}

csg::Node parse_node(const json& j, const std::string& ptr) {
  Object o(j, ptr);
  static const std::pair<const char*, csg::Node::Op> ops[] = {{"union", csg::Node::Op::Union},
                                                              {"intersection", csg::Node::Op::Intersection},
                                                              {"difference", csg::Node::Op::Difference}};
  for (const auto& [key, op] : ops)
    if (j.contains(key)) return parse_boolean(o, key, op);
  if (!j.contains("type")) fail(ptr, "expected a primitive ('type') or one of 'union', 'intersection', 'difference'");
  const std::string type = string(o.required("type"), o.at("type"));
  csg::Node n;
  o.read("name", [&](const json& nj, const std::string& np) { n.primitive.name = string(nj, np); });
  if (type == "half_space") {
    csg::HalfSpace h;
    h.point = vec3(o.required("point"), o.at("point"));
    h.normal = unit(o.required("normal"), o.at("normal"));
    n.primitive.shape = h;
  } else if (type == "cylinder") {
    csg::Cylinder c;
    c.point = vec3(o.required("point"), o.at("point"));
    c.axis = unit(o.required("axis"), o.at("axis"));
    c.diameter_mm = positive(o.required("diameter_mm"), o.at("diameter_mm"));
    o.read("length_mm", [&](const json& lj, const std::string& lp) { c.length_mm = positive(lj, lp); });
    n.primitive.shape = c;
  } else if (type == "sphere") {
    csg::Sphere s;
    s.centre = vec3(o.required("centre"), o.at("centre"));
    s.diameter_mm = positive(o.required("diameter_mm"), o.at("diameter_mm"));
    n.primitive.shape = s;
  } else if (type == "cone") {
    csg::Cone c;
    c.apex = vec3(o.required("apex"), o.at("apex"));
    c.axis = unit(o.required("axis"), o.at("axis"));
    c.half_angle_deg = number(o.required("half_angle_deg"), o.at("half_angle_deg"));
    if (!(c.half_angle_deg > 0 && c.half_angle_deg < 90))
      fail(o.at("half_angle_deg"), "expected an angle in (0, 90) degrees");
    n.primitive.shape = c;
  } else if (type == "torus") {
    csg::Torus t;
    t.centre = vec3(o.required("centre"), o.at("centre"));
    t.axis = unit(o.required("axis"), o.at("axis"));
    t.major_diameter_mm = positive(o.required("major_diameter_mm"), o.at("major_diameter_mm"));
    t.minor_diameter_mm = positive(o.required("minor_diameter_mm"), o.at("minor_diameter_mm"));
    if (t.minor_diameter_mm >= t.major_diameter_mm)
      fail(o.at("minor_diameter_mm"), "the tube's diameter must be less than the centre circle's (a ring with a hole)");
    n.primitive.shape = t;
  } else if (type == "elliptic_cylinder") {
    csg::EllipticCylinder e;
    e.point = vec3(o.required("point"), o.at("point"));
    e.axis = unit(o.required("axis"), o.at("axis"));
    e.major_axis = unit(o.required("major_axis"), o.at("major_axis"));
    if (std::abs(e.major_axis.dot(e.axis)) > 1e-6)
      fail(o.at("major_axis"), "the major axis must be normal to the axis");
    e.major_diameter_mm = positive(o.required("major_diameter_mm"), o.at("major_diameter_mm"));
    e.minor_diameter_mm = positive(o.required("minor_diameter_mm"), o.at("minor_diameter_mm"));
    if (e.minor_diameter_mm > e.major_diameter_mm)
      fail(o.at("minor_diameter_mm"), "the minor diameter must not exceed the major diameter");
    o.read("length_mm", [&](const json& lj, const std::string& lp) { e.length_mm = positive(lj, lp); });
    n.primitive.shape = e;
  } else {
    fail(o.at("type"), fmt::format("unknown primitive type '{}' (expected half_space, cylinder, sphere, cone, torus or "
                                   "elliptic_cylinder)",
                                   type));
  }
  o.finish();
  return n;
}

void collect_names(const csg::Node& n, std::map<std::string, std::vector<const csg::Primitive*>>& out) {
  if (n.op == csg::Node::Op::Primitive) {
    if (!n.primitive.name.empty()) out[n.primitive.name].push_back(&n.primitive);
    return;
  }
  for (const csg::Node& c : n.children) collect_names(c, out);
}

csg::Deviation parse_deviation(const json& j, const std::string& ptr, bool planar, bool round) {
  csg::Deviation d;
  Object o(j, ptr);
  o.vec3("offset_mm", d.offset_mm);
  o.read("tilt_deg", [&](const json& tj, const std::string& tp) {
    if (!tj.is_array() || tj.size() != 2) fail(tp, "expected an array of 2 numbers");
    d.tilt_deg = {number(tj[0], tp + "/0"), number(tj[1], tp + "/1")};
  });
  o.number("size_mm", d.size_mm);
  if (round) o.number("diameter_mm", d.size_mm);  // the same as size_mm, for readability
  o.read("form", [&](const json& fj, const std::string& fp) {
    Object f(fj, fp);
    if (planar) {
      csg::Waviness w;
      f.number("amplitude_mm", w.amplitude_mm);
      f.positive("wavelength_mm", w.wavelength_mm);
      f.number("phase_deg", w.phase_deg);
      d.waviness = w;
    } else {
      csg::Lobing l;
      f.read("lobes",
             [&](const json& lj, const std::string& lp) { l.lobes = static_cast<int>(sj::integer(lj, lp, 1)); });
      f.number("amplitude_mm", l.amplitude_mm);
      f.number("phase_deg", l.phase_deg);
      d.lobing = l;
    }
    f.finish();
  });
  o.finish();
  return d;
}

// STEP and IGES keep their analytic faces for exact contact; other formats are plain meshes.
void load_cad_design(CadDesign& cad, const std::string& ptr) {
  std::string ext = std::filesystem::path(cad.path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".step" || ext == ".stp" || ext == ".iges" || ext == ".igs") {
    const geometry::TessellationOptions options;
    auto model = geometry::load_cad_model(cad.path, options);
    if (!model) fail(ptr, model.error().message);
    cad.mesh = std::make_shared<const geometry::Mesh>(std::move(model->mesh));
    cad.faces = std::make_shared<const std::vector<geometry::CadFace>>(std::move(model->faces));
    cad.chord_tolerance_mm = options.chord_tolerance_mm;
  } else {
    auto mesh = geometry::load_mesh(cad.path);
    if (!mesh) fail(ptr, mesh.error().message);
    cad.mesh = std::make_shared<const geometry::Mesh>(std::move(*mesh));
  }
  if (!cad.mesh->is_closed())
    fail(ptr, fmt::format("'{}' is not a closed (watertight) mesh, so it has no inside", cad.path));
}

PartSpec parse_part(const json& j, const std::string& ptr, const std::string& base_dir) {
  PartSpec part;
  Object o(j, ptr);
  {
    const json& dj = o.required("design");
    const std::string dp = o.at("design");
    if (dj.is_object() && dj.contains("cad")) {
      Object d(dj, dp);
      CadDesign cad;
      std::filesystem::path p = string(d.required("cad"), d.at("cad"));
      if (p.is_relative() && !base_dir.empty()) p = std::filesystem::path(base_dir) / p;
      cad.path = p.lexically_normal().string();
      d.finish();
      load_cad_design(cad, d.at("cad"));
      part.design = std::move(cad);
    } else {
      part.design = parse_node(dj, dp);
    }
  }
  const auto read_pose = [](const json& pj, const std::string& pp, Pose& into) {
    Object pose(pj, pp);
    pose.vec3("translation_mm", into.translation_mm);
    pose.vec3("rotation_deg", into.rotation_deg);
    pose.finish();
  };
  o.read("pose", [&](const json& pj, const std::string& pp) { read_pose(pj, pp, part.pose); });
  o.read("setups", [&](const json& sj, const std::string& sp) {
    if (!sj.is_array()) fail(sp, "expected an array of poses (translation_mm, rotation_deg)");
    for (std::size_t i = 0; i < sj.size(); ++i) {
      Pose pose;
      read_pose(sj[i], sp + "/" + std::to_string(i), pose);
      part.setups.push_back(pose);
    }
  });
  o.read("deviations", [&](const json& dj, const std::string& dp) {
    Object devs(dj, dp);
    const auto* tree = std::get_if<csg::Node>(&part.design);
    if (!tree) {
      if (!dj.empty()) fail(dp, "deviations by name need a CSG design; a CAD part takes 'bumps'");
      return;
    }
    std::map<std::string, std::vector<const csg::Primitive*>> names;
    collect_names(*tree, names);
    for (const auto& item : dj.items()) {
      const json* v = devs.find(item.key());
      const auto it = names.find(item.key());
      if (it == names.end())
        fail(devs.at(item.key()), fmt::format("no primitive named '{}' in the design", item.key()));
      bool planar = false, round = false;
      for (const csg::Primitive* p : it->second)
        (std::holds_alternative<csg::HalfSpace>(p->shape) ? planar : round) = true;
      if (planar && round) fail(devs.at(item.key()), "the name is shared by planar and round primitives");
      part.deviations[item.key()] = parse_deviation(*v, devs.at(item.key()), planar, round);
    }
    devs.finish();
  });
  o.read("bumps", [&](const json& bj, const std::string& bp) {
    if (!bj.is_array()) fail(bp, "expected an array of bumps");
    if (!std::holds_alternative<CadDesign>(part.design) && !bj.empty())
      fail(bp, "bumps apply to CAD parts; a CSG part takes 'deviations'");
    for (std::size_t i = 0; i < bj.size(); ++i) {
      Object b(bj[i], bp + "/" + std::to_string(i));
      Bump bump;
      bump.centre_mm = vec3(b.required("centre_mm"), b.at("centre_mm"));
      bump.amplitude_mm = number(b.required("amplitude_mm"), b.at("amplitude_mm"));
      bump.sigma_mm = positive(b.required("sigma_mm"), b.at("sigma_mm"));
      b.finish();
      part.bumps.push_back(bump);
    }
  });
  o.read("roughness", [&](const json& rj, const std::string& rp) {
    Object r(rj, rp);
    r.non_negative("amplitude_mm", part.roughness.amplitude_mm);
    r.positive("correlation_mm", part.roughness.correlation_mm);
    r.finish();
  });
  o.read("seed", [&](const json& nj, const std::string& np) { part.seed = sj::unsigned_integer(nj, np); });
  o.finish();
  return part;
}

World parse_world_or_throw(const json& j, const std::string& base_dir) {
  World w;
  Object o(j, "");
  // Worlds of other machine kinds share the folder (docs/world.md); say which command reads them.
  o.read("kind", [&](const json& kj, const std::string& kp) {
    if (sj::one_of(kj, kp, {"cmm", "wavefront"}) == "wavefront")
      sj::fail(kp,
               "a world of kind \"wavefront\" is a wavefront-gauge machine, not a CMM: it is read by "
               "`metron calibrate wavefront --world FILE` (docs/wavefront.md)");
  });
  o.read("name", [&](const json& nj, const std::string& np) { w.name = string(nj, np); });
  o.read("description", [&](const json& dj, const std::string& dp) { string(dj, dp); });
  o.read("seed", [&](const json& nj, const std::string& np) { w.seed = sj::unsigned_integer(nj, np); });
  // machine.data_sheet: published probe values that differ from the truth (issue 11: the
  // controller plans with its data sheet, never with the hidden values). Read after the rest.
  json sheet;
  o.read("machine", [&](const json& mj, const std::string& mp) {
    json m = mj;
    if (m.is_object() && m.contains("data_sheet")) sheet = m["data_sheet"], m.erase("data_sheet");
    parse_machine(m, mp, w.machine, w.truth);
  });
  o.read("probe", [&](const json& pj, const std::string& pp) { w.truth.probe = parse_probe(pj, pp); });
  o.read("probe_library",
         [&](const json& lj, const std::string& lp) { w.machine.probe_library = parse_probe_library(lj, lp); });
  o.read("reference_sphere", [&](const json& rj, const std::string& rp) {
    parse_reference_sphere(rj, rp, w.machine.reference_sphere, w.truth.reference_sphere);
  });
  o.read("part", [&](const json& pj, const std::string& pp) {
    if (!pj.is_null()) w.truth.part = parse_part(pj, pp, base_dir);
  });
  o.read("scanning", [&](const json& nj, const std::string& np) {
    if (auto ok = parse_scanning_spec(nj, np, w.machine.scanning, w.truth.scanning); !ok) throw ok.error();
  });
  o.finish();
  // The data sheets the controller is given: the true values (a data-sheet error would go here).
  w.machine.data_sheet = data_sheet_of(w.truth);
  if (!sheet.is_null()) {
    Object d(sheet, "/machine/data_sheet");
    d.positive("rated_over_travel_mm", w.machine.data_sheet.rated_over_travel_mm);
    d.positive("scanning_stiffness_n_mm", w.machine.data_sheet.scanning_stiffness_n_mm);
    d.positive("scanning_stylus_mass_g", w.machine.data_sheet.scanning_stylus_mass_g);
    d.finish();
  }
  return w;
}

}  // namespace

DataSheet data_sheet_of(const WorldTruth& truth) {
  DataSheet d;
  d.rated_over_travel_mm = truth.probe.over_travel_mm;
  d.scanning_stiffness_n_mm = truth.scanning.probe.stiffness_n_mm;
  d.scanning_stylus_mass_g = truth.scanning.probe.stylus_mass_g;
  return d;
}

Frame Pose::part_to_machine() const {
  const double k = std::numbers::pi / 180.0;
  Frame f = Frame::Identity();
  f.translate(translation_mm);
  f.rotate(Eigen::AngleAxisd(rotation_deg.z() * k, Vec3::UnitZ()));
  f.rotate(Eigen::AngleAxisd(rotation_deg.y() * k, Vec3::UnitY()));
  f.rotate(Eigen::AngleAxisd(rotation_deg.x() * k, Vec3::UnitX()));
  return f;
}

namespace {

tl::expected<json, WorldError> read_json(const std::string& path) {
  // The strict reader's parse: a size cap (no /dev/zero), a nesting limit and numbers out of
  // range (1e400) reported, never thrown.
  auto text = read_input_file(path);
  if (!text) {
    const std::string reason = text.error().substr(text.error().rfind(": ") + 2);
    return tl::unexpected(WorldError{reason == "no such file"
                                         ? fmt::format("{}: cannot read the file", path)
                                         : fmt::format("{}: cannot read the file: {}", path, reason)});
  }
  auto j = sj::parse_document(*text);
  if (!j) return tl::unexpected(WorldError{fmt::format("{}: invalid JSON: {}", path, j.error())});
  return std::move(*j);
}

// A CAD path in a base world stays relative to the base file, not to the file extending it.
void anchor_cad_path(json& j, const std::string& base_dir) {
  if (base_dir.empty() || !j.is_object() || !j.contains("part") || !j["part"].is_object()) return;
  json& part = j["part"];
  if (!part.contains("design") || !part["design"].is_object() || !part["design"].contains("cad")) return;
  json& cad = part["design"]["cad"];
  if (cad.is_string() && std::filesystem::path(cad.get<std::string>()).is_relative())
    cad = (std::filesystem::path(base_dir) / cad.get<std::string>()).lexically_normal().string();
}

// "extends": a base world ("default" for the embedded one, else a path relative to the file),
// overridden by this file as an RFC 7386 merge patch; machine.skip and part.design replace the
// base's whole (and so does machine.axes).
tl::expected<json, WorldError> resolve_extends(json j, const std::string& source, const std::string& base_dir,
                                               int depth) {
  if (!j.is_object() || !j.contains("extends")) return j;
  const json& ext = j["extends"];
  if (!ext.is_string()) return tl::unexpected(WorldError{fmt::format("{}: /extends: expected a string", source)});
  if (depth > 8) return tl::unexpected(WorldError{fmt::format("{}: /extends: too deeply nested", source)});
  const std::string name = ext.get<std::string>();
  json base;
  if (name == "default") {
    base = json::parse(default_world_json(), nullptr, true, true);
  } else {
    std::filesystem::path p = name;
    if (p.is_relative() && !base_dir.empty()) p = std::filesystem::path(base_dir) / p;
    auto read = read_json(p.string());
    if (!read) return tl::unexpected(read.error());
    const std::string dir = p.parent_path().string();
    auto resolved = resolve_extends(std::move(*read), p.string(), dir, depth + 1);
    if (!resolved) return resolved;
    base = std::move(*resolved);
    anchor_cad_path(base, dir);
  }
  j.erase("extends");
  // One-of choices are replaced, not merged: a scanned skip must not keep the base's latched.
  for (const auto& [section, key] :
       {std::pair{"machine", "skip"}, std::pair{"machine", "axes"}, std::pair{"part", "design"}}) {
    if (j.contains(section) && j[section].is_object() && j[section].contains(key) && base.contains(section) &&
        base[section].is_object())
      base[section].erase(key);
  }
  base.merge_patch(j);
  return base;
}

}  // namespace

tl::expected<World, WorldError> parse_world(const nlohmann::json& json_in, const std::string& source_name,
                                            const std::string& base_dir) {
  auto j = resolve_extends(json_in, source_name, base_dir, 0);
  if (!j) return tl::unexpected(j.error());
  auto w = sj::read([&] { return parse_world_or_throw(*j, base_dir); });
  if (!w)
    return tl::unexpected(WorldError{fmt::format("{}: {}: {}", source_name, w.error().pointer, w.error().message)});
  w->source = source_name;
  return std::move(*w);
}

tl::expected<World, WorldError> load_world(const std::string& path) {
  auto j = read_json(path);
  if (!j) return tl::unexpected(j.error());
  return parse_world(*j, path, std::filesystem::path(path).parent_path().string());
}

World default_world() {
  auto w = parse_world(json::parse(default_world_json(), nullptr, true, true), "<default>");
  if (!w) throw std::logic_error("the embedded default world is invalid: " + w.error().message);
  return *w;
}

tl::expected<World, WorldError> load_world_or_default(const std::optional<std::string>& path) {
  if (path) return load_world(*path);
  return default_world();
}

}  // namespace metron::machine
