// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/interpreter/run_limits.hpp"

#include <csignal>

namespace metron::interpreter {
namespace {
volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void on_stop_signal(int signal) { g_stop_signal = signal; }
}  // namespace

void request_stop(int signal) noexcept { g_stop_signal = signal == 0 ? -1 : signal; }
int stop_requested() noexcept { return g_stop_signal; }
void clear_stop() noexcept { g_stop_signal = 0; }

void install_stop_signal_handlers() {
  struct sigaction action{};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace metron::interpreter
