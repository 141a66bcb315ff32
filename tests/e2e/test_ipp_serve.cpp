// SPDX-License-Identifier: GPL-3.0-or-later
// `metron serve` over a real loopback socket: a client session with GoTo and PtMeas (answers
// checked against the perfect world's hidden truth: the block's top face at z = 40), a second
// client refused cleanly, malformed lines answered without the server dying, a new session after
// the first, SIGTERM ending the server with exit code 0 and a complete exchange log.
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "metron/machine/ipp/command_line.hpp"
#include "metron/machine/ipp/response_line.hpp"
#include "metron/stdlib/geometry/vec.hpp"

using namespace metron::machine::ipp;
using metron::Vec3;
namespace fs = std::filesystem;

namespace {

/// `metron serve` in a child process; the port is read from its first output line.
class ServerProcess {
 public:
  explicit ServerProcess(const std::vector<std::string>& extra) {
    int out[2];
    if (::pipe(out) != 0) throw std::runtime_error("pipe");
    const pid_t parent = ::getpid();
    m_pid = ::fork();
    if (m_pid == 0) {
      // Dies with the test process: a crashed test must not leave a server holding ctest's pipe.
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(126);
      ::dup2(out[1], 1);
      ::close(out[0]);
      std::vector<std::string> args{METRON_BINARY, "serve", "--port", "0"};
      args.insert(args.end(), extra.begin(), extra.end());
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    ::close(out[1]);
    m_out = ::fdopen(out[0], "r");
    char line[512] = {};
    if (!std::fgets(line, sizeof line, m_out)) {
      kill_child();  // the destructor does not run after a throwing constructor
      throw std::runtime_error("metron serve printed nothing");
    }
    const std::string s = line;
    const auto colon = s.rfind(':', s.find(" (world"));
    m_port = static_cast<std::uint16_t>(std::stoi(s.substr(colon + 1)));
  }
  ~ServerProcess() { kill_child(); }
  void kill_child() {
    if (m_pid > 0) {
      ::kill(m_pid, SIGKILL);
      ::waitpid(m_pid, nullptr, 0);
      m_pid = -1;
    }
    if (m_out) std::fclose(m_out);
    m_out = nullptr;
  }
  [[nodiscard]] std::uint16_t port() const { return m_port; }
  /// Sends `signal` and returns the exit status (-1: still running after 10 s).
  int terminate(int signal) {
    ::kill(m_pid, signal);
    for (int i = 0; i < 1000; ++i) {
      int status = 0;
      if (::waitpid(m_pid, &status, WNOHANG) == m_pid) {
        m_pid = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }

 private:
  pid_t m_pid = -1;
  FILE* m_out = nullptr;
  std::uint16_t m_port = 0;
};

/// A blocking line client with a receive timeout.
class Client {
 public:
  explicit Client(std::uint16_t port) {
    m_fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(m_fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("connect");
    timeval tv{10, 0};
    ::setsockopt(m_fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }
  ~Client() { ::close(m_fd); }
  void send_raw(const std::string& bytes) { (void)::send(m_fd, bytes.data(), bytes.size(), MSG_NOSIGNAL); }
  /// One line without CR/LF; empty at EOF or timeout.
  std::string line() {
    for (;;) {
      if (const auto nl = m_buffer.find('\n'); nl != std::string::npos) {
        std::string l = m_buffer.substr(0, nl);
        m_buffer.erase(0, nl + 1);
        if (!l.empty() && l.back() == '\r') l.pop_back();
        return l;
      }
      char chunk[4096];
      const auto n = ::recv(m_fd, chunk, sizeof chunk, 0);
      if (n <= 0) return "";
      m_buffer.append(chunk, static_cast<std::size_t>(n));
    }
  }
  /// Sends a command and collects its answer up to `%` (or a lone E0000 error line).
  std::vector<std::string> exchange(const std::string& command) {
    send_raw(command + "\r\n");
    std::vector<std::string> lines;
    for (;;) {
      const std::string l = line();
      if (l.empty()) break;
      lines.push_back(l);
      if ((l.size() >= 7 && l[6] == '%') || l.rfind("E0000 !", 0) == 0) break;
    }
    return lines;
  }
  /// The server closed the connection (recv returns 0).
  bool closed_by_peer() {
    char c;
    return ::recv(m_fd, &c, 1, 0) == 0;
  }

 private:
  int m_fd = -1;
  std::string m_buffer;
};

double item(const std::string& line, const std::string& name) {
  auto r = parse_response_line(line);
  if (r && r->kind == ResponseLine::Kind::Data)
    if (auto args = parse_arguments(r->body))
      for (const auto& a : *args)
        if (a.is_call(name) && a.call_number()) return *a.call_number();
  ADD_FAILURE() << "no " << name << " in " << line;
  return NAN;
}

}  // namespace

TEST(IppServe, SessionOverLoopback) {
  const fs::path log = metron::test_support::scratch_root("metron_ipp_serve") / "serve.log";
  fs::remove(log);
  ServerProcess server(
      {"--world", std::string(METRON_SOURCE_DIR) + "/programs/worlds/perfect.json", "--log", log.string()});
  {
    Client a(server.port());
    EXPECT_EQ(a.exchange("00001 StartSession()"), (std::vector<std::string>{"00001 &", "00001 %"}));

    // A second client while the first holds the session: one error line, then the server closes it.
    Client b(server.port());
    const std::string refusal = b.line();
    auto parsed = parse_response_line(refusal);
    ASSERT_TRUE(parsed) << refusal;
    EXPECT_EQ(parsed->tag.text(), "E0000");
    EXPECT_EQ(parsed->error_number, 508);
    EXPECT_TRUE(b.closed_by_peer());

    EXPECT_EQ(a.exchange("00002 Home()").back(), "00002 %");
    EXPECT_EQ(a.exchange("00003 ChangeTool(\"Probe1\")").back(), "00003 %");
    EXPECT_EQ(a.exchange("00004 GoTo(X(445), Y(210), Z(60))"), (std::vector<std::string>{"00004 &", "00004 %"}));
    const auto pt = a.exchange("00005 PtMeas(X(445), Y(210), Z(41), IJK(0, 0, 1))");
    ASSERT_EQ(pt.size(), 3u);
    EXPECT_NEAR(item(pt[1], "Z"), 41, 1e-4);  // ball centre on the top face z = 40 (1 mm ball)
    EXPECT_NEAR(item(pt[1], "X"), 445, 1e-4);

    // Malformed input: answered, and the session goes on.
    const auto bad_tag = a.exchange("garbage");
    ASSERT_EQ(bad_tag.size(), 1u);
    EXPECT_EQ(parse_response_line(bad_tag[0])->error_number, 1);
    const auto bad_number = a.exchange("00006 GoTo(X(0.34.33))");
    ASSERT_EQ(bad_number.size(), 3u);
    EXPECT_EQ(parse_response_line(bad_number[1])->error_number, 509);
    EXPECT_EQ(a.exchange("00007 ClearAllErrors()").back(), "00007 %");
    static constexpr char binary_line[] = "00008 Get(X(\x01\xff\x00))";  // a NUL inside the line
    const auto binary = a.exchange(std::string(binary_line, sizeof binary_line - 1));
    EXPECT_EQ(parse_response_line(binary[1])->error_number, 7);
    EXPECT_EQ(a.exchange("00009 ClearAllErrors()").back(), "00009 %");
    const auto get = a.exchange("00010 Get(X(), Y(), Z())");
    ASSERT_EQ(get.size(), 3u);
    EXPECT_NEAR(item(get[1], "Z"), 43, 1e-4);  // retracted by the default 2 mm

    EXPECT_EQ(a.exchange("09999 EndSession()"), (std::vector<std::string>{"09999 &", "09999 %"}));
    EXPECT_TRUE(a.closed_by_peer());
  }
  {
    // The next client gets a new session on the same machine (the position is kept).
    Client c(server.port());
    EXPECT_EQ(c.exchange("00001 StartSession()"), (std::vector<std::string>{"00001 &", "00001 %"}));
    const auto get = c.exchange("00002 Get(Z())");
    ASSERT_EQ(get.size(), 3u);
    EXPECT_NEAR(item(get[1], "Z"), 43, 1e-4);
    // SIGTERM during a session: the server closes the connection and exits 0.
    EXPECT_EQ(server.terminate(SIGTERM), 0);
    EXPECT_TRUE(c.closed_by_peer());
  }
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  EXPECT_NE(s.find("received: 00005 PtMeas(X(445), Y(210), Z(41), IJK(0, 0, 1))"), std::string::npos) << s;
  EXPECT_NE(s.find("sent: 00005 # X(445)"), std::string::npos);
  EXPECT_NE(s.find("refused: 127.0.0.1:"), std::string::npos);
  EXPECT_NE(s.find("signal: 15"), std::string::npos);
  fs::remove(log);
}

TEST(IppServe, OverlongLineEndsOnlyThatConnection) {
  ServerProcess server({});
  {
    Client a(server.port());
    a.send_raw(std::string(100000, 'X'));
    const std::string l = a.line();
    EXPECT_EQ(parse_response_line(l)->error_number, 8) << l;
    EXPECT_TRUE(a.closed_by_peer());
  }
  Client b(server.port());
  EXPECT_EQ(b.exchange("00001 StartSession()"), (std::vector<std::string>{"00001 &", "00001 %"}));
  EXPECT_EQ(server.terminate(SIGINT), 0);
}

// --realtime: the acknowledgement comes at once, the completion after the simulated motion
// time (here at least the 100 mm path at 200 mm/s, 0.5 s); a command sent meanwhile is
// acknowledged at once and answered after the motion, at its end position.
TEST(IppServe, RealtimePacesTheCompletion) {
  ServerProcess server({"--realtime"});
  Client a(server.port());
  for (const char* c : {"00001 StartSession()", "00002 Home()", "00003 SetProp(Tool.GoToPar.Speed(200))"})
    ASSERT_EQ(a.exchange(c).back().substr(6), "%") << c;
  const auto t0 = std::chrono::steady_clock::now();
  a.send_raw("00004 GoTo(X(100), Y(0), Z(500))\r\n");
  EXPECT_EQ(a.line(), "00004 &");
  const double ack_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Commands sent during the motion are acknowledged when they arrive and executed after it, in
  // order.
  a.send_raw("00005 Get(X(), Y(), Z())\r\n00006 IsHomed()\r\n00007 Get(X(), Y(), Z())\r\n");
  EXPECT_EQ(a.line(), "00005 &");
  EXPECT_EQ(a.line(), "00006 &");
  EXPECT_EQ(a.line(), "00007 &");
  const double queued_ack_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(a.line(), "00004 %");
  const double done_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(ack_s, 0.25);
  EXPECT_LT(queued_ack_s, 0.25);
  EXPECT_GE(done_s, 0.5);
  EXPECT_LT(done_s, 5.0);
  const std::string position = a.line();
  EXPECT_NEAR(item(position, "X"), 100, 1e-6);
  EXPECT_EQ(a.line(), "00005 %");
  EXPECT_EQ(a.line(), "00006 # IsHomed(1)");
  EXPECT_EQ(a.line(), "00006 %");
  EXPECT_EQ(a.line().substr(0, 7), "00007 #");
  EXPECT_EQ(a.line(), "00007 %");
  EXPECT_EQ(server.terminate(SIGTERM), 0);
}

// --realtime and AbortE during the motion: AbortE_TestWhileMoving.prg of the NIST suite as its
// client sent it (the AbortE while the GoTo runs), compared line kind by line kind with the NIST
// server's AbortE_TestWhileMoving.res: the GoTo is answered 0006 and completes before the AbortE
// does. The machine must then stand on the GoTo's line where the move was: a stop from the cruise
// at the move's limits ends v*tau from the start (VirtualCmm.AStopRequestCutsAGoToWhereTheMachineWas),
// and the server's tau lies between what the client can see: from its AbortE back to the GoTo's
// acknowledgement, and from the AbortE's completion back to the GoTo's sending.
TEST(IppServe, RealtimeAbortEStopsTheMoveWhereItWas) {
  ServerProcess server({"--realtime"});
  Client a(server.port());
  const auto kinds = [](const std::vector<std::string>& lines) {
    std::vector<std::string> out;
    for (const auto& l : lines)
      if (l.size() >= 7 && l[6] != '#') out.push_back(l.substr(0, 7));
    return out;
  };
  for (const char* c : {"00010 StartSession()", "00020 Home()", "00030 ChangeTool(\"Probe1\")",
                        "00040 SetProp(Tool.GoToPar.Accel(50.0))", "00050 SetProp(Tool.GoToPar.Speed(5.0))",
                        "E0060 OnMoveReportE(Dis(1), X(), Y(), Z())"})
    ASSERT_EQ(a.exchange(c).back().substr(6), "%") << c;
  const auto home_line = a.exchange("00065 Get(X(), Y(), Z())");
  ASSERT_EQ(home_line.size(), 3u);
  const Vec3 home(item(home_line[1], "X"), item(home_line[1], "Y"), item(home_line[1], "Z"));
  const Vec3 target(20, 40, 60);

  using clock = std::chrono::steady_clock;
  const auto sent_goto = clock::now();
  a.send_raw("00070 GoTo(X(20), Y(40), Z(60))\r\n");
  ASSERT_EQ(a.line(), "00070 &");
  const auto acknowledged = clock::now();
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  const auto sent_abort = clock::now();
  a.send_raw("E0090 AbortE()\r\n");
  std::vector<std::string> answer;
  for (std::string l = a.line(); !l.empty(); l = a.line()) {
    answer.push_back(l);
    if (l == "E0090 %") break;
  }
  const auto completed = clock::now();
  EXPECT_EQ(kinds(answer), (std::vector<std::string>{"E0090 &", "00070 !", "00070 %", "E0090 %"}));
  const auto error_line =
      std::find_if(answer.begin(), answer.end(), [](const auto& l) { return l.rfind("00070 !", 0) == 0; });
  ASSERT_NE(error_line, answer.end());
  const auto error = parse_response_line(*error_line);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->error_number, 6);
  EXPECT_EQ(error->error_cause, "00070 GoTo(X(20), Y(40), Z(60))");
  // The daemon (Dis(1)) reported along the move while it ran, as the NIST server did: before the
  // AbortE, at least 1 mm apart (and at most a control cycle's travel more), on the line.
  std::vector<Vec3> reports;
  for (const auto& l : answer) {
    if (l == "E0090 &") break;
    if (l.rfind("E0060 #", 0) == 0) reports.emplace_back(item(l, "X"), item(l, "Y"), item(l, "Z"));
  }
  EXPECT_GE(reports.size(), 4u);

  const auto at = a.exchange("00095 Get(X(), Y(), Z())");
  ASSERT_EQ(at.size(), 3u);
  const Vec3 p(item(at[1], "X"), item(at[1], "Y"), item(at[1], "Z"));
  const Vec3 u = (target - home).normalized();
  const double along = (p - home).dot(u);
  EXPECT_NEAR(((p - home) - along * u).norm(), 0, 1e-3);
  const double seconds = [](auto d) { return std::chrono::duration<double>(d).count(); }(sent_abort - acknowledged);
  const double at_most = std::chrono::duration<double>(completed - sent_goto).count();
  std::cout << "[figures] stopped " << along << " mm along the GoTo (" << along / 5.0 << " s at 5 mm/s); client bounds "
            << seconds << " .. " << at_most << " s\n";
  EXPECT_GE(along, 5.0 * seconds - 1e-3) << "stopped after " << along / 5.0 << " s of the move";
  EXPECT_LE(along, 5.0 * at_most + 1e-3) << "stopped after " << along / 5.0 << " s of the move";
  Vec3 previous = home;
  for (const Vec3& r : reports) {
    EXPECT_NEAR(((r - home) - (r - home).dot(u) * u).norm(), 0, 1e-3);
    EXPECT_GE((r - previous).norm(), 1.0 - 1e-4);
    EXPECT_LE((r - previous).norm(), 1.0 + 5.0 * 0.001 + 1e-4);
    EXPECT_LE((r - home).dot(u), along + 1e-4);
    previous = r;
  }

  // The rest of the NIST file, as its .res answers it.
  std::vector<std::string> rest;
  for (const char* c : {"00100 ClearAllErrors()", "E0110 OnMoveReportE(Dis(1), X(), Y(), Z())", "00120 Home()",
                        "00130 StopAllDaemons()", "09999 EndSession()"})
    for (const auto& l : a.exchange(c)) rest.push_back(l);
  EXPECT_EQ(kinds(rest), (std::vector<std::string>{"00100 &", "00100 %", "E0110 &", "E0110 %", "00120 &", "00120 %",
                                                   "00130 &", "00130 %", "09999 &", "09999 %"}));
  EXPECT_EQ(server.terminate(SIGTERM), 0);
}
