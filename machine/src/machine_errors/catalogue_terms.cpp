// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/machine_errors/catalogue_terms.hpp"

#include <cmath>

#include <fmt/format.h>

#include "metron/machine/machine_errors/rigid_body.hpp"
#include "metron/stdlib/json_reader.hpp"

namespace metron::machine {

namespace {
constexpr double kPi = 3.14159265358979323846;
Vec3 along(int c, double v) {
  Vec3 e = Vec3::Zero();
  e[c] = v;
  return e;
}
}  // namespace

Vec3 LinearTerm::displacement(const MachinePose& p, double) const { return along(m_c, m_k * p.axes_mm[m_j]); }
Vec3 CrossAxisTerm::displacement(const MachinePose& p, double) const {
  return along(m_c, m_k * p.axes_mm[m_i] * p.axes_mm[m_j]);
}
Vec3 CyclicTerm::displacement(const MachinePose& p, double) const {
  return along(m_c, m_a * std::sin(2 * kPi * p.axes_mm[m_j] / m_p + m_phi));
}
Vec3 DriftTerm::displacement(const MachinePose&, double t) const { return along(m_c, m_rate * (t - m_t0)); }
Vec3 TransientTerm::displacement(const MachinePose&, double t) const {
  return along(m_c, t >= m_t0 ? m_a * std::exp(-(t - m_t0) / m_tau) : 0.0);
}
Vec3 ThermalLagTerm::displacement(const MachinePose& p, double t) const {
  const double dT = (m_t ? m_t->body_c(t) : 20.0) - m_ref;
  return along(m_c, (m_k0 + m_k1 * p.axes_mm[m_c]) * dT);
}

void parse_catalogue_terms(const nlohmann::json& terms, const std::string& pointer, MachineErrorModel& model) {
  using namespace strict_json;
  if (!terms.is_array()) fail(pointer, "expected an array of terms");
  auto axis = [](const nlohmann::json& j, const std::string& p) {
    const std::string s = one_of(j, p, {"x", "y", "z"});
    return s == "x" ? 0 : s == "y" ? 1 : 2;
  };
  for (std::size_t i = 0; i < terms.size(); ++i) {
    const std::string p = fmt::format("{}/{}", pointer, i);
    Object o(terms[i], p);
    const std::string kind = one_of(o.required("kind"), o.at("kind"),
                                    {"linear", "cross_axis", "cyclic", "drift", "transient", "thermal", "reversal"});
    const int c = axis(o.required("component"), o.at("component"));
    if (kind == "linear") {
      model.add(
          std::make_shared<LinearTerm>(c, axis(o.required("along"), o.at("along")), o.get("coefficient", number)));
    } else if (kind == "cross_axis") {
      const nlohmann::json& a = o.required("along");
      if (!a.is_array() || a.size() != 2) fail(o.at("along"), "expected two axes");
      model.add(std::make_shared<CrossAxisTerm>(c, axis(a[0], o.at("along") + "/0"), axis(a[1], o.at("along") + "/1"),
                                                o.get("coefficient", number)));
    } else if (kind == "cyclic") {
      const int j = axis(o.required("along"), o.at("along"));
      const double a = o.get("amplitude_mm", number), period = o.get("period_mm", positive);
      double phase = 0;
      o.number("phase_rad", phase);
      model.add(std::make_shared<CyclicTerm>(c, j, a, period, phase));
    } else if (kind == "drift") {
      double t0 = 0;
      o.number("t0_s", t0);
      model.add(std::make_shared<DriftTerm>(c, o.get("rate_mm_per_s", number), t0));
    } else if (kind == "transient") {
      double t0 = 0;
      o.number("t0_s", t0);
      model.add(std::make_shared<TransientTerm>(c, o.get("amplitude_mm", number), o.get("tau_s", positive), t0));
    } else if (kind == "reversal") {
      std::array<double, 3> rev{0, 0, 0};
      rev[static_cast<std::size_t>(c)] = o.get("reversal_mm", number);
      model.add(std::make_shared<ReversalTerm>(rev));
    } else {  // thermal
      double k0 = 0, k1 = 0, ref = 20;
      o.number("mm_per_k", k0);
      o.number("per_k", k1);
      o.number("reference_c", ref);
      Object t(o.required("temperature"), o.at("temperature"));
      const auto ts = numbers(t.required("t_s"), t.at("t_s"));
      const auto temp = numbers(t.required("temperature_c"), t.at("temperature_c"), static_cast<long>(ts.size()));
      double lag = 0;
      t.non_negative("lag_s", lag);
      if (ts.empty()) fail(t.at("t_s"), "expected at least one time");
      for (std::size_t k = 1; k < ts.size(); ++k)
        if (!(ts[k] > ts[k - 1])) fail(fmt::format("{}/{}", t.at("t_s"), k), "expected increasing times");
      t.finish();
      model.add(std::make_shared<ThermalLagTerm>(c, k0, k1, ref,
                                                 std::make_shared<TemperatureHistory>(ts, temp, lag, std::nan(""))));
    }
    o.finish();
  }
}

}  // namespace metron::machine
