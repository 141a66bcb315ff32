// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/interpreter/run_limits.hpp"

#include <sys/resource.h>

#include <cerrno>
#include <csignal>
#include <cstring>

#include <fmt/format.h>

namespace metron::interpreter {
namespace {
volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void on_stop_signal(int signal) { g_stop_signal = signal; }
}  // namespace

void request_stop(int signal) noexcept { g_stop_signal = signal == 0 ? -1 : signal; }
int stop_requested() noexcept { return g_stop_signal; }
void clear_stop() noexcept { g_stop_signal = 0; }

void install_stop_signal_handlers() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

std::optional<std::string> apply_memory_limit(std::uint64_t mib) {
#if defined(__SANITIZE_ADDRESS__)
  (void)mib;
  return std::nullopt;  // ASan reserves terabytes of shadow memory: RLIMIT_DATA would stop it at once
#else
  if (mib == 0) return std::nullopt;
  rlimit limit{};
  if (getrlimit(RLIMIT_DATA, &limit) != 0) return fmt::format("cannot read the memory limit: {}", std::strerror(errno));
  rlim_t wanted = static_cast<rlim_t>(mib) * 1024 * 1024;
  if (limit.rlim_max != RLIM_INFINITY && wanted > limit.rlim_max) wanted = limit.rlim_max;  // only root may raise it
  limit.rlim_cur = wanted;
  if (setrlimit(RLIMIT_DATA, &limit) != 0) return fmt::format("cannot set the memory limit: {}", std::strerror(errno));
  return std::nullopt;
#endif
}

StopSignalScope::StopSignalScope() {
  clear_stop();
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;
  sigaction(SIGINT, &action, &m_interrupt);
  sigaction(SIGTERM, &action, &m_terminate);
}

StopSignalScope::~StopSignalScope() {
  sigaction(SIGINT, &m_interrupt, nullptr);
  sigaction(SIGTERM, &m_terminate, nullptr);
  clear_stop();
}

}  // namespace metron::interpreter
