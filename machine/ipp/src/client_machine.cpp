// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/ipp/client_machine.hpp"

#include "metron/machine/aborted_response.hpp"

#include <charconv>
#include <cstdio>
#include <deque>
#include <functional>
#include <map>
#include <stdexcept>

#include <asio.hpp>

#include "metron/machine/ipp/command_line.hpp"
#include "metron/machine/ipp/response_line.hpp"

namespace metron::machine::ipp {
namespace {

using asio::ip::tcp;

/// The answer to one protocol command.
struct Answer {
  std::vector<std::string> data;  ///< bodies of its `#` lines
  std::optional<ResponseLine> error;
};

std::string number(double v) { return format_number(v, 9); }

std::string xyz(const Vec3& p) {
  return "X(" + number(p.x()) + "), Y(" + number(p.y()) + "), Z(" + number(p.z()) + ")";
}

FaultKind fault_kind(int error_number) {
  switch (error_number) {
    case 2504: return FaultKind::Collision;
    case 1003:
    case 1006: return FaultKind::NoContact;
    case 2001: return FaultKind::OverTravel;
    case 1008:
    case 2500: return FaultKind::AxisLimit;
    case 2002: return FaultKind::NoTool;
    case 1502:
    case 1503: return FaultKind::UnknownTool;
    case 6: return FaultKind::Aborted;
    case 511: return FaultKind::Stalled;
    case 503: return FaultKind::Communication;
    default: return FaultKind::BadCommand;
  }
}

std::optional<double> item(const std::string& body, const std::string& name, std::size_t index = 0) {
  auto args = parse_arguments(body);
  if (!args) return std::nullopt;
  for (const auto& a : *args)
    if (a.is_call(name) && a.args.size() > index && a.args[index].is_number()) return a.args[index].number;
  return std::nullopt;
}

}  // namespace

std::optional<std::pair<std::string, std::uint16_t>> parse_ipp_url(std::string_view url) {
  constexpr std::string_view scheme = "ipp://";
  if (url.substr(0, scheme.size()) != scheme) return std::nullopt;
  url.remove_prefix(scheme.size());
  while (!url.empty() && url.back() == '/') url.remove_suffix(1);
  const auto colon = url.rfind(':');
  std::string host(url.substr(0, colon));
  std::uint16_t port = 1294;
  if (colon != std::string_view::npos) {
    const auto p = url.substr(colon + 1);
    const auto [end, ec] = std::from_chars(p.data(), p.data() + p.size(), port);
    if (ec != std::errc() || end != p.data() + p.size()) return std::nullopt;
  }
  if (host.empty()) return std::nullopt;
  return std::make_pair(host, port);
}

namespace {

/// A tool the server offers, as its properties describe it.
struct ServerTool {
  std::string name;
  double radius_mm = 0;           ///< Tool.AvrRadius (0: no stylus, or not answered)
  std::optional<Vec3> alignment;  ///< Tool.Alignment: from the tip towards the head
};

std::string describe(const DefineTool& d) {
  const Vec3 u = d.stylus_direction.normalized();
  return "ball " + format_number(d.ball_diameter_mm, 4) + " mm, stylus (" + format_number(u.x(), 4) + ", " +
         format_number(u.y(), 4) + ", " + format_number(u.z(), 4) + ")";
}

std::string describe(const ServerTool& t) {
  std::string s = t.name + " (ball " + format_number(2 * t.radius_mm, 4) + " mm";
  if (t.alignment) {
    const Vec3 u = -*t.alignment;
    s += ", stylus (" + format_number(u.x(), 4) + ", " + format_number(u.y(), 4) + ", " + format_number(u.z(), 4) + ")";
  }
  return s + ")";
}

// Geometry that counts as "the same tool": the ball diameter to 1 µm, the stylus direction to
// 0.1° (a qualified tool's radius differs from its nominal one by the pre-travel, which is why
// the server's nominal/average radius before qualification is compared).
constexpr double k_same_radius_mm = 0.0005;
constexpr double k_same_direction_cos = 0.9999985;

}  // namespace

struct ClientMachine::Impl {
  asio::io_context io;
  tcp::socket socket{io};
  asio::streambuf input;
  std::uint32_t tag = 0;
  std::vector<std::string> transcript;
  std::deque<Command> queue;
  std::map<std::string, DefineTool> definitions;
  std::map<std::string, ServerTool> mapped;             ///< DMIS sensor label -> the server's tool
  std::optional<std::vector<ServerTool>> server_tools;  ///< read once, on the first DefineTool
  std::function<void(const std::string&)> on_warning;
  std::optional<ToolInfo> tool;
  double positioning_feed = 0, measuring_feed = 0;
  std::size_t executed = 0;
  std::optional<std::string> lost;    ///< why the connection is gone (then every command faults)
  bool density_supported = true;      ///< the server answered ScanOnCurveDensity (or was not asked yet)
  Vec3 last_position = Vec3::Zero();  ///< the last position the server answered

  std::string read_line() {
    asio::read_until(socket, input, '\n');
    std::istream in(&input);
    std::string line;
    std::getline(in, line);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    transcript.push_back("< " + line);
    return line;
  }

  /// Sends one command and reads up to its `%`; an error leaves the server cleared again. A lost
  /// connection or an unreadable answer throws std::runtime_error and marks the connection lost.
  Answer call(const std::string& command, bool clear_errors = true) {
    if (lost) throw std::runtime_error(*lost);
    try {
      return exchange(command, clear_errors);
    } catch (const std::exception& e) {
      lost = std::string("the connection to the I++ server is lost: ") + e.what();
      asio::error_code ignored;
      socket.close(ignored);
      throw std::runtime_error(*lost);
    }
  }

  Answer exchange(const std::string& command, bool clear_errors) {
    tag = tag % 99999 + 1;
    const Tag t{false, tag};
    const std::string line = t.text() + " " + command;
    transcript.push_back("> " + line);
    asio::write(socket, asio::buffer(line + "\r\n"));
    Answer answer;
    for (;;) {
      const std::string l = read_line();
      auto r = parse_response_line(l);
      if (!r) throw std::runtime_error("ipp: unreadable answer '" + l + "'");
      if (r->tag.event && r->tag.number == 0 && r->kind == ResponseLine::Kind::Error) {
        if (!(r->tag == t)) throw std::runtime_error("ipp: the server refused: " + l);
      }
      if (!(r->tag == t)) continue;  // daemon reports
      if (r->kind == ResponseLine::Kind::Data) answer.data.push_back(r->body);
      if (r->kind == ResponseLine::Kind::Error) answer.error = *r;
      if (r->kind == ResponseLine::Kind::Complete) break;
    }
    if (answer.error && clear_errors && answer.error->severity >= 3) exchange("ClearAllErrors()", false);
    return answer;
  }

  /// The ball centre as the server reports it; the last known one once the connection is lost.
  Vec3 position() {
    if (lost) return last_position;
    try {
      const Answer a = call("Get(X(), Y(), Z())");
      if (!a.data.empty())
        last_position = {item(a.data[0], "X").value_or(0), item(a.data[0], "Y").value_or(0),
                         item(a.data[0], "Z").value_or(0)};
    } catch (const std::runtime_error&) {  // lost: reported by the next command's fault
    }
    return last_position;
  }

  /// EnumTools, then FindTool and GetProp(FoundTool.AvrRadius(), FoundTool.Alignment()) for each:
  /// what a client can learn about the server's tools without changing the mounted one.
  const std::vector<ServerTool>& enumerate_tools() {
    if (server_tools) return *server_tools;
    server_tools.emplace();
    const Answer list = call("EnumTools()");
    for (const auto& body : list.data) {
      auto args = parse_arguments(body);
      if (!args || args->size() != 1 || (*args)[0].kind != Argument::Kind::String) continue;
      ServerTool t;
      t.name = (*args)[0].text;
      if (call("FindTool(\"" + t.name + "\")").error) continue;
      // A server without AvrRadius answers an error for the pair: then only the name can match.
      const Answer p = call("GetProp(FoundTool.AvrRadius(), FoundTool.Alignment())");
      if (!p.error && !p.data.empty()) {
        t.radius_mm = item(p.data[0], "FoundTool.AvrRadius").value_or(0);
        const auto i = item(p.data[0], "FoundTool.Alignment", 0), j = item(p.data[0], "FoundTool.Alignment", 1),
                   k = item(p.data[0], "FoundTool.Alignment", 2);
        if (i && j && k && Vec3(*i, *j, *k).norm() > 1e-9) t.alignment = Vec3(*i, *j, *k).normalized();
      }
      server_tools->push_back(t);
    }
    return *server_tools;
  }

  /// The server's tool for a DMIS sensor (SNSDEF): the one of the same name, else the one with
  /// the same ball diameter and stylus direction (with a warning), else a fault that names the
  /// sensor and lists what the server offers.
  tl::expected<ServerTool, std::string> resolve_tool(const DefineTool& d) {
    const auto& tools = enumerate_tools();
    const Vec3 want_alignment = -d.stylus_direction.normalized();
    const auto same_geometry = [&](const ServerTool& t) {
      return t.radius_mm > 0 && std::abs(2 * t.radius_mm - d.ball_diameter_mm) <= 2 * k_same_radius_mm &&
             (!t.alignment || t.alignment->dot(want_alignment) >= k_same_direction_cos);
    };
    for (const auto& t : tools)
      if (t.name == d.name) {
        if (t.radius_mm > 0 && !same_geometry(t))
          warn("sensor S(" + d.name + ") = SNSDEF (" + describe(d) + "): the I++ server's tool of the same name is " +
               describe(t) + "; its geometry is used");
        return t;
      }
    for (const auto& t : tools)
      if (same_geometry(t)) {
        warn("sensor S(" + d.name + ") = SNSDEF (" + describe(d) + "): the I++ server has no tool " + d.name +
             "; using its tool " + describe(t) + ", the same geometry");
        return t;
      }
    std::string offered;
    for (const auto& t : tools)
      if (t.radius_mm > 0) offered += (offered.empty() ? "" : ", ") + describe(t);
    return tl::unexpected("sensor S(" + d.name + ") = SNSDEF (" + describe(d) + "): the I++ server has no tool named " +
                          d.name + " and none with this geometry; it offers " +
                          (offered.empty() ? std::string("no probing tool") : offered) +
                          " (metron serve: --probe-diameter or --tool NAME=DIAMETER)");
  }

  void warn(const std::string& message) {
    transcript.push_back("! warning: " + message);
    if (on_warning) on_warning(message);
  }

  /// Tool.AvrRadius of the mounted tool (nullopt when the server does not answer it).
  std::optional<double> mounted_radius() {
    const Answer a = call("GetProp(Tool.AvrRadius())");
    if (a.error || a.data.empty()) return std::nullopt;
    const auto r = item(a.data[0], "Tool.AvrRadius");
    return r && *r > 0 ? r : std::nullopt;
  }

  Response fault(std::uint64_t command_tag, const ResponseLine& e) {
    Response r;
    r.tag = command_tag;
    r.status = Response::Status::Fault;
    r.fault = Fault{fault_kind(e.error_number), e.error_text + " (" + e.error_cause + ")", position(), 0};
    return r;
  }

  /// ScanPath -> ScanOnCurve through the path's interpolation points, moved back from the
  /// reference deflection E0 to the ball centre at the nominal contact (the server moves them by
  /// its own E0 into the surface again); the samples' X, Y, Z and IJK (the deflection direction)
  /// come back as ScanSamples. A path that ends where it starts is sent Closed(1).
  Response scan(std::uint64_t command_tag, const ScanPath& body) {
    Response done;
    done.tag = command_tag;
    const auto& path = body.path;
    if (path.segments.empty() || path.normals.size() != path.segments.size() + 1) {
      done.status = Response::Status::Fault;
      done.fault =
          Fault{FaultKind::BadCommand, "a scan path needs segments and a normal at each point", last_position, 0};
      return done;
    }
    const double e0 = body.reference_deflection_mm.value_or(0.3);
    std::vector<Vec3> points, normals;
    for (std::size_t k = 0; k < path.segments.size(); ++k)
      points.push_back(path.segments[k].start()), normals.push_back(path.normals[k]);
    points.push_back(path.segments.back().end()), normals.push_back(path.normals.back());
    const bool closed = points.size() > 3 && (points.back() - points.front()).norm() < 1e-6;
    if (closed) points.pop_back(), normals.pop_back();
    std::string data;
    for (std::size_t k = 0; k < points.size(); ++k) {
      const Vec3 n = normals[k].normalized();
      const Vec3 p = points[k] + e0 * n;
      data += (k ? ", " : "") + number(p.x()) + ", " + number(p.y()) + ", " + number(p.z()) + ", " + number(n.x()) +
              ", " + number(n.y()) + ", " + number(n.z());
    }
    return scan_command(command_tag,
                        std::string("ScanOnCurve(Closed(") + (closed ? "1" : "0") +
                            "), Format(X(), Y(), Z(), IJK()), Data(" + data + "))",
                        e0, body.speed_mm_s.value_or(measuring_feed), body.sample_spacing_mm, true);
  }

  // An unknown-contour scan is the I++ DME ScanIn... command of its section and end (docs/ipp-dme.md).
  Response contour_scan(std::uint64_t command_tag, const ContourScan& body) {
    const auto v3 = [](const Vec3& p) { return number(p.x()) + ", " + number(p.y()) + ", " + number(p.z()); };
    const Vec3 n = body.start_normal.normalized();
    const double step = body.sample_spacing_mm > 0 ? body.sample_spacing_mm : 0.1;
    // I++ gives the direction as a point D: the start plus the direction.
    const std::string start =
        v3(body.start_mm) + ", " + v3(n) + ", " + v3(body.start_mm + body.direction.normalized()) + ", " + number(step);
    std::string end;
    const Vec3 ed = body.end.direction.normalized();
    switch (body.end.kind) {
      case ContourEnd::Kind::Sphere: end = "EndIsSphere"; break;
      case ContourEnd::Kind::Plane: end = "EndIsPlane"; break;
      case ContourEnd::Kind::Cylinder: end = "EndIsCyl"; break;
    }
    std::string end_args = v3(body.end.point_mm);
    if (body.end.kind == ContourEnd::Kind::Sphere)
      end_args += ", " + number(body.end.diameter_mm);
    else if (body.end.kind == ContourEnd::Kind::Plane)
      end_args += ", " + v3(ed) + ", " + std::to_string(body.end.crossings);
    else
      end_args += ", " + v3(ed) + ", " + number(body.end.diameter_mm) + ", " + std::to_string(body.end.crossings);
    end_args += ", " + v3(n);  // the surface normal at the end: not known ahead, the start's stands for it
    std::string text;
    if (body.section.kind == ContourSection::Kind::Plane) {
      text = "ScanInPlane" + end + "(" + start + ", " + end_args + ")";
    } else {
      if (body.end.kind == ContourEnd::Kind::Cylinder) {
        Response r;
        r.tag = command_tag;
        r.status = Response::Status::Fault;
        r.fault = Fault{FaultKind::BadCommand,
                        "I++ DME has no cylinder section with a cylinder end (ScanInCylEndIsCyl)", last_position, 0};
        return r;
      }
      text = "ScanInCyl" + end + "(" + v3(body.section.point_mm) + ", " + v3(body.section.direction.normalized()) +
             ", " + start + ", " + end_args + ")";
    }
    return scan_command(command_tag, text, body.reference_deflection_mm.value_or(0.3),
                        body.speed_mm_s.value_or(measuring_feed), body.sample_spacing_mm, false);
  }

  /// Sends a scan command with its speed and report format and reads its samples (X, Y, Z, IJK).
  Response scan_command(std::uint64_t command_tag, const std::string& text, double e0, double speed, double spacing_mm,
                        bool density_applies) {
    Response done;
    done.tag = command_tag;
    auto fault_of = [&](const Answer& a) -> std::optional<Response> {
      if (a.error && a.error->severity >= 2) return fault(command_tag, *a.error);
      return std::nullopt;
    };
    if (speed > 0)
      if (auto f = fault_of(call("SetProp(Tool.PtMeasPar.Speed(" + number(speed) + "))"))) return *f;
    if (auto f = fault_of(call("OnScanReport(X(), Y(), Z(), IJK())"))) return *f;
    // The program's point density (SCNSET): at most this far apart, if the server takes it.
    if (density_applies && spacing_mm > 0 && density_supported) {
      const Answer d = call("ScanOnCurveDensity(Dis(" + number(spacing_mm) + "))");
      if (d.error) {
        density_supported = false;
        warn("the I++ server does not take ScanOnCurveDensity (" + d.error->error_text +
             "): scanned points are as dense as the server chooses, not every " + number(spacing_mm) + " mm");
      }
    }
    const Answer a = call(text);
    if (auto f = fault_of(a)) return *f;
    std::vector<double> v;
    for (const auto& body_line : a.data) {
      std::size_t start = 0;
      while (start < body_line.size()) {
        const auto comma = body_line.find(',', start);
        const std::string field =
            body_line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        double x = 0;
        const auto* b = field.data() + field.find_first_not_of(' ');
        std::from_chars(b, field.data() + field.size(), x);
        v.push_back(x);
        if (comma == std::string::npos) break;
        start = comma + 1;
      }
    }
    double s_mm = 0;
    for (std::size_t k = 0; k + 5 < v.size(); k += 6) {
      ScanSample sample;
      sample.centre_mm = {v[k], v[k + 1], v[k + 2]};
      // The report carries the deflection's direction; its size is the reference deflection.
      sample.deflection_mm = e0 * Vec3(v[k + 3], v[k + 4], v[k + 5]);
      if (!done.scan.empty()) s_mm += (sample.centre_mm - done.scan.back().centre_mm).norm();
      sample.path_s_mm = s_mm;
      done.scan.push_back(sample);
    }
    if (measuring_feed > 0) call("SetProp(Tool.PtMeasPar.Speed(" + number(measuring_feed) + "))");
    return done;
  }

  Response run(const Command& c) {
    Response done;
    done.tag = c.tag;
    auto check = [&](const Answer& a) -> std::optional<Response> {
      if (a.error && a.error->severity >= 2) return fault(c.tag, *a.error);
      return std::nullopt;
    };
    return std::visit(
        [&](const auto& body) -> Response {
          using T = std::decay_t<decltype(body)>;
          if constexpr (std::is_same_v<T, GoTo>) {
            if (body.speed_mm_s)
              if (auto f = check(call("SetProp(Tool.GoToPar.Speed(" + number(*body.speed_mm_s) + "))"))) return *f;
            if (auto f = check(call("GoTo(" + xyz(body.target_mm) + ")"))) return *f;
            if (body.speed_mm_s && positioning_feed > 0)
              call("SetProp(Tool.GoToPar.Speed(" + number(positioning_feed) + "))");
            return done;
          } else if constexpr (std::is_same_v<T, PtMeas>) {
            if (body.two_touch || body.blend_mm) {
              Response r;
              r.tag = c.tag;
              r.status = Response::Status::Fault;
              r.fault = Fault{FaultKind::BadCommand, "two-touch and blended cycles are not part of I++ DME PtMeas",
                              Vec3::Zero(), 0};
              return r;
            }
            const double speed = body.speed_mm_s.value_or(measuring_feed);
            if (auto f = check(
                    call("SetProp(Tool.PtMeasPar.Approach(" + number(body.approach_mm) + "), Tool.PtMeasPar.Search(" +
                         number(body.search_mm) + "), Tool.PtMeasPar.Retract(" + number(body.retract_mm) + ")" +
                         (speed > 0 ? ", Tool.PtMeasPar.Speed(" + number(speed) + ")" : std::string()) + ")")))
              return *f;
            const Vec3 n = body.normal.normalized();
            const double r_mm = tool ? tool->effective_radius_mm : 0;
            // I++ DME PtMeas takes the ball centre at the nominal contact (docs/ipp-dme.md).
            const Answer a = call("OnPtMeasReport(X(), Y(), Z(), IJK(), ER())");
            if (auto f = check(a)) return *f;
            const Answer m = call("PtMeas(" + xyz(body.nominal_mm + r_mm * n) + ", IJK(" + number(n.x()) + ", " +
                                  number(n.y()) + ", " + number(n.z()) + "))");
            if (auto f = check(m)) return *f;
            if (m.data.empty())
              return fault(c.tag, ResponseLine{{}, ResponseLine::Kind::Error, "", 2, 1003, "PtMeas", "No touch"});
            Hit h;
            h.centre_mm = {item(m.data[0], "X").value_or(0), item(m.data[0], "Y").value_or(0),
                           item(m.data[0], "Z").value_or(0)};
            h.normal = n;
            h.ball_radius_mm = item(m.data[0], "ER").value_or(r_mm);
            done.hit = h;
            return done;
          } else if constexpr (std::is_same_v<T, DefineTool>) {
            // An I++ server owns its tools: the sensor is mapped onto one of them, as I++ clients do.
            auto server_tool = resolve_tool(body);
            if (!server_tool) {
              Response r;
              r.tag = c.tag;
              r.status = Response::Status::Fault;
              r.fault = Fault{FaultKind::UnknownTool, server_tool.error(), position(), 0};
              return r;
            }
            definitions[body.name] = body;
            mapped[body.name] = *server_tool;
            ToolInfo info;
            info.name = body.name;
            info.nominal_radius_mm = info.effective_radius_mm =
                server_tool->radius_mm > 0 ? server_tool->radius_mm : body.ball_diameter_mm / 2;
            done.tool = info;
            return done;
          } else if constexpr (std::is_same_v<T, SelectTool>) {
            const auto m = mapped.find(body.name);
            const std::string server_name = m != mapped.end() ? m->second.name : body.name;
            if (auto f = check(call("ChangeTool(\"" + server_name + "\")"))) return *f;
            ToolInfo info;
            info.name = body.name;
            if (auto d = definitions.find(body.name); d != definitions.end())
              info.nominal_radius_mm = info.effective_radius_mm = d->second.ball_diameter_mm / 2;
            if (m != mapped.end() && m->second.radius_mm > 0)
              info.nominal_radius_mm = info.effective_radius_mm = m->second.radius_mm;
            if (const auto r = mounted_radius()) info.effective_radius_mm = *r;
            tool = info;
            done.tool = info;
            // Feeds are per tool on the server: read the new tool's, unless this client set them.
            const Answer feeds = call("GetProp(Tool.GoToPar.Speed(), Tool.PtMeasPar.Speed())");
            if (!feeds.data.empty()) {
              if (!(positioning_feed > 0)) positioning_feed = item(feeds.data[0], "Tool.GoToPar.Speed").value_or(0);
              if (!(measuring_feed > 0)) measuring_feed = item(feeds.data[0], "Tool.PtMeasPar.Speed").value_or(0);
            }
            if (positioning_feed > 0 && measuring_feed > 0)
              call("SetProp(Tool.GoToPar.Speed(" + number(positioning_feed) + "), Tool.PtMeasPar.Speed(" +
                   number(measuring_feed) + "))");
            return done;
          } else if constexpr (std::is_same_v<T, QualifyTool>) {
            if (auto f = check(call("ReQualify()"))) return *f;
            if (tool) {
              tool->qualified = true;
              // The qualified (effective) radius, which the server also uses for PtMeas nominals.
              if (const auto r = mounted_radius()) tool->effective_radius_mm = *r;
            }
            done.tool = tool;
            return done;
          } else if constexpr (std::is_same_v<T, SetFeeds>) {
            std::string props;
            auto add = [&](const std::string& p) { props += (props.empty() ? "" : ", ") + p; };
            if (body.positioning_mm_s > 0)
              add("Tool.GoToPar.Speed(" + number(body.positioning_mm_s) + ")"),
                  positioning_feed = body.positioning_mm_s;
            if (body.measuring_mm_s > 0)
              add("Tool.PtMeasPar.Speed(" + number(body.measuring_mm_s) + ")"), measuring_feed = body.measuring_mm_s;
            if (body.acceleration_mm_s2 > 0)
              add("Tool.GoToPar.Accel(" + number(body.acceleration_mm_s2) + "), Tool.PtMeasPar.Accel(" +
                  number(body.acceleration_mm_s2) + ")");
            if (!props.empty())
              if (auto f = check(call("SetProp(" + props + ")"))) return *f;
            return done;
          } else if constexpr (std::is_same_v<T, ScanPath>) {
            return scan(c.tag, body);
          } else if constexpr (std::is_same_v<T, ContourScan>) {
            return contour_scan(c.tag, body);
          } else {
            Response r;
            r.tag = c.tag;
            r.status = Response::Status::Fault;
            r.fault = Fault{FaultKind::BadCommand, "segmented scans (ScanBufferWrite) are not mapped onto I++ DME",
                            Vec3::Zero(), 0};
            return r;
          }
        },
        c.body);
  }
};

ClientMachine::ClientMachine(const std::string& host, std::uint16_t port) : m_impl(std::make_unique<Impl>()) {
  tcp::resolver resolver(m_impl->io);
  asio::connect(m_impl->socket, resolver.resolve(host, std::to_string(port)));
  m_impl->socket.set_option(tcp::no_delay(true));
  const Answer start = m_impl->call("StartSession()");
  if (start.error) throw std::runtime_error("ipp: StartSession refused: " + start.error->error_text);
  const Answer homed = m_impl->call("IsHomed()");
  if (homed.data.empty() || homed.data[0] != "IsHomed(1)") {
    const Answer h = m_impl->call("Home()");
    if (h.error) throw std::runtime_error("ipp: Home failed: " + h.error->error_text);
  }
}

ClientMachine::~ClientMachine() {
  try {
    m_impl->call("EndSession()", false);
  } catch (...) {  // the server may already be gone; nothing to report from a destructor
  }
}

void ClientMachine::submit(Command command) { m_impl->queue.push_back(std::move(command)); }

std::vector<Response> ClientMachine::execute() {
  std::vector<Response> out;
  bool faulted = false;
  while (!m_impl->queue.empty()) {
    Command c = std::move(m_impl->queue.front());
    m_impl->queue.pop_front();
    if (faulted) {
      out.push_back(aborted_response(c, Vec3::Zero(), 0));  // the protocol gives no clock
      continue;
    }
    try {
      out.push_back(m_impl->run(c));
    } catch (const std::runtime_error& e) {
      // The server went away (or answered nonsense): a fault of this command, not a crash.
      Response r;
      r.tag = c.tag;
      r.status = Response::Status::Fault;
      r.fault = Fault{FaultKind::Communication, e.what(), m_impl->last_position, 0};
      out.push_back(std::move(r));
    }
    ++m_impl->executed;
    faulted = out.back().status == Response::Status::Fault;
  }
  return out;
}

MachineState ClientMachine::state() const {
  MachineState s;
  s.position_mm = m_impl->position();
  s.tool = m_impl->tool;
  s.active_tool = m_impl->tool ? m_impl->tool->name : "";
  s.positioning_feed_mm_s = m_impl->positioning_feed;
  s.measuring_feed_mm_s = m_impl->measuring_feed;
  s.queued_commands = m_impl->queue.size();
  s.executed_commands = m_impl->executed;
  return s;
}

std::vector<Command> ClientMachine::queued() const { return {m_impl->queue.begin(), m_impl->queue.end()}; }

const std::vector<std::string>& ClientMachine::transcript() const { return m_impl->transcript; }

void ClientMachine::on_warning(std::function<void(const std::string&)> handler) {
  m_impl->on_warning = std::move(handler);
}

}  // namespace metron::machine::ipp
