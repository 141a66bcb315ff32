// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "metron/machine/ipp/session.hpp"
#include "metron/machine/machine.hpp"

namespace metron::machine::ipp {

/// How `metron serve` listens and paces (docs/ipp-dme.md).
struct ServerOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 1294;           ///< I++ DME's port; 0 picks a free one (see Server::port)
  bool realtime = false;               ///< hold `%` back for the simulated duration of the motion
  std::string log_path;                ///< every exchange, NIST server log style; empty: none
  bool once = false;                   ///< stop after the first session's connection closes
  std::size_t max_line_bytes = 65536;  ///< a longer line is a protocol error and ends the connection
};

/// The I++ DME TCP server: one client and one Session at a time (further clients get an error
/// line and are closed), lines in, response lines out, SIGINT/SIGTERM end it cleanly.
/// Networking on standalone Asio, kept out of this header.
class Server {
 public:
  Server(Machine& machine, SessionOptions session_options, ServerOptions options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// Binds and listens (throws std::runtime_error when the address cannot be bound).
  void listen();
  /// The bound port (after listen()).
  [[nodiscard]] std::uint16_t port() const;
  /// Serves until stop(), a signal (when `handle_signals`), or the end of the first session
  /// with `once`. Blocks the calling thread.
  void run(bool handle_signals = true);
  /// Ends run() from any thread: open connections are closed.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace metron::machine::ipp
