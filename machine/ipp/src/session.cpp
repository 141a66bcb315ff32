// SPDX-License-Identifier: GPL-3.0-or-later
// The I++ DME server's session logic (docs/ipp-dme.md): each received command line is checked,
// mapped onto machine::Machine commands, run to completion on the (simulated) machine, and
// answered with `&`, data `#`, errors `!` and `%`, as the NIST test suite's server does.
#include "metron/machine/ipp/session.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <set>

#include "metron/machine/ipp/command_line.hpp"
#include "metron/machine/ipp/error_code.hpp"
#include "metron/machine/ipp/response_line.hpp"

namespace metron::machine::ipp {
namespace {

using Args = std::vector<Argument>;
constexpr double k_deg = std::numbers::pi / 180;
constexpr double k_max_scan_samples = 1e6;  ///< per scan command

/// A number property of a tool (I++ DME: value with .Act, .Def, .Max, .Min).
struct NumberProperty {
  double act = 0, def = 0, min = 0, max = 0;
};

struct Tool {
  std::string name;
  int id = 0;
  std::optional<DefineTool> definition;  ///< none: NoTool and RefTool (no stylus)
  bool defined_on_machine = false;
  std::optional<double> qualified_radius_mm;      ///< the effective radius from the last ReQualify
  std::map<std::string, NumberProperty> numbers;  ///< "GoToPar.Speed", "PtMeasPar.Search", ...
};

const std::vector<std::string> k_number_properties{"GoToPar.Speed",   "GoToPar.Accel",      "PtMeasPar.Speed",
                                                   "PtMeasPar.Accel", "PtMeasPar.Approach", "PtMeasPar.Retract",
                                                   "PtMeasPar.Search"};

/// A coordinate system's placement: machine = origin + R * p, R = Rz(psi) Rx(theta) Rz(phi)
/// (the Euler angles of I++ DME SetCsyTransformation, degrees).
struct Csy {
  double x0 = 0, y0 = 0, z0 = 0, theta = 0, psi = 0, phi = 0;
  [[nodiscard]] Eigen::Matrix3d rotation() const {
    return (Eigen::AngleAxisd(psi * k_deg, Vec3::UnitZ()) * Eigen::AngleAxisd(theta * k_deg, Vec3::UnitX()) *
            Eigen::AngleAxisd(phi * k_deg, Vec3::UnitZ()))
        .toRotationMatrix();
  }
  [[nodiscard]] Vec3 origin() const { return {x0, y0, z0}; }
};

const std::vector<std::string> k_csy_names{"MachineCsy", "MoveableMachineCsy", "MultipleArmCsy", "RotaryTableVarCsy",
                                           "PartCsy"};
const std::vector<std::string> k_transform_names{"PartCsy",       "MoveableMachineCsy", "MultipleArmCsy",
                                                 "JogDisplayCsy", "JogMoveCsy",         "SensorCsy"};

/// A daemon started by OnMoveReportE. With Time and/or Dis it reports along the motion whenever
/// both given conditions hold since its last report (I++ DME 1.4: Time the least time between
/// reports, Dis the least distance); with neither, once at the end of each motion.
struct Daemon {
  std::vector<std::string> items;  ///< "X", "Y", "Z", "R", "Tool.A", ...
  std::optional<double> every_s;   ///< Time(s)
  std::optional<double> every_mm;  ///< Dis(d)
  double last_s = 0;               ///< controller clock of the last report (or the command's start)
  Vec3 last_mm = Vec3::Zero();     ///< machine position then
  [[nodiscard]] bool along_motion() const { return every_s || every_mm; }
};

/// Thrown inside a command handler to answer it with an error; never leaves the Session.
struct CommandError {
  ErrorCode code;
  std::string cause;  ///< the machine's fault message; empty: the command text is the cause
};

// Commands the standard defines that this server answers with 0501 "Unsupported command".
const std::set<std::string> k_unsupported{
    "AlignPart", "CenterPart", "TiltPart", "TiltCenterPart", "LockAxis", "OnScanReportE",
    // Methods of the later versions (I++ DME 1.5 to 2.5; the names as the VDMA 8722 client library
    // libjdme2x lists them) that the server does not carry out: a client that tries one learns
    // the command is known and unsupported (0501), not that it is no command at all (0507).
    "LockPosition", "ScanOnHelix", "ScanUnknownDensity", "PtMeasSelfCenter", "PtMeasSelfCenterLocked", "GoToOnCircle",
    "GoToOnSpiral", "Step", "IsAlignable", "OnMoveReport", "EnumNameSpaces", "EnumerateMoverAxes",
    "GetSupportedCommands", "GetSupportedArguments", "GetTemperatureSensors", "ReadTemperatureSensor",
    "ReadAllTemperatures", "GetScaleTemperatures", "SetScaleTemperatures", "UpdateScaleTemperatures",
    "SetTemperatureCompensationOrigin", "EnumToolCollection", "EnumAllToolCollections", "OpenToolCollection"};
/// The unsupported commands that would move the machine: they need Home first, as the supported
/// ones do (NIST: 0507 before 0501).
const std::set<std::string> k_unsupported_motion{"AlignPart",
                                                 "CenterPart",
                                                 "TiltPart",
                                                 "TiltCenterPart",
                                                 "ScanOnHelix",
                                                 "PtMeasSelfCenter",
                                                 "PtMeasSelfCenterLocked",
                                                 "GoToOnCircle",
                                                 "GoToOnSpiral",
                                                 "Step"};

bool is_event_command(std::string_view name) {
  return name == "AbortE" || name == "GetErrStatusE" || name == "GetPropE" || name == "OnMoveReportE" ||
         name == "SetPropE";
}

}  // namespace

struct Session::Impl {
  Machine& machine;
  SessionOptions options;
  bool started = false;
  bool ended = false;
  bool homed = false;
  bool user_enabled = false;
  bool error_state = false;
  std::vector<std::string> pending_errors;  ///< error lines since the last ClearAllErrors
  std::vector<Tool> tools;
  std::size_t active_tool = 0;  ///< index into tools
  std::size_t found_tool = 0;
  std::uint64_t next_machine_tag = 1;
  std::map<std::string, Csy> csys;  ///< transformations by name
  std::map<std::string, Csy> saved_csys;
  std::string active_csy = "MachineCsy";
  /// The Part object's properties (I++ DME 1.5 section 6.4): what the client says of the part's
  /// temperature (C) and expansion coefficient (1/K). Kept and answered, not applied: the virtual
  /// CMM does not compensate the part's expansion by them (docs/ipp-dme.md).
  double part_temperature_c = 20.0;
  double part_expansion_per_k = 0.0;
  std::vector<std::string> pt_report{"X", "Y", "Z"};
  std::vector<std::string> scan_report{"X", "Y", "Z"};
  std::map<std::string, Daemon> daemons;  ///< by tag text
  double scan_hint_min_radius_mm = 0;
  /// ScanOnCurveDensity: at most this far between reported points (Dis), at most this angle in
  /// degrees between the chords of three consecutive points (Angle); none: the server's choice.
  std::optional<double> curve_density_mm, curve_density_deg;
  /// The acceleration last sent to the machine; the default (Accel.Def) leaves the machine's own
  /// limits untouched, so a client that never sets Accel moves exactly as a direct run.
  double sent_acceleration = -1;
  double motion_s = 0;
  bool observing = false;                    ///< the machine reports its motion (daemons along it)
  double command_start_s = 0;                ///< controller clock when the command started
  std::map<std::size_t, double> line_due_s;  ///< reply lines due before the command's end (reports)
  /// The last command, when it moved the machine and ended without error: an AbortE received
  /// while its answer is still paced stops it (interrupt()).
  struct Running {
    Tag tag;
    std::string text;
  };
  std::optional<Running> running;

  // The reply under construction.
  Tag tag;
  std::string command_text;
  std::vector<std::string>* out = nullptr;

  Impl(Machine& m, SessionOptions o) : machine(m), options(std::move(o)) {
    observing = machine.set_motion_observer(nullptr);  // can the machine report its motion?
    homed = options.start_homed;
    sent_acceleration = options.max_acceleration_mm_s2;
    const auto s = machine.state();
    auto make = [&](std::string name, std::optional<DefineTool> d) {
      Tool t;
      t.name = std::move(name);
      t.id = static_cast<int>(tools.size()) + 1;
      t.definition = std::move(d);
      const double pos = s.positioning_feed_mm_s > 0 ? s.positioning_feed_mm_s : 50;
      const double meas = s.measuring_feed_mm_s > 0 ? s.measuring_feed_mm_s : 5;
      const double vmax = options.max_speed_mm_s, amax = options.max_acceleration_mm_s2;
      t.numbers["GoToPar.Speed"] = {pos, pos, 0.1, vmax};
      t.numbers["GoToPar.Accel"] = {amax, amax, 1, amax};
      t.numbers["PtMeasPar.Speed"] = {meas, meas, 0.1, vmax};
      t.numbers["PtMeasPar.Accel"] = {amax, amax, 1, amax};
      t.numbers["PtMeasPar.Approach"] = {2, 2, 0, 100};
      t.numbers["PtMeasPar.Retract"] = {2, 2, 0, 100};
      t.numbers["PtMeasPar.Search"] = {5, 5, 0, 100};
      tools.push_back(std::move(t));
    };
    // Tools without a stylus: no tool mounted, the head's mounting point (BaseTool, which the
    // NIST files change to), and the reference tool.
    make("NoTool", std::nullopt);
    make("BaseTool", std::nullopt);
    make("RefTool", std::nullopt);
    for (const auto& d : options.tools) make(d.name, d);
    for (const auto& n : k_transform_names) csys[n] = {};
    if (!s.active_tool.empty())
      for (std::size_t k = 0; k < tools.size(); ++k)
        if (tools[k].name == s.active_tool) active_tool = k, tools[k].defined_on_machine = true;
  }

  // ---- reply helpers
  void data(const std::string& body) { out->push_back(format_data(tag, body)); }
  [[noreturn]] static void fail(ErrorCode code) { throw CommandError{code, {}}; }

  // ---- coordinates
  [[nodiscard]] Csy active() const {
    if (active_csy == "MachineCsy" || active_csy == "RotaryTableVarCsy") return {};
    return csys.at(active_csy);
  }
  [[nodiscard]] Vec3 to_machine(const Vec3& p) const {
    const Csy c = active();
    return c.origin() + c.rotation() * p;
  }
  [[nodiscard]] Vec3 to_csy(const Vec3& m) const {
    const Csy c = active();
    return c.rotation().transpose() * (m - c.origin());
  }
  [[nodiscard]] Vec3 dir_to_machine(const Vec3& d) const { return active().rotation() * d; }
  [[nodiscard]] Vec3 dir_to_csy(const Vec3& d) const { return active().rotation().transpose() * d; }

  // ---- argument checks (error numbers as the NIST parser assigns them)
  static void no_args(const Args& a) {
    if (!a.empty()) fail(ErrorCode::IncorrectArguments);
  }
  // A coordinate system's name: a name (PartCsy), or quoted ("PartCsy") as the I++ DME 2.5
  // client library libjdme2x writes it.
  static bool csy_name_argument(const Argument& x) {
    return x.kind == Argument::Kind::Name || x.kind == Argument::Kind::String;
  }
  // X0, Y0, Z0, Theta, Psi, Phi as GetCsyTransformation and GetNamedCsyTransformation answer them.
  static std::string transformation_text(const Csy& t) {
    return format_number(t.x0) + ", " + format_number(t.y0) + ", " + format_number(t.z0) + ", " +
           format_number(t.theta) + ", " + format_number(t.psi) + ", " + format_number(t.phi);
  }
  static const std::string& one_string(const Args& a) {
    if (a.size() != 1) fail(ErrorCode::IncorrectArguments);
    if (a[0].kind != Argument::Kind::String) fail(ErrorCode::BadArgument);
    return a[0].text;
  }
  static std::vector<double> numbers(const Args& a) {
    std::vector<double> v;
    for (const auto& x : a) {
      if (!x.is_number()) fail(ErrorCode::IncorrectArguments);
      v.push_back(x.number);
    }
    return v;
  }
  /// Item lists such as Get(X(), Tool.A()) or OnPtMeasReport(X(), IJK(), ER()): empty calls,
  /// each from `allowed` and none twice.
  static std::vector<std::string> items(const Args& a, const std::set<std::string>& allowed) {
    std::vector<std::string> v;
    if (a.empty()) fail(ErrorCode::IncorrectArguments);
    for (const auto& x : a) {
      if (x.kind != Argument::Kind::Call || !x.args.empty() || !allowed.count(x.text))
        fail(ErrorCode::IncorrectArguments);
      if (std::find(v.begin(), v.end(), x.text) != v.end()) fail(ErrorCode::IncorrectArguments);
      v.push_back(x.text);
    }
    return v;
  }

  Tool& tool() { return tools[active_tool]; }
  /// The tool of a ChangeTool/SetTool/FindTool/GetChangeToolAction argument: "UnDefTool" is the
  /// specification's pseudo tool for "none found" (1503 Tool not defined, as the NIST server
  /// answers), any other unknown name 1502.
  std::size_t named_tool(const Args& a) {
    const std::string& name = one_string(a);
    if (name == "UnDefTool") fail(ErrorCode::ToolNotDefined);
    const auto k = find_tool(name);
    if (!k) fail(ErrorCode::ToolNotFound);
    return *k;
  }
  /// NoTool measures nothing and has no PtMeasPar: as the NIST server, 0507 for probing with it
  /// (the other tools without a stylus answer 2002 from the machine's point of view).
  void require_probing_tool() {
    if (tool().name == "NoTool") fail(ErrorCode::IllegalCommand);
    if (!tool().definition) fail(ErrorCode::ProbeTypeDoesNotAllow);
  }
  std::optional<std::size_t> find_tool(const std::string& name) const {
    for (std::size_t k = 0; k < tools.size(); ++k)
      if (tools[k].name == name) return k;
    return std::nullopt;
  }

  // ---- the machine
  Response run(decltype(Command::body) body) {
    Command c{next_machine_tag++, std::move(body)};
    machine.submit(std::move(c));
    // The daemons that report along the motion watch it while it runs, and only then (the
    // machine outlives the session, and a cycle without a watcher costs nothing).
    const bool watch =
        observing && std::any_of(daemons.begin(), daemons.end(), [](const auto& d) { return d.second.along_motion(); });
    struct Watching {
      Machine* m;
      ~Watching() {
        if (m) m->set_motion_observer(nullptr);
      }
    } watching{watch ? &machine : nullptr};
    if (watch) machine.set_motion_observer([this](double t, const Vec3& p) { on_motion(t, p); });
    auto responses = machine.execute();
    if (responses.empty()) fail(ErrorCode::ControllerCommunicationsFailure);
    const Response r = responses.back();
    motion_s += std::max(0.0, r.end_time_s - r.start_time_s);
    if (r.status == Response::Status::Fault && r.fault) {
      ErrorCode code = ErrorCode::ErrorProcessingMethod;
      switch (r.fault->kind) {
        case FaultKind::Collision: code = ErrorCode::Collision; break;
        case FaultKind::NoContact: code = ErrorCode::NoTouch; break;
        case FaultKind::OverTravel: code = ErrorCode::HeadErrorExcessiveForce; break;
        case FaultKind::AxisLimit: code = ErrorCode::TargetOutOfVolume; break;
        case FaultKind::NoTool: code = ErrorCode::ProbeTypeDoesNotAllow; break;
        case FaultKind::UnknownTool: code = ErrorCode::ToolNotFound; break;
        case FaultKind::BadCommand: code = ErrorCode::BadArgument; break;
        case FaultKind::Aborted: code = ErrorCode::TransactionAborted; break;
        case FaultKind::Stalled: code = ErrorCode::ErrorProcessingMethod; break;
        case FaultKind::Communication: code = ErrorCode::ControllerCommunicationsFailure; break;
      }
      throw CommandError{code, r.fault->message};
    }
    return r;
  }
  void require_motion_ready() {
    if (!homed) fail(ErrorCode::IllegalCommand);
  }
  void apply_acceleration(double accel) {
    if (accel != sent_acceleration) {
      run(SetFeeds{0, 0, accel});
      sent_acceleration = accel;
    }
  }
  void select_on_machine(Tool& t) {
    if (!t.definition) return;
    if (!t.defined_on_machine) {
      run(*t.definition);
      t.defined_on_machine = true;
    }
    run(SelectTool{t.name});
  }
  // The end of a command's motion: the daemons that do not report along it report where it ended.
  void move_reports() {
    if (daemons.empty()) return;
    const Vec3 p = machine.state().position_mm;
    for (const auto& [daemon_tag, d] : daemons)
      if (!observing || !d.along_motion()) move_report(daemon_tag, d, p, std::nullopt);
  }
  /// A daemon's report; `due_s`: its time after the command's start (none: with the command's end).
  void move_report(const std::string& daemon_tag, const Daemon& d, const Vec3& machine_mm,
                   std::optional<double> due_s) {
    std::string body;
    const Vec3 p = to_csy(machine_mm);
    for (const char* item : {"R", "X", "Y", "Z", "Tool.A", "Tool.B", "Tool.C"}) {
      if (std::find(d.items.begin(), d.items.end(), item) == d.items.end()) continue;
      const std::string s = item;
      const double v = s == "X" ? p.x() : s == "Y" ? p.y() : s == "Z" ? p.z() : 0.0;
      body += (body.empty() ? "" : ", ") + s + "(" + format_number(v) + ")";
    }
    if (body.empty()) return;
    if (due_s) line_due_s[out->size()] = *due_s;
    out->push_back(daemon_tag + " # " + body);
  }
  // Every control cycle of a motion (Machine::set_motion_observer): the daemons with Time or Dis
  // report when their conditions hold, due at that time of the command.
  void on_motion(double time_s, const Vec3& position_mm) {
    if (!out) return;
    for (auto& [daemon_tag, d] : daemons) {
      if (!d.along_motion()) continue;
      if (d.every_s && time_s - d.last_s < *d.every_s - 1e-9) continue;
      if (d.every_mm && (position_mm - d.last_mm).norm() < *d.every_mm) continue;
      d.last_s = time_s;
      d.last_mm = position_mm;
      move_report(daemon_tag, d, position_mm, std::max(0.0, time_s - command_start_s));
    }
  }

  /// Tool.AvrRadius: the tip's effective radius as the machine has it (after ReQualify the
  /// qualified one), the nominal one before, 0 for the tools without a stylus.
  double avr_radius(const Tool& t) const {
    if (!t.definition) return 0;
    if (&t == &tools[active_tool])
      if (const auto s = machine.state(); s.tool && s.active_tool == t.name) return s.tool->effective_radius_mm;
    return t.qualified_radius_mm.value_or(t.definition->ball_diameter_mm / 2);
  }

  // ---- properties
  struct PropertyRef {
    Tool* tool;
    std::string prefix;  ///< "Tool" or "FoundTool"
    std::string path;    ///< after the prefix: "GoToPar.Speed.Max", "Name", ...
  };
  PropertyRef property(const std::string& dotted) {
    const auto dot = dotted.find('.');
    const std::string head = dotted.substr(0, dot);
    if (head != "Tool" && head != "FoundTool") fail(ErrorCode::BadArgument);
    if (dot == std::string::npos) fail(ErrorCode::IncorrectArguments);
    PropertyRef ref{head == "Tool" ? &tools[active_tool] : &tools[found_tool], head, dotted.substr(dot + 1)};
    // NoTool cannot probe: it has no PtMeasPar (NIST: 0507).
    if (head == "Tool" && ref.tool->name == "NoTool" && ref.path.rfind("PtMeasPar", 0) == 0)
      fail(ErrorCode::IllegalCommand);
    return ref;
  }
  /// Part.Temperature, Part.XpanCoefficient; nullptr for another Part. name (0509).
  double* part_property(const std::string& dotted) {
    if (dotted == "Part.Temperature") return &part_temperature_c;
    if (dotted == "Part.XpanCoefficient") return &part_expansion_per_k;
    return nullptr;
  }
  std::string get_property(const Argument& a) {
    if (a.kind != Argument::Kind::Call || !a.args.empty()) fail(ErrorCode::IncorrectArguments);
    if (a.text.rfind("Part.", 0) == 0) {
      const double* v = part_property(a.text);
      if (!v) fail(ErrorCode::BadArgument);
      // An expansion coefficient (1e-5 / K) needs more decimals than a length.
      return a.text + "(" + format_number(*v, v == &part_expansion_per_k ? 12 : 6) + ")";
    }
    auto p = property(a.text);
    const Tool& t = *p.tool;
    const std::string& path = p.path;
    if (path == "Name") return a.text + "(\"" + t.name + "\")";
    if (path == "Id") return a.text + "(\"" + std::to_string(t.id) + "\")";
    if (path == "Alignment") {
      const Vec3 d = t.definition ? Vec3(dir_to_csy(-t.definition->stylus_direction)) : Vec3(0, 0, 1);
      return a.text + "(" + format_number(d.x()) + ", " + format_number(d.y()) + ", " + format_number(d.z()) + ")";
    }
    if (path == "A" || path == "B" || path == "C") return a.text + "(0)";
    if (path == "AvrRadius") return a.text + "(" + format_number(avr_radius(t)) + ")";
    for (const auto& name : k_number_properties) {
      if (path.rfind(name, 0) != 0) continue;
      const std::string suffix = path.substr(name.size());
      const auto& n = t.numbers.at(name);
      if (suffix.empty() || suffix == ".Act") return a.text + "(" + format_number(n.act) + ")";
      if (suffix == ".Def") return a.text + "(" + format_number(n.def) + ")";
      if (suffix == ".Max") return a.text + "(" + format_number(n.max) + ")";
      if (suffix == ".Min") return a.text + "(" + format_number(n.min) + ")";
    }
    fail(ErrorCode::BadArgument);  // NIST parser: an unknown property part is 0509
  }
  /// Returns true when the value was clamped into the property's range.
  bool set_property(const Argument& a) {
    if (a.kind != Argument::Kind::Call || a.args.size() != 1) fail(ErrorCode::IncorrectArguments);
    if (!a.args[0].is_number()) fail(ErrorCode::BadArgument);
    if (a.text.rfind("Part.", 0) == 0) {
      double* v = part_property(a.text);
      if (!v || !std::isfinite(a.args[0].number)) fail(ErrorCode::BadArgument);
      // Below absolute zero is no temperature; a coefficient beyond 1e-3 / K no solid's.
      if ((v == &part_temperature_c && a.args[0].number < -273.15) ||
          (v == &part_expansion_per_k && std::abs(a.args[0].number) > 1e-3))
        fail(ErrorCode::BadArgument);
      *v = a.args[0].number;
      return false;
    }
    auto p = property(a.text);
    for (const auto& name : k_number_properties) {
      if (p.path != name && p.path != name + ".Act") continue;
      auto& n = p.tool->numbers.at(name);
      const double v = a.args[0].number;
      n.act = std::clamp(v, n.min, n.max);
      return n.act != v;
    }
    fail(ErrorCode::BadArgument);  // NIST parser: an unknown property part is 0509
  }
  /// (name, type) of a property node's children, recursively with `all`.
  void enum_properties(const std::string& dotted, bool all) {
    if (dotted == "Part") {
      for (const char* name : {"Temperature", "XpanCoefficient"}) data("\"" + std::string(name) + "\", \"Number\"");
      return;
    }
    auto p = property(dotted + ".X");                        // validates the head
    std::string node = p.path.substr(0, p.path.size() - 1);  // "" or "GoToPar." or "GoToPar.Speed."
    if (!node.empty()) node.pop_back();
    std::vector<std::pair<std::string, std::string>> children;
    auto add_number = [&](const std::string& path) {
      children.emplace_back(path, "Number");
      if (all) {
        children.emplace_back(path, "Property");
        for (const char* s : {"Act", "Def", "Max", "Min"}) children.emplace_back(path + "." + s, "Number");
      }
    };
    if (node.empty()) {
      for (const char* group : {"GoToPar", "PtMeasPar"}) {
        children.emplace_back(group, "Property");
        if (all)
          for (const auto& n : k_number_properties)
            if (n.rfind(group, 0) == 0) add_number(n);
      }
      // Name, Id, Alignment and AvrRadius are readable (GetProp) but, as in the NIST files, not enumerated.
    } else if (node == "GoToPar" || node == "PtMeasPar") {
      for (const auto& n : k_number_properties)
        if (n.rfind(node + ".", 0) == 0) {
          const std::string leaf = n.substr(node.size() + 1);
          if (all) {
            children.emplace_back(leaf, "Number");
            children.emplace_back(leaf, "Property");
            for (const char* s : {"Act", "Def", "Max", "Min"}) children.emplace_back(leaf + "." + s, "Number");
          } else {
            children.emplace_back(leaf, "Number");
          }
        }
    } else if (std::find(k_number_properties.begin(), k_number_properties.end(), node) != k_number_properties.end()) {
      for (const char* s : {"Act", "Def", "Max", "Min"}) children.emplace_back(s, "Number");
    } else {
      fail(ErrorCode::BadArgument);
    }
    for (const auto& [name, type] : children) data("\"" + name + "\", \"" + type + "\"");
  }

  // ---- motion
  Vec3 target(const Args& a, bool allow_tool_angles) {
    Vec3 p = to_csy(machine.state().position_mm);
    std::set<std::string> seen;
    bool any = false;
    for (const auto& x : a) {
      if (x.kind != Argument::Kind::Call) fail(ErrorCode::IncorrectArguments);
      if (!seen.insert(x.text).second) fail(ErrorCode::IncorrectArguments);
      const auto v = x.call_number();
      const int axis = x.text == "X" ? 0 : x.text == "Y" ? 1 : x.text == "Z" ? 2 : -1;
      if (axis >= 0) {
        if (!v) fail(x.args.empty() ? ErrorCode::IncorrectArguments : ErrorCode::BadArgument);
        p[axis] = *v;
        any = true;
      } else if (allow_tool_angles && (x.text == "Tool.A" || x.text == "Tool.B" || x.text == "Tool.C")) {
        if (!v) fail(ErrorCode::IncorrectArguments);
        if (*v != 0) fail(ErrorCode::AngleOutOfRange);  // a fixed probe head: only 0
        any = true;
      } else if (x.text != "IJK" && x.text != "I" && x.text != "J" && x.text != "K") {
        fail(ErrorCode::IncorrectArguments);
      }
    }
    if (!any) fail(ErrorCode::IncorrectArguments);
    return p;
  }

  // The probing direction: IJK(i, j, k), or I(i), J(j), K(k) as some clients write it (the three
  // together, and not beside IJK).
  static std::optional<Vec3> direction_argument(const Args& a) {
    std::optional<Vec3> ijk;
    std::array<std::optional<double>, 3> separate;
    for (const auto& x : a) {
      if (x.is_call("IJK")) {
        if (ijk || x.args.size() != 3) fail(ErrorCode::IncorrectArguments);
        const auto v = numbers(x.args);
        ijk = Vec3(v[0], v[1], v[2]);
      } else if (x.kind == Argument::Kind::Call && (x.text == "I" || x.text == "J" || x.text == "K")) {
        const auto v = x.call_number();
        if (!v) fail(ErrorCode::IncorrectArguments);
        separate[static_cast<std::size_t>(x.text[0] - 'I')] = *v;
      }
    }
    const int given =
        static_cast<int>(std::count_if(separate.begin(), separate.end(), [](const auto& c) { return c.has_value(); }));
    if (given == 0) return ijk;
    if (given != 3 || ijk) fail(ErrorCode::IncorrectArguments);
    return Vec3(*separate[0], *separate[1], *separate[2]);
  }

  void go_to(const Args& a) {
    require_motion_ready();
    const Vec3 p = target(a, true);
    const auto& n = tool().numbers;
    apply_acceleration(n.at("GoToPar.Accel").act);
    run(GoTo{to_machine(p), n.at("GoToPar.Speed").act});
    move_reports();
  }

  void pt_meas(const Args& a) {
    require_motion_ready();
    const std::optional<Vec3> ijk = direction_argument(a);
    const Vec3 nominal = target(a, false);
    if (ijk && ijk->norm() < 1e-12) fail(ErrorCode::VectorHasNoNorm);  // the arguments first (NIST)
    require_probing_tool();
    const Vec3 here = to_csy(machine.state().position_mm);
    Vec3 normal = ijk ? *ijk : Vec3(here - nominal);  // no IJK: approach from the current position
    if (normal.norm() < 1e-12) fail(ErrorCode::VectorHasNoNorm);
    normal.normalize();
    const auto& n = tool().numbers;
    apply_acceleration(n.at("PtMeasPar.Accel").act);
    // X, Y, Z are the ball centre at the nominal contact; the machine wants the surface point.
    const double r_mm = machine.state().tool ? machine.state().tool->effective_radius_mm : 0.0;
    PtMeas m;
    m.nominal_mm = to_machine(nominal) - r_mm * dir_to_machine(normal);
    m.normal = dir_to_machine(normal);
    m.approach_mm = n.at("PtMeasPar.Approach").act;
    m.search_mm = n.at("PtMeasPar.Search").act;
    m.retract_mm = n.at("PtMeasPar.Retract").act;
    m.speed_mm_s = n.at("PtMeasPar.Speed").act;
    run(SetFeeds{n.at("GoToPar.Speed").act, 0, 0});
    const Response r = run(m);
    move_reports();
    if (!r.hit) fail(ErrorCode::NoTouch);
    // The latched ball centre; ER lets the client compensate along its surface normal.
    const Vec3 s = to_csy(r.hit->centre_mm);
    const Vec3 d = dir_to_csy(r.hit->normal);
    std::string body;
    for (const auto& item : pt_report) {
      std::string v;
      if (item == "X")
        v = format_number(s.x());
      else if (item == "Y")
        v = format_number(s.y());
      else if (item == "Z")
        v = format_number(s.z());
      // IJKAct (I++ DME 1.5), the normal the sensor measured: a touch-trigger probe measures none,
      // so it is the probing direction, as IJK.
      else if (item == "IJK" || item == "IJKAct")
        v = format_number(d.x()) + ", " + format_number(d.y()) + ", " + format_number(d.z());
      else if (item == "ER")
        v = format_number(r.hit->ball_radius_mm);
      else
        v = "0";  // R, Tool.A/B/C: no rotary table, a fixed head
      body += (body.empty() ? "" : ", ") + item + "(" + v + ")";
    }
    data(body);
  }

  void get(const Args& a) {
    const auto wanted = items(a, {"X", "Y", "Z", "R", "Tool.A", "Tool.B", "Tool.C"});
    const Vec3 p = to_csy(machine.state().position_mm);
    std::string body;
    for (const auto& item : wanted) {
      const double v = item == "X" ? p.x() : item == "Y" ? p.y() : item == "Z" ? p.z() : 0.0;
      body += (body.empty() ? "" : ", ") + item + "(" + format_number(v) + ")";
    }
    data(body);
  }

  // ScanOnLine(Sx,Sy,Sz,Ex,Ey,Ez,i,j,k,StepW) and
  // ScanOnCircle(Cx,Cy,Cz,Sx,Sy,Sz,i,j,k,delta,sfa,StepW): the points are ball centres at the
  // nominal contact (as in PtMeas); the machine follows them moved by the reference deflection
  // E0 into the surface (ScanPath: the centre path at deflection E0); samples every StepW mm.
  void scan(const std::string& name, const Args& a) {
    require_motion_ready();
    const auto v = numbers(a);
    const double deflection_mm = options.scan_reference_deflection_mm;
    ScanPath sp;
    sp.reference_deflection_mm = deflection_mm;
    auto hermite_line = [&](const Vec3& p0, const Vec3& p1, const Vec3& normal) {
      const Vec3 u = (p1 - p0).normalized();
      sp.path.segments.push_back(geometry::PccSegment::hermite(p0, p1, u, u));
      sp.path.normals.push_back(normal);
    };
    double step = 0;
    if (name == "ScanOnLine") {
      if (v.size() != 10) fail(ErrorCode::IncorrectArguments);
      Vec3 n(v[6], v[7], v[8]);
      if (n.norm() < 1e-12) fail(ErrorCode::VectorHasNoNorm);
      n = dir_to_machine(n.normalized());
      const Vec3 s = to_machine({v[0], v[1], v[2]}), e = to_machine({v[3], v[4], v[5]});
      step = v[9];
      if ((e - s).norm() < 1e-9) fail(ErrorCode::IncorrectArguments);  // NIST: start = end is 0502
      if (step <= 0) fail(ErrorCode::BadArgument);
      require_probing_tool();
      if ((e - s).norm() / step > k_max_scan_samples) fail(ErrorCode::ArgumentOutOfRange);
      hermite_line(s - deflection_mm * n, e - deflection_mm * n, n);
      sp.path.normals.push_back(n);
      sp.approach_normal = n;
    } else {
      if (v.size() != 12) fail(ErrorCode::IncorrectArguments);
      Vec3 w(v[6], v[7], v[8]);
      if (w.norm() < 1e-12) fail(ErrorCode::VectorHasNoNorm);
      w = dir_to_machine(w.normalized());
      const Vec3 c = to_machine({v[0], v[1], v[2]}), s = to_machine({v[3], v[4], v[5]});
      const double delta = v[9] * k_deg, sfa = v[10];
      step = v[11];
      // NIST: a zero radius, or a start not in the plane through C normal to IJK, is 0502.
      if ((s - c).norm() < 1e-9 || std::abs((s - c).dot(w)) > 1e-6 * (s - c).norm())
        fail(ErrorCode::IncorrectArguments);
      Vec3 e0 = (s - c) - (s - c).dot(w) * w;
      const double radius = e0.norm();
      if (step <= 0 || radius < 1e-9) fail(ErrorCode::BadArgument);
      // At most ten turns and k_max_scan_samples samples: a client cannot make the server
      // allocate without bound.
      if (std::abs(delta) > 20 * std::numbers::pi || std::abs(delta) * radius / step > k_max_scan_samples)
        fail(ErrorCode::ArgumentOutOfRange);
      require_probing_tool();
      e0 /= radius;
      // sfa 90: the probe touches the inside of a bore (normal towards the centre); else outside.
      const double sign = std::abs(sfa - 90) < 45 ? -1 : 1;
      const Vec3 e1 = w.cross(e0);
      const int n = std::max(1, static_cast<int>(std::ceil(std::abs(delta) / (10 * k_deg))));
      const double rc = radius - sign * deflection_mm;
      for (int k = 0; k < n; ++k) {
        const double a0 = delta * k / n, a1 = delta * (k + 1) / n;
        const auto radial = [&](double t) { return Vec3(std::cos(t) * e0 + std::sin(t) * e1); };
        const auto tangent = [&](double t) {
          return Vec3((delta > 0 ? 1 : -1) * (-std::sin(t) * e0 + std::cos(t) * e1));
        };
        sp.path.segments.push_back(
            geometry::PccSegment::hermite(c + rc * radial(a0), c + rc * radial(a1), tangent(a0), tangent(a1)));
        sp.path.normals.push_back(sign * radial(a0));
      }
      sp.path.normals.push_back(sign * Vec3(std::cos(delta) * e0 + std::sin(delta) * e1));
      sp.approach_normal = sp.path.normals.front();
    }
    sp.sample_spacing_mm = step;
    run_scan(sp);
  }

  /// Runs a scan on the machine and answers its samples in the OnScanReport format.
  void run_scan(ScanPath& sp) {
    sp.speed_mm_s = tool().numbers.at("PtMeasPar.Speed").act;
    const Response resp = run(sp);
    move_reports();
    report_scan(resp);
  }

  /// Answers a scan's samples in the OnScanReport format.
  void report_scan(const Response& resp) {
    std::string body;
    for (const auto& sample : resp.scan) {
      const Vec3 p = to_csy(sample.centre_mm);
      const Vec3 d =
          sample.deflection_mm.norm() > 0 ? Vec3(dir_to_csy(sample.deflection_mm.normalized())) : Vec3::Zero();
      for (const auto& item : scan_report) {
        if (!body.empty()) body += ",";
        if (item == "X")
          body += format_number(p.x());
        else if (item == "Y")
          body += format_number(p.y());
        else if (item == "Z")
          body += format_number(p.z());
        else if (item == "IJK" || item == "IJKAct")  // the deflection's direction: what the probe measured
          body += format_number(d.x()) + "," + format_number(d.y()) + "," + format_number(d.z());
        else
          body += "0";
      }
    }
    data(body);
  }

  // ScanOnCurve(Closed(b), Format(X(), Y(), Z(), IJK()[, tag][, pi(), pj(), pk()][, si(), sj(), sk()]),
  // Data(x, y, z, i, j, k[, tag][, ...], ...)): the points are ball centres at the nominal contact
  // with their surface normals (as in PtMeas); the machine follows the curve through them (cubic
  // Hermite segments, Catmull-Rom tangents) moved by E0 into the surface. The tool directions
  // pi..sk are read and ignored (a fixed head).
  void scan_on_curve(const Args& a) {
    require_motion_ready();
    if (a.size() != 3 || !a[0].is_call("Closed") || !a[1].is_call("Format") || !a[2].is_call("Data"))
      fail(ErrorCode::IncorrectArguments);
    const auto closed = a[0].call_number();
    if (!closed || (*closed != 0 && *closed != 1)) fail(ErrorCode::BadArgument);
    // Columns of one Data record, and where X and IJK start in it.
    std::size_t columns = 0;
    std::vector<std::string> names;
    for (const auto& f : a[1].args) {
      const std::string n = f.text;
      if (std::find(names.begin(), names.end(), n) != names.end()) fail(ErrorCode::IncorrectArguments);
      if (f.kind == Argument::Kind::Name && n == "tag")
        columns += 1;
      else if (f.kind != Argument::Kind::Call || !f.args.empty())
        fail(ErrorCode::IncorrectArguments);
      else if (n == "IJK")
        columns += 3;
      else if (n == "X" || n == "Y" || n == "Z" || n == "pi" || n == "pj" || n == "pk" || n == "si" || n == "sj" ||
               n == "sk")
        columns += 1;
      else
        fail(ErrorCode::BadArgument);
      names.push_back(n);
    }
    // X, Y, Z, IJK first, in this order: the form of the standard's table and of the NIST files.
    if (names.size() < 4 || names[0] != "X" || names[1] != "Y" || names[2] != "Z" || names[3] != "IJK")
      fail(ErrorCode::BadArgument);
    const auto v = numbers(a[2].args);
    if (v.empty() || v.size() % columns != 0) fail(ErrorCode::IncorrectArguments);
    const std::size_t n = v.size() / columns;
    if (n < 2) fail(ErrorCode::BadArgument);
    require_probing_tool();
    const double e0 = options.scan_reference_deflection_mm;
    std::vector<Vec3> q(n), normal(n);
    for (std::size_t k = 0; k < n; ++k) {
      const double* r = &v[k * columns];
      Vec3 ijk(r[3], r[4], r[5]);
      if (ijk.norm() < 1e-12) fail(ErrorCode::VectorHasNoNorm);
      normal[k] = dir_to_machine(ijk.normalized());
      q[k] = to_machine({r[0], r[1], r[2]}) - e0 * normal[k];
    }
    const bool loop = *closed == 1;
    const std::size_t segments = loop ? n : n - 1;
    double length = 0;
    for (std::size_t k = 0; k < segments; ++k) {
      const double d = (q[(k + 1) % n] - q[k]).norm();
      if (d < 1e-9) fail(ErrorCode::BadArgument);  // two equal points: no direction
      length += d;
    }
    // Samples at the points' mean spacing, at least every millimetre, or as ScanOnCurveDensity
    // asked (below, once the path's curvature is known).
    double step = curve_density_mm ? *curve_density_mm : std::min(1.0, length / static_cast<double>(segments));
    // Catmull-Rom tangents (central differences; one-sided at the ends of an open curve).
    auto tangent = [&](std::size_t k) {
      const Vec3 prev = loop ? q[(k + n - 1) % n] : q[k == 0 ? 0 : k - 1];
      const Vec3 next = loop ? q[(k + 1) % n] : q[k + 1 == n ? n - 1 : k + 1];
      return Vec3((next - prev).normalized());
    };
    ScanPath sp;
    sp.reference_deflection_mm = e0;
    for (std::size_t k = 0; k < segments; ++k) {
      const std::size_t j = (k + 1) % n;
      sp.path.segments.push_back(geometry::PccSegment::hermite(q[k], q[j], tangent(k), tangent(j)));
      sp.path.normals.push_back(normal[k]);
    }
    sp.path.normals.push_back(normal[loop ? 0 : n - 1]);
    sp.approach_normal = normal[0];
    if (curve_density_deg) {
      // Three samples a step apart on a curve of curvature k turn their chords by about step*k:
      // the step at the path's sharpest point keeps every turn within the angle. The measured
      // points scatter about the path (the surface, the probe's noise), which turns their chords
      // further, so the step aims at three quarters of the angle.
      double k_max = 0;
      for (const auto& seg : sp.path.segments)
        for (int i = 0; i <= 16; ++i) k_max = std::max(k_max, seg.curvature(seg.d_mm * i / 16.0));
      if (k_max > 0) step = std::min(step, 0.75 * *curve_density_deg * std::numbers::pi / 180 / k_max);
    }
    if (length / step > k_max_scan_samples) fail(ErrorCode::ArgumentOutOfRange);
    sp.sample_spacing_mm = step;
    run_scan(sp);
  }

  // The unknown-contour scans (I++ DME 1.5): the probe follows the surface it feels, its ball
  // centre held in a plane or on a cylinder, from a start until an end condition.
  //   ScanInPlaneEndIsSphere(S, Sijk, D, StepW, E, Dia, Eijk)
  //   ScanInPlaneEndIsPlane(S, Sijk, D, StepW, P, Pijk, Num, Eijk)
  //   ScanInPlaneEndIsCyl(S, Sijk, D, StepW, C, Cijk, Dia, Num, Eijk)
  //   ScanInCylEndIsSphere(C, Cijk, S, Sijk, D, StepW, E, Dia, Eijk)
  //   ScanInCylEndIsPlane(C, Cijk, S, Sijk, D, StepW, P, Pijk, Num, Eijk)
  // S: the ball centre at the nominal contact (as PtMeas), Sijk the surface normal there; D a
  // point the scan sets off toward; the plane section contains S, Sijk and D; the cylinder
  // section is about the axis C, Cijk through S. The scan ends when the ball centre enters the
  // sphere of diameter Dia about E, or has crossed the plane (P, Pijk) or the cylinder (C, Cijk,
  // Dia) Num times. Eijk, the normal at the end, is read: the retract follows the normal felt.
  void scan_in(const std::string& name, const Args& a) {
    require_motion_ready();
    const auto v = numbers(a);
    const bool in_cyl = name.rfind("ScanInCyl", 0) == 0;
    const std::string end_kind = name.substr(name.find("EndIs") + 5);
    const std::size_t head = in_cyl ? 6 : 0;  // the section cylinder's axis comes first
    const std::size_t end_size = end_kind == "Sphere" ? 7 : end_kind == "Plane" ? 10 : 11;
    if (v.size() != head + 10 + end_size) fail(ErrorCode::IncorrectArguments);
    const auto vec = [&](std::size_t i) { return Vec3(v[i], v[i + 1], v[i + 2]); };
    const auto unit = [&](std::size_t i) {
      const Vec3 d = vec(i);
      if (d.norm() < 1e-12) fail(ErrorCode::VectorHasNoNorm);
      return Vec3(dir_to_machine(d.normalized()));
    };
    ContourScan c;
    const std::size_t s = head, e = head + 10;
    if (in_cyl) {
      c.section.kind = ContourSection::Kind::Cylinder;
      c.section.point_mm = to_machine(vec(0));
      c.section.direction = unit(3);
    }
    c.start_mm = to_machine(vec(s));
    c.start_normal = unit(s + 3);
    const Vec3 toward = to_machine(vec(s + 6)) - c.start_mm;
    const double step = v[s + 9];
    (void)unit(e + end_size - 3);  // Eijk: must be a direction
    if (end_kind == "Sphere") {
      c.end.kind = ContourEnd::Kind::Sphere;
      c.end.point_mm = to_machine(vec(e));
      c.end.diameter_mm = v[e + 3];
    } else {
      c.end.kind = end_kind == "Plane" ? ContourEnd::Kind::Plane : ContourEnd::Kind::Cylinder;
      c.end.point_mm = to_machine(vec(e));
      c.end.direction = unit(e + 3);
      if (end_kind == "Cyl") c.end.diameter_mm = v[e + 6];
      const double num = v[e + (end_kind == "Cyl" ? 7 : 6)];
      if (num < 1 || num != std::floor(num) || num > 1000) fail(ErrorCode::BadArgument);
      c.end.crossings = static_cast<int>(num);
    }
    // NIST: D at S (no direction), or S on the section cylinder's axis, is 0502.
    const Vec3 across = toward - toward.dot(c.start_normal) * c.start_normal;
    if (toward.norm() < 1e-9 || across.norm() < 1e-9 * std::max(1.0, toward.norm()))
      fail(ErrorCode::IncorrectArguments);
    if (in_cyl) {
      const Vec3 r = c.start_mm - c.section.point_mm;
      if ((r - r.dot(c.section.direction) * c.section.direction).norm() < 1e-9) fail(ErrorCode::IncorrectArguments);
    } else {
      c.section.point_mm = c.start_mm;
      c.section.direction = c.start_normal.cross(across).normalized();
    }
    c.direction = across.normalized();
    if (!(step > 0)) fail(ErrorCode::BadArgument);
    if (end_kind != "Plane" && !(c.end.diameter_mm > 0)) fail(ErrorCode::BadArgument);
    require_probing_tool();
    c.reference_deflection_mm = options.scan_reference_deflection_mm;
    c.sample_spacing_mm = step;
    // At most k_max_scan_samples samples: a client cannot make the server allocate without bound.
    c.max_length_mm = std::min(c.max_length_mm, step * k_max_scan_samples);
    if (scan_hint_min_radius_mm > 0) c.min_radius_mm = scan_hint_min_radius_mm;
    c.speed_mm_s = tool().numbers.at("PtMeasPar.Speed").act;
    const Response resp = run(c);
    move_reports();
    report_scan(resp);
  }

  // ScanOnCurveDensity(Dis(d), Angle(a), AngleBaseLength(b), AtNominals(0|1)), any of them, for
  // the following ScanOnCurve commands. The angle is held through the path's curvature, so the
  // base length is accepted and not needed; points at the nominals (AtNominals(1)) are not
  // offered: 0506.
  void scan_on_curve_density(const Args& a) {
    if (a.empty()) fail(ErrorCode::IncorrectArguments);
    std::set<std::string> seen;
    std::optional<double> dis, angle;
    for (const auto& x : a) {
      if (x.kind != Argument::Kind::Call || !seen.insert(x.text).second) fail(ErrorCode::IncorrectArguments);
      const auto v = x.call_number();
      if (!v) fail(ErrorCode::IncorrectArguments);
      if (x.text == "Dis") {
        if (!(*v > 0)) fail(ErrorCode::BadArgument);
        dis = *v;
      } else if (x.text == "Angle") {
        if (!(*v > 0 && *v < 180)) fail(ErrorCode::BadArgument);
        angle = *v;
      } else if (x.text == "AngleBaseLength") {
        if (*v < 0) fail(ErrorCode::BadArgument);
      } else if (x.text == "AtNominals") {
        if (*v != 0 && *v != 1) fail(ErrorCode::BadArgument);
        if (*v == 1) fail(ErrorCode::ArgumentNotSupported);
      } else {
        fail(ErrorCode::IncorrectArguments);
      }
    }
    curve_density_mm = dis;
    curve_density_deg = angle;
  }

  // ---- dispatch
  void dispatch(const CommandLine& c) {
    const std::string& n = c.name;
    const Args& a = c.args;
    if (is_event_command(n) != c.tag.event) fail(ErrorCode::IllegalTag);
    if (n == "StartSession") {
      no_args(a);
      if (started) fail(ErrorCode::IllegalCommand);  // one session per connection (NIST: 0507)
      started = true;
      return;
    }
    if (!started) fail(ErrorCode::IllegalCommand);
    if (error_state && n != "ClearAllErrors" && n != "GetErrStatusE" && n != "GetXtdErrStatus" && n != "GetErrorInfo" &&
        n != "EndSession" && n != "StopDaemon" && n != "StopAllDaemons" && n != "AbortE")
      fail(ErrorCode::UseClearAllErrors);
    if (n == "EndSession") {
      no_args(a);
      ended = true;
      started = false;  // a new StartSession may follow (NIST StartSession.prg)
    } else if (n == "ClearAllErrors") {
      no_args(a);
      error_state = false;
      pending_errors.clear();
    } else if (n == "AbortE") {
      no_args(a);  // every command ran to completion already: nothing is moving
    } else if (n == "GetDMEVersion") {
      no_args(a);
      data("DMEVersion(\"1.4\")");
    } else if (n == "GetMachineClass") {
      no_args(a);
      data("GetMachineClass(\"" + options.machine_class + "\")");
    } else if (n == "GetErrStatusE") {
      no_args(a);
      data(std::string("ErrStatus(") + (error_state ? "1" : "0") + ")");
    } else if (n == "GetXtdErrStatus") {
      no_args(a);
      data(std::string("IsHomed(") + (homed ? "1" : "0") + ")");
      data(std::string("IsUserEnabled(") + (user_enabled ? "1" : "0") + ")");
      for (const auto& e : pending_errors) data(e);
    } else if (n == "GetErrorInfo") {
      if (a.size() != 1 || !a[0].is_number() || a[0].text.find_first_of(".eE") != std::string::npos)
        fail(ErrorCode::IncorrectArguments);
      if (a[0].number < 0 || a[0].number > 9999) fail(ErrorCode::ArgumentOutOfRange);
      const auto info = find_error(static_cast<int>(a[0].number));
      if (!info) fail(ErrorCode::ArgumentOutOfRange);
      data("\"" + std::string(info->text) + "\"");
    } else if (n == "IsHomed") {
      no_args(a);
      data(std::string("IsHomed(") + (homed ? "1" : "0") + ")");
    } else if (n == "Home") {
      no_args(a);
      apply_acceleration(tool().numbers.at("GoToPar.Accel").act);
      run(GoTo{options.home_mm, tool().numbers.at("GoToPar.Speed").act});
      homed = true;
      move_reports();
    } else if (n == "IsUserEnabled") {
      no_args(a);
      data(std::string("IsUserEnabled(") + (user_enabled ? "1" : "0") + ")");
    } else if (n == "EnableUser" || n == "DisableUser") {
      no_args(a);
      user_enabled = n == "EnableUser";
    } else if (n == "OnPtMeasReport") {
      pt_report = items(a, {"X", "Y", "Z", "IJK", "IJKAct", "ER", "R", "Tool.A", "Tool.B", "Tool.C"});
    } else if (n == "OnScanReport") {
      scan_report = items(a, {"X", "Y", "Z", "IJK", "IJKAct", "Q", "R", "ER", "Tool.A", "Tool.B", "Tool.C"});
    } else if (n == "OnMoveReportE") {
      Daemon d;
      std::set<std::string> seen;
      for (const auto& x : a) {
        if (x.kind != Argument::Kind::Call || !seen.insert(x.text).second) fail(ErrorCode::IncorrectArguments);
        if (x.text == "Time" || x.text == "Dis") {
          if (!x.call_number()) fail(ErrorCode::BadArgument);
          // As the NIST server (checkerCmdErrors.res): reports at most ten a second, no negative
          // distance, else 0510.
          if (*x.call_number() < (x.text == "Time" ? 0.1 : 0.0)) fail(ErrorCode::BadProperty);
          (x.text == "Time" ? d.every_s : d.every_mm) = *x.call_number();
        } else if (x.args.empty() && (x.text == "X" || x.text == "Y" || x.text == "Z" || x.text == "R" ||
                                      x.text == "Tool.A" || x.text == "Tool.B" || x.text == "Tool.C")) {
          d.items.push_back(x.text);
        } else {
          fail(ErrorCode::IncorrectArguments);
        }
      }
      if (daemons.count(c.tag.text())) fail(ErrorCode::DaemonAlreadyExists);
      daemons[c.tag.text()] = d;
    } else if (n == "StopDaemon") {
      if (a.size() != 1 || a[0].kind != Argument::Kind::Name) fail(ErrorCode::IncorrectArguments);
      if (!daemons.erase(a[0].text)) fail(ErrorCode::DaemonDoesNotExist);
    } else if (n == "StopAllDaemons") {
      no_args(a);
      if (daemons.empty()) fail(ErrorCode::NoDaemonsActive);
      daemons.clear();
    } else if (n == "EnumTools") {
      no_args(a);
      for (const auto& t : tools) data("\"" + t.name + "\"");
    } else if (n == "ChangeTool" || n == "SetTool") {
      const auto k = named_tool(a);
      select_on_machine(tools[k]);
      active_tool = k;
    } else if (n == "FindTool") {
      found_tool = named_tool(a);
    } else if (n == "FoundTool") {
      no_args(a);
      data("FoundTool.Name(\"" + tools[found_tool].name + "\")");
    } else if (n == "GetChangeToolAction") {
      const auto k = named_tool(a);
      const Vec3 p = to_csy(machine.state().position_mm);
      data(std::string("ChangeToolAction(") + (k == active_tool ? "None" : "Switch") + ", X(" + format_number(p.x()) +
           "), Y(" + format_number(p.y()) + "), Z(" + format_number(p.z()) + "))");
    } else if (n == "AlignTool") {
      // A fixed probe head: the tool's alignment is answered when it lies within the tolerance.
      require_motion_ready();
      const auto v = numbers(a);
      if (v.size() != 4 && v.size() != 8) fail(ErrorCode::IncorrectArguments);
      Vec3 want(v[0], v[1], v[2]);
      if (want.norm() < 1e-12) fail(ErrorCode::VectorHasNoNorm);
      const Vec3 have = tool().definition ? Vec3(dir_to_csy(-tool().definition->stylus_direction)) : Vec3(0, 0, 1);
      const double tolerance_deg = v.size() == 4 ? v[3] : v[6];
      const double angle = std::acos(std::clamp(want.normalized().dot(have), -1.0, 1.0)) / k_deg;
      if (angle > tolerance_deg) fail(ErrorCode::AngleOutOfRange);
      data(format_number(have.x()) + ", " + format_number(have.y()) + ", " + format_number(have.z()));
    } else if (n == "GetProp" || n == "GetPropE") {
      if (a.empty()) fail(ErrorCode::IncorrectArguments);
      std::string body;
      for (const auto& x : a) body += (body.empty() ? "" : ", ") + get_property(x);
      data(body);
    } else if (n == "SetProp" || n == "SetPropE") {
      if (a.empty()) fail(ErrorCode::IncorrectArguments);
      bool clamped = false;
      for (const auto& x : a) clamped = set_property(x) || clamped;
      if (&tool() == &tools[active_tool]) {
        const auto& num = tool().numbers;
        run(SetFeeds{num.at("GoToPar.Speed").act, num.at("PtMeasPar.Speed").act, 0});
      }
      if (clamped) fail(ErrorCode::ArgumentOutOfRange);
    } else if (n == "EnumProp" || n == "EnumAllProp") {
      if (a.size() != 1 || a[0].kind != Argument::Kind::Call || !a[0].args.empty()) fail(ErrorCode::IncorrectArguments);
      enum_properties(a[0].text, n == "EnumAllProp");
    } else if (n == "GetCoordSystem") {
      no_args(a);
      data("CoordSystem(" + active_csy + ")");
    } else if (n == "SetCoordSystem") {
      if (a.size() != 1 || !csy_name_argument(a[0])) fail(ErrorCode::IncorrectArguments);
      // MCS and PCS: the shorthands of the specification's example dialogs, as clients send them.
      const std::string csy = a[0].text == "MCS" ? "MachineCsy" : a[0].text == "PCS" ? "PartCsy" : a[0].text;
      if (std::find(k_csy_names.begin(), k_csy_names.end(), csy) == k_csy_names.end()) fail(ErrorCode::BadArgument);
      active_csy = csy;
    } else if (n == "GetCsyTransformation") {
      if (a.size() != 1 || !csy_name_argument(a[0])) fail(ErrorCode::IncorrectArguments);
      const auto it = csys.find(a[0].text);
      if (it == csys.end()) fail(ErrorCode::BadArgument);
      data("GetCsyTransformation(" + transformation_text(it->second) + ")");
    } else if (n == "SetCsyTransformation") {
      if (a.size() != 7 || !csy_name_argument(a[0])) fail(ErrorCode::IncorrectArguments);
      const auto it = csys.find(a[0].text);
      if (it == csys.end()) fail(ErrorCode::BadArgument);
      const auto v = numbers(Args(a.begin() + 1, a.end()));
      if (v[3] < 0 || v[3] > 180) fail(ErrorCode::ThetaOutOfRange);
      it->second = {v[0], v[1], v[2], v[3], v[4], v[5]};
    } else if (n == "SaveActiveCoordSystem") {
      saved_csys[one_string(a)] = active();
    } else if (n == "LoadCoordSystem") {
      const auto it = saved_csys.find(one_string(a));
      if (it == saved_csys.end()) fail(ErrorCode::BadArgument);
      csys["PartCsy"] = it->second;
      active_csy = "PartCsy";
    } else if (n == "SaveNamedCsyTransformation") {
      // I++ DME 1.5: a named part system from its transformation, without making it active.
      if (a.size() != 7 || a[0].kind != Argument::Kind::String) fail(ErrorCode::IncorrectArguments);
      const auto v = numbers(Args(a.begin() + 1, a.end()));
      if (v[3] < 0 || v[3] > 180) fail(ErrorCode::ThetaOutOfRange);
      saved_csys[a[0].text] = {v[0], v[1], v[2], v[3], v[4], v[5]};
    } else if (n == "GetNamedCsyTransformation") {
      const auto it = saved_csys.find(one_string(a));
      if (it == saved_csys.end()) fail(ErrorCode::BadArgument);
      data("GetNamedCsyTransformation(" + transformation_text(it->second) + ")");
    } else if (n == "DeleteCoordSystem") {
      if (saved_csys.erase(one_string(a)) == 0) fail(ErrorCode::BadArgument);
    } else if (n == "EnumCoordSystems") {
      no_args(a);
      for (const auto& [name, csy] : saved_csys) data("\"" + name + "\"");
    } else if (n == "GoTo") {
      go_to(a);
    } else if (n == "PtMeas") {
      pt_meas(a);
    } else if (n == "Get") {
      get(a);
    } else if (n == "GetPos") {  // not in I++ DME 1.4: Get(X(), Y(), Z()) under a clearer name
      no_args(a);
      const Vec3 p = to_csy(machine.state().position_mm);
      data("X(" + format_number(p.x()) + "), Y(" + format_number(p.y()) + "), Z(" + format_number(p.z()) + ")");
    } else if (n == "ReQualify") {
      no_args(a);
      require_motion_ready();
      require_probing_tool();
      const Response q = run(QualifyTool{});
      if (q.tool) tool().qualified_radius_mm = q.tool->effective_radius_mm;
      move_reports();
    } else if (n == "ScanUnknownHint") {
      if (a.size() != 1) fail(ErrorCode::IncorrectArguments);
      if (!a[0].is_number() || a[0].number <= 0) fail(ErrorCode::BadArgument);
      scan_hint_min_radius_mm = a[0].number;
    } else if (n == "ScanOnCircleHint" || n == "ScanOnLineHint" || n == "ScanOnCurveHint") {
      // Hints (I++ DME 1.5, 4.3.2.2.1.1): the expected deviations from the nominal (circle:
      // displacement and form; line: angle and form; curve: deviation and least radius of
      // curvature), which "the DME must be able to execute without". The scans here follow the
      // surface they feel: the hints are checked, and not needed.
      if (a.size() != 2 || !a[0].is_number() || !a[1].is_number()) fail(ErrorCode::IncorrectArguments);
      if (a[0].number < 0 || a[1].number < 0) fail(ErrorCode::BadArgument);
    } else if (n == "ScanOnCurveDensity") {
      scan_on_curve_density(a);
    } else if (n == "ScanOnLine" || n == "ScanOnCircle") {
      scan(n, a);
    } else if (n == "ScanOnCurve") {
      scan_on_curve(a);
    } else if (n == "ScanInPlaneEndIsSphere" || n == "ScanInPlaneEndIsPlane" || n == "ScanInPlaneEndIsCyl" ||
               n == "ScanInCylEndIsSphere" || n == "ScanInCylEndIsPlane") {
      scan_in(n, a);
    } else if (k_unsupported.count(n)) {
      if (k_unsupported_motion.count(n)) require_motion_ready();
      fail(ErrorCode::UnsupportedCommand);
    } else {
      fail(ErrorCode::IllegalCommand);
    }
  }

  void error_line(const Tag& t, ErrorCode code, std::string_view cause) {
    const std::string line = format_error(t, code, cause);
    out->push_back(line);
    if (static_cast<int>(error_info(code).severity) >= static_cast<int>(Severity::Stop)) {
      error_state = true;
      pending_errors.push_back(line.substr(8));
    }
  }

  SessionReply handle(std::string_view line) {
    SessionReply reply = handle_line(line);
    finish(reply);
    return reply;
  }
  // Every line is due at once except what waits for the motion: reports along it at their time,
  // everything after the acknowledgement at the motion's end.
  void finish(SessionReply& reply) {
    reply.due_s.assign(reply.lines.size(), 0.0);
    for (std::size_t i = 1; i < reply.lines.size(); ++i) {
      const auto it = line_due_s.find(i);
      reply.due_s[i] = it != line_due_s.end() ? std::min(it->second, reply.motion_s) : reply.motion_s;
    }
    line_due_s.clear();
    out = nullptr;
  }

  SessionReply handle_line(std::string_view line) {
    SessionReply reply;
    out = &reply.lines;
    motion_s = 0;
    line_due_s.clear();
    while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.remove_suffix(1);
    auto parsed = parse_command_line(line);
    if (!parsed) {
      // Without a readable tag the error goes out under the server's own tag E0000.
      const Tag t = parsed.error().tag.value_or(Tag{true, 0});
      if (parsed.error().tag) out->push_back(format_ack(t));
      error_line(t, parsed.error().code, line);
      if (parsed.error().tag) out->push_back(format_complete(t));
      return reply;
    }
    tag = parsed->tag;
    command_text = parsed->text;
    out->push_back(format_ack(tag));
    running.reset();
    if (observing &&
        std::any_of(daemons.begin(), daemons.end(), [](const auto& d) { return d.second.along_motion(); })) {
      const MachineState s = machine.state();
      command_start_s = s.time_s;
      for (auto& [daemon_tag, d] : daemons) d.last_s = s.time_s, d.last_mm = s.position_mm;
    }
    bool failed = false;
    try {
      dispatch(*parsed);
    } catch (const CommandError& e) {
      error_line(tag, e.code, e.cause.empty() ? command_text : e.cause);
      failed = true;
    }
    out->push_back(format_complete(tag));
    reply.motion_s = motion_s;
    if (!failed && motion_s > 0) running = Running{tag, command_text};
    return reply;
  }

  // AbortE while the last command's answer is paced: the machine stops that command where it
  // was `elapsed_s` into its motion (a GoTo, a probing cycle's moves, an active scan; the
  // command's result is lost), and the command is answered 0006 before the AbortE completes,
  // as the NIST server answers AbortE_TestWhileMoving.prg.
  SessionReply interrupt(std::string_view line, double elapsed_s) {
    auto parsed = parse_command_line(line);
    if (!running || !parsed || parsed->name != "AbortE" || !parsed->tag.event || !parsed->args.empty() || !started) {
      const auto keep = running;  // another E-command leaves the paced command running
      SessionReply reply = handle(line);
      if (parsed && parsed->tag.event) running = keep;
      return reply;
    }
    SessionReply reply;
    out = &reply.lines;
    motion_s = 0;
    out->push_back(format_ack(parsed->tag));
    const Running stopped = *running;
    running.reset();
    machine.stop_last_motion(elapsed_s);
    error_line(stopped.tag, ErrorCode::TransactionAborted, stopped.text);
    out->push_back(format_complete(stopped.tag));
    out->push_back(format_complete(parsed->tag));
    reply.interrupted = true;
    line_due_s.clear();
    finish(reply);
    return reply;
  }
};

Session::Session(Machine& machine, SessionOptions options)
    : m_impl(std::make_unique<Impl>(machine, std::move(options))) {}
Session::~Session() = default;
SessionReply Session::handle(std::string_view line) { return m_impl->handle(line); }
SessionReply Session::interrupt(std::string_view line, double elapsed_s) { return m_impl->interrupt(line, elapsed_s); }
bool Session::ended() const { return m_impl->ended; }

}  // namespace metron::machine::ipp
