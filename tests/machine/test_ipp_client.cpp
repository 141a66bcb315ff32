// SPDX-License-Identifier: GPL-3.0-or-later
// The I++ DME client backend round trip: the same machine commands on a virtual CMM directly and
// through ClientMachine -> loopback TCP -> Server -> Session -> an identical virtual CMM (same
// world, same seed) give the same hits, to the protocol's 6 decimals.
#include <gtest/gtest.h>

#include <thread>

#include "metron/machine/ipp/client_machine.hpp"
#include "metron/machine/ipp/server.hpp"
#include "metron/machine/virtual_cmm.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

using Body = decltype(Command::body);

PtMeas pt(const Vec3& nominal, const Vec3& normal) {
  PtMeas m;
  m.nominal_mm = nominal;
  m.normal = normal;
  return m;
}

std::vector<Response> run(Machine& m, std::vector<Body> bodies) {
  std::uint64_t tag = 0;
  for (auto& b : bodies) m.submit({++tag, std::move(b)});
  return m.execute();
}

/// `metron serve` of the default world on a loopback port, in a thread of its own.
class LoopbackServer {
 public:
  LoopbackServer() : m_served(machine::default_world(), 1), m_server(m_served, session_options(), server_options()) {
    m_server.listen();
    m_thread = std::thread([this] { m_server.run(false); });
  }
  ~LoopbackServer() { stop(); }
  [[nodiscard]] std::uint16_t port() const { return m_server.port(); }
  void stop() {
    if (!m_thread.joinable()) return;
    m_server.stop();
    m_thread.join();
  }

 private:
  static ipp::SessionOptions session_options() {
    ipp::SessionOptions so;
    so.home_mm = machine::default_world().machine.home_mm;
    return so;
  }
  static ipp::ServerOptions server_options() {
    ipp::ServerOptions o;
    o.port = 0;
    return o;
  }
  VirtualCmm m_served;
  ipp::Server m_server;
  std::thread m_thread;
};

}  // namespace

TEST(IppClient, ParsesUrls) {
  EXPECT_EQ(ipp::parse_ipp_url("ipp://127.0.0.1:4000"), std::make_pair(std::string("127.0.0.1"), std::uint16_t{4000}));
  EXPECT_EQ(ipp::parse_ipp_url("ipp://cmm.local"), std::make_pair(std::string("cmm.local"), std::uint16_t{1294}));
  EXPECT_FALSE(ipp::parse_ipp_url("http://x:1"));
  EXPECT_FALSE(ipp::parse_ipp_url("ipp://x:notaport"));
  EXPECT_FALSE(ipp::parse_ipp_url("ipp://:12"));
}

TEST(IppClient, SameHitsDirectAndThroughTheServer) {
  const World world = machine::default_world();  // with pre-travel, delays and noise
  VirtualCmm served(world, 7);
  ipp::SessionOptions so;
  so.home_mm = world.machine.home_mm;
  so.max_acceleration_mm_s2 = world.machine.max_acceleration_mm_s2;
  so.max_speed_mm_s = world.machine.max_speed_mm_s;
  ipp::ServerOptions o;
  o.port = 0;
  ipp::Server server(served, so, o);
  server.listen();
  std::thread thread([&] { server.run(false); });

  // The block's top (z = 40), right face (x = 460) and bore BORE1 (centre (340, 250), d 20).
  const std::vector<Body> program{
      DefineTool{"Probe1", 2.0, -Vec3::UnitZ(), 50.0},
      SelectTool{"Probe1"},
      GoTo{Vec3(445, 210, 60), std::nullopt},
      pt(Vec3(445, 210, 40), Vec3::UnitZ()),
      [] {
        PtMeas m = pt(Vec3(430, 215, 40), Vec3::UnitZ());
        m.approach_mm = 3;
        m.speed_mm_s = 5;  // once at 5 mm/s; the next touches are at the default feed again
        return m;
      }(),
      GoTo{Vec3(470, 250, 60), std::nullopt},
      pt(Vec3(460, 250, 20), Vec3::UnitX()),
      GoTo{Vec3(470, 250, 60), std::nullopt},
      GoTo{Vec3(340, 250, 60), 80.0},
      GoTo{Vec3(340, 250, 30), std::nullopt},
      pt(Vec3(350, 250, 30), -Vec3::UnitX()),
      pt(Vec3(340, 260, 30), -Vec3::UnitY()),
  };
  std::vector<Response> via;
  {
    ipp::ClientMachine client("127.0.0.1", server.port());
    via = run(client, program);
    EXPECT_EQ(client.state().active_tool, "Probe1");
  }
  server.stop();
  thread.join();

  VirtualCmm direct(world, 7);
  direct.submit({100, GoTo{world.machine.home_mm, std::nullopt}});  // the server's Home()
  ASSERT_EQ(direct.execute().front().status, Response::Status::Done);
  const auto expected = run(direct, program);
  ASSERT_EQ(via.size(), expected.size());
  int hits = 0;
  for (std::size_t k = 0; k < via.size(); ++k) {
    ASSERT_EQ(via[k].status, expected[k].status) << k << ": " << (via[k].fault ? via[k].fault->message : "") << " / "
                                                 << (expected[k].fault ? expected[k].fault->message : "");
    ASSERT_EQ(via[k].hit.has_value(), expected[k].hit.has_value()) << k;
    if (!via[k].hit) continue;
    ++hits;
    EXPECT_NEAR((via[k].hit->centre_mm - expected[k].hit->centre_mm).norm(), 0, 1e-6) << k;
    EXPECT_NEAR(via[k].hit->ball_radius_mm, expected[k].hit->ball_radius_mm, 1e-9);
  }
  EXPECT_EQ(hits, 5);
  // And both are where the world's block is (the ball centre 1 mm off the top face, the
  // latch a little past it: pre-travel and delay).
  EXPECT_NEAR(via[3].hit->centre_mm.z(), 41, 0.05);
}

TEST(IppClient, FaultsComeBackAsMachineFaults) {
  LoopbackServer server;
  {
    ipp::ClientMachine client("127.0.0.1", server.port());
    const auto r =
        run(client, {SelectTool{"Probe1"}, GoTo{Vec3(5000, 0, 0), std::nullopt}, GoTo{Vec3(0, 0, 400), std::nullopt}});
    ASSERT_EQ(r.size(), 3u);
    EXPECT_EQ(r[0].status, Response::Status::Done);
    ASSERT_TRUE(r[1].fault);
    EXPECT_EQ(r[1].fault->kind, FaultKind::AxisLimit);
    EXPECT_EQ(r[2].fault->kind, FaultKind::Aborted);
    // The client cleared the server's error state: the next command runs.
    const auto next = run(client, {pt(Vec3(445, 150, 40), Vec3::UnitZ())});  // nothing there
    ASSERT_TRUE(next[0].fault);
    EXPECT_EQ(next[0].fault->kind, FaultKind::NoContact);
    const auto unknown = run(client, {SelectTool{"T9"}});
    EXPECT_EQ(unknown[0].fault->kind, FaultKind::UnknownTool);
  }
}

// A server that goes away mid-program: the next command is a communication fault naming the
// lost link, not a crash and not a "bad command".
TEST(IppClient, ALostServerIsACommunicationFault) {
  LoopbackServer server;
  ipp::ClientMachine client("127.0.0.1", server.port());
  EXPECT_EQ(run(client, {GoTo{Vec3(100, 100, 400), std::nullopt}})[0].status, Response::Status::Done);
  server.stop();
  const auto r = run(client, {GoTo{Vec3(120, 100, 400), std::nullopt}, GoTo{Vec3(140, 100, 400), std::nullopt}});
  ASSERT_EQ(r.size(), 2u);
  ASSERT_TRUE(r[0].fault);
  EXPECT_EQ(r[0].fault->kind, FaultKind::Communication) << r[0].fault->message;
  EXPECT_STREQ(to_string(r[0].fault->kind), "communication");
  ASSERT_TRUE(r[1].fault);
  EXPECT_EQ(r[1].fault->kind, FaultKind::Aborted);
}

// An unknown-contour scan goes to the server as its I++ command (ScanInPlaneEndIsSphere) and
// comes back as the same samples the virtual CMM gives directly: BORE1 followed round.
TEST(IppClient, AnUnknownContourScanThroughTheServerEqualsTheDirectOne) {
  LoopbackServer server;
  ContourScan c;
  c.start_mm = Vec3(349, 250, 30);
  c.start_normal = -Vec3::UnitX();
  c.direction = Vec3::UnitY();
  c.section = {ContourSection::Kind::Plane, c.start_mm, Vec3::UnitZ()};
  c.end = {ContourEnd::Kind::Sphere, c.start_mm, Vec3::UnitZ(), 1.0, 1};
  c.sample_spacing_mm = 0.5;
  c.speed_mm_s = 10;
  const std::vector<Body> program{SelectTool{"Probe1"}, GoTo{Vec3(340, 250, 60), std::nullopt},
                                  GoTo{Vec3(340, 250, 30), std::nullopt}, c};
  std::vector<Response> via;
  {
    ipp::ClientMachine client("127.0.0.1", server.port());
    via = run(client, program);
  }
  server.stop();
  VirtualCmm direct(machine::default_world(), 1);
  run(direct,
      {DefineTool{"Probe1", 2.0, -Vec3::UnitZ(), 50.0}, GoTo{machine::default_world().machine.home_mm, std::nullopt}});
  const auto expected = run(direct, program);
  ASSERT_EQ(via.size(), 4u);
  ASSERT_EQ(via[3].status, Response::Status::Done) << via[3].fault->message;
  ASSERT_EQ(expected[3].status, Response::Status::Done) << expected[3].fault->message;
  const auto& a = via[3].scan;
  const auto& b = expected[3].scan;
  ASSERT_GT(a.size(), 100u);
  EXPECT_NEAR(static_cast<double>(a.size()), static_cast<double>(b.size()), 2);
  for (std::size_t k = 0; k < std::min(a.size(), b.size()); k += 10)
    EXPECT_NEAR((a[k].centre_mm - b[k].centre_mm).norm(), 0, 0.01) << k;
  for (const auto& s : a) EXPECT_NEAR(std::hypot(s.centre_mm.x() - 340, s.centre_mm.y() - 250), 9, 0.02);
}
