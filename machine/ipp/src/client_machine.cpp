// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/ipp/client_machine.hpp"

#include "metron/machine/aborted_response.hpp"

#include <charconv>
#include <cstdio>
#include <deque>
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
  std::vector<std::string> data;      ///< bodies of its `#` lines
  std::optional<ResponseLine> error;
};

std::string number(double v) { return format_number(v, 9); }

std::string xyz(const Vec3& p) { return "X(" + number(p.x()) + "), Y(" + number(p.y()) + "), Z(" + number(p.z()) + ")"; }

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

struct ClientMachine::Impl {
  asio::io_context io;
  tcp::socket socket{io};
  asio::streambuf input;
  std::uint32_t tag = 0;
  std::vector<std::string> transcript;
  std::deque<Command> queue;
  std::map<std::string, DefineTool> definitions;
  std::optional<ToolInfo> tool;
  double positioning_feed = 0, measuring_feed = 0;
  std::size_t executed = 0;

  std::string read_line() {
    asio::read_until(socket, input, '\n');
    std::istream in(&input);
    std::string line;
    std::getline(in, line);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    transcript.push_back("< " + line);
    return line;
  }

  /// Sends one command and reads up to its `%`; an error leaves the server cleared again.
  Answer call(const std::string& command, bool clear_errors = true) {
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
    if (answer.error && clear_errors && answer.error->severity >= 3) call("ClearAllErrors()", false);
    return answer;
  }

  Vec3 position() {
    const Answer a = call("Get(X(), Y(), Z())");
    if (a.data.empty()) return Vec3::Zero();
    return {item(a.data[0], "X").value_or(0), item(a.data[0], "Y").value_or(0), item(a.data[0], "Z").value_or(0)};
  }

  Response fault(std::uint64_t command_tag, const ResponseLine& e) {
    Response r;
    r.tag = command_tag;
    r.status = Response::Status::Fault;
    r.fault = Fault{fault_kind(e.error_number), e.error_text + " (" + e.error_cause + ")", position(), 0};
    return r;
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
              r.fault = Fault{FaultKind::BadCommand, "two-touch and blended cycles are not part of I++ DME PtMeas", Vec3::Zero(), 0};
              return r;
            }
            const double speed = body.speed_mm_s.value_or(measuring_feed);
            if (auto f = check(call("SetProp(Tool.PtMeasPar.Approach(" + number(body.approach_mm) + "), Tool.PtMeasPar.Search(" +
                                    number(body.search_mm) + "), Tool.PtMeasPar.Retract(" + number(body.retract_mm) +
                                    ")" + (speed > 0 ? ", Tool.PtMeasPar.Speed(" + number(speed) + ")" : std::string()) + ")")))
              return *f;
            const Vec3 n = body.normal.normalized();
            const double r_mm = tool ? tool->effective_radius_mm : 0;
            // I++ DME PtMeas takes the ball centre at the nominal contact (docs/ipp-dme.md).
            const Answer a = call("OnPtMeasReport(X(), Y(), Z(), IJK(), ER())");
            if (auto f = check(a)) return *f;
            const Answer m = call("PtMeas(" + xyz(body.nominal_mm + r_mm * n) + ", IJK(" + number(n.x()) + ", " +
                                  number(n.y()) + ", " + number(n.z()) + "))");
            if (auto f = check(m)) return *f;
            if (m.data.empty()) return fault(c.tag, ResponseLine{{}, ResponseLine::Kind::Error, "", 2, 1003, "PtMeas", "No touch"});
            Hit h;
            h.centre_mm = {item(m.data[0], "X").value_or(0), item(m.data[0], "Y").value_or(0), item(m.data[0], "Z").value_or(0)};
            h.normal = n;
            h.ball_radius_mm = item(m.data[0], "ER").value_or(r_mm);
            done.hit = h;
            return done;
          } else if constexpr (std::is_same_v<T, DefineTool>) {
            definitions[body.name] = body;
            ToolInfo info;
            info.name = body.name;
            info.nominal_radius_mm = info.effective_radius_mm = body.ball_diameter_mm / 2;
            done.tool = info;
            return done;
          } else if constexpr (std::is_same_v<T, SelectTool>) {
            if (auto f = check(call("ChangeTool(\"" + body.name + "\")"))) return *f;
            ToolInfo info;
            info.name = body.name;
            if (auto d = definitions.find(body.name); d != definitions.end())
              info.nominal_radius_mm = info.effective_radius_mm = d->second.ball_diameter_mm / 2;
            tool = info;
            done.tool = info;
            // Feeds are per tool on the server: read the new tool's, unless this client set them.
            const Answer feeds = call("GetProp(Tool.GoToPar.Speed(), Tool.PtMeasPar.Speed())");
            if (!feeds.data.empty()) {
              if (!(positioning_feed > 0)) positioning_feed = item(feeds.data[0], "Tool.GoToPar.Speed").value_or(0);
              if (!(measuring_feed > 0)) measuring_feed = item(feeds.data[0], "Tool.PtMeasPar.Speed").value_or(0);
            }
            if (positioning_feed > 0 && measuring_feed > 0)
              call("SetProp(Tool.GoToPar.Speed(" + number(positioning_feed) + "), Tool.PtMeasPar.Speed(" + number(measuring_feed) + "))");
            return done;
          } else if constexpr (std::is_same_v<T, QualifyTool>) {
            if (auto f = check(call("ReQualify()"))) return *f;
            if (tool) tool->qualified = true;
            done.tool = tool;
            return done;
          } else if constexpr (std::is_same_v<T, SetFeeds>) {
            std::string props;
            auto add = [&](const std::string& p) { props += (props.empty() ? "" : ", ") + p; };
            if (body.positioning_mm_s > 0) add("Tool.GoToPar.Speed(" + number(body.positioning_mm_s) + ")"), positioning_feed = body.positioning_mm_s;
            if (body.measuring_mm_s > 0) add("Tool.PtMeasPar.Speed(" + number(body.measuring_mm_s) + ")"), measuring_feed = body.measuring_mm_s;
            if (body.acceleration_mm_s2 > 0)
              add("Tool.GoToPar.Accel(" + number(body.acceleration_mm_s2) + "), Tool.PtMeasPar.Accel(" + number(body.acceleration_mm_s2) + ")");
            if (!props.empty())
              if (auto f = check(call("SetProp(" + props + ")"))) return *f;
            return done;
          } else {
            Response r;
            r.tag = c.tag;
            r.status = Response::Status::Fault;
            r.fault = Fault{FaultKind::BadCommand, "scans are not mapped onto I++ DME by this client", Vec3::Zero(), 0};
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
    out.push_back(m_impl->run(c));
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

}  // namespace metron::machine::ipp
