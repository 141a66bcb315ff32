// SPDX-License-Identifier: GPL-3.0-or-later
// I++ DME round trips over loopback (docs/ipp-dme.md): the server (machine/src/ipp/server.cpp)
// runs in-process on its own thread with the perfect world's virtual CMM in simulated time; a
// blocking client sends one command and waits for its `%`. Wall-clock time per round trip:
// commands per second, median and p99 latency, for Get (protocol and session cost only), GoTo
// (plus a simulated 20 mm move) and PtMeas (plus a touch cycle).
#include <benchmark/benchmark.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "metron/machine/ipp/server.hpp"
#include "metron/machine/virtual_cmm.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

struct Loopback {
  World world;
  std::unique_ptr<Machine> cmm;
  std::unique_ptr<ipp::Server> server;
  std::thread thread;
  int fd = -1;
  std::string buffer;
  int tag = 0;
  int errors = 0;  ///< error lines received (a benchmark of failing commands would be meaningless)

  Loopback() {
    auto w = load_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/perfect.json");
    if (!w) throw std::runtime_error(w.error().message);
    world = *w;
    cmm = make_virtual_cmm(world, 1);
    ipp::SessionOptions so;
    so.home_mm = world.machine.home_mm;
    ipp::ServerOptions o;
    o.port = 0;
    server = std::make_unique<ipp::Server>(*cmm, so, o);
    server->listen();
    thread = std::thread([this] { server->run(false); });
    fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(server->port());
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("connect");
    int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    for (const char* c : {"StartSession()", "Home()", "ChangeTool(\"Probe1\")", "GoTo(X(445), Y(210), Z(60))"}) call(c);
  }
  ~Loopback() {
    ::close(fd);
    server->stop();
    thread.join();
  }
  /// One round trip: the command out, lines in up to its `%`.
  void call(const std::string& command) {
    tag = tag % 99999 + 1;  // tags 00001..99999, then around again
    char t[16];
    std::snprintf(t, sizeof t, "%05d", tag);
    const std::string line = std::string(t) + " " + command + "\r\n";
    if (::send(fd, line.data(), line.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(line.size()))
      throw std::runtime_error("send");
    for (;;) {
      const auto nl = buffer.find('\n');
      if (nl != std::string::npos) {
        const bool done = nl >= 7 && buffer.compare(0, 5, t) == 0 && buffer[6] == '%';
        if (nl >= 7 && buffer[6] == '!') ++errors;
        buffer.erase(0, nl + 1);
        if (done) return;
        continue;
      }
      char chunk[4096];
      const auto n = ::recv(fd, chunk, sizeof chunk, 0);
      if (n <= 0) throw std::runtime_error("connection closed");
      buffer.append(chunk, static_cast<std::size_t>(n));
    }
  }
};

void round_trips(benchmark::State& state, const std::vector<std::string>& cycle) {
  Loopback lb;
  std::vector<double> latency_us;
  std::size_t k = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    lb.call(cycle[k++ % cycle.size()]);
    latency_us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(latency_us.begin(), latency_us.end());
  state.SetItemsProcessed(static_cast<std::int64_t>(latency_us.size()));
  state.counters["median_us"] = latency_us[latency_us.size() / 2];
  state.counters["p99_us"] = latency_us[std::min(latency_us.size() - 1, latency_us.size() * 99 / 100)];
  state.counters["errors"] = lb.errors;
  state.counters["sim_time_s"] = lb.cmm->state().time_s;
}

void BM_IppGet(benchmark::State& state) { round_trips(state, {"Get(X(), Y(), Z())"}); }
// A 20 mm positioning move back and forth above the block.
void BM_IppGoTo(benchmark::State& state) {
  round_trips(state, {"GoTo(X(425), Y(210), Z(60))", "GoTo(X(445), Y(210), Z(60))"});
}
// A touch on the top face (z = 40; X, Y, Z are the ball centre) with the default 2 mm approach.
void BM_IppPtMeas(benchmark::State& state) { round_trips(state, {"PtMeas(X(445), Y(210), Z(41), IJK(0, 0, 1))"}); }

}  // namespace

BENCHMARK(BM_IppGet)->Unit(benchmark::kMicrosecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_IppGoTo)->Unit(benchmark::kMicrosecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_IppPtMeas)->Unit(benchmark::kMicrosecond)->MinTime(2.0)->UseRealTime();

BENCHMARK_MAIN();
