// SPDX-License-Identifier: GPL-3.0-or-later
// The I++ DME server on standalone Asio: one io_context thread; the acceptor stays open so that
// a second client can be told why it is refused; the connection reads CR/LF lines, hands them to
// the Session and writes the answers, optionally paced by the simulated motion time.
#include "metron/machine/ipp/server.hpp"

#include <chrono>
#include <csignal>
#include <ctime>
#include <deque>
#include <fstream>
#include <mutex>
#include <optional>
#include <stdexcept>

#include <asio.hpp>

#include "metron/machine/ipp/command_line.hpp"
#include "metron/machine/ipp/error_code.hpp"
#include "metron/machine/ipp/response_line.hpp"

namespace metron::machine::ipp {
namespace {

using asio::ip::tcp;

/// The exchange log, one line per event: `2026-11-24_23:59:01.123 received: 00001 StartSession()`
/// (the NIST suite's server logs: time, direction, the line as on the wire).
class ExchangeLog {
 public:
  explicit ExchangeLog(const std::string& path) {
    if (!path.empty()) {
      m_out.open(path, std::ios::app);
      if (!m_out) throw std::runtime_error("cannot open the log file " + path);
    }
  }
  void write(std::string_view what, std::string_view line) {
    if (!m_out.is_open()) return;
    const auto now = std::chrono::system_clock::now();
    const std::time_t t = std::chrono::system_clock::to_time_t(now);
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
    std::tm utc{};
    gmtime_r(&t, &utc);
    char stamp[40];
    std::strftime(stamp, sizeof stamp, "%Y-%m-%d_%H:%M:%S", &utc);
    char millis[8];
    std::snprintf(millis, sizeof millis, ".%03d", static_cast<int>(ms));
    m_out << stamp << millis << ' ' << what << ": " << line << '\n';
    m_out.flush();
  }

 private:
  std::ofstream m_out;
};

struct Connection;

/// Everything the connections share (Server::Impl is this; a namespace-scope type so that
/// Connection can name it).
struct ServerCore {
  Machine& machine;
  SessionOptions session_options;
  ServerOptions options;
  asio::io_context io;
  tcp::acceptor acceptor{io};
  asio::signal_set signals{io};
  ExchangeLog log;
  bool busy = false;  ///< a client holds the session
  std::shared_ptr<Connection> active;

  ServerCore(Machine& m, SessionOptions s, ServerOptions o)
      : machine(m), session_options(std::move(s)), options(std::move(o)), log(options.log_path) {}

  void accept();
  void refuse(std::shared_ptr<tcp::socket> socket);
  void shutdown() {
    asio::error_code ignored;
    acceptor.close(ignored);
    signals.cancel(ignored);
    if (active) active_close();
    io.stop();
  }
  void active_close();
};

/// One client connection with its session. Lines are handled in order; in real time the lines
/// of an answer after its acknowledgement are held back for the simulated motion time, and
/// meanwhile the connection keeps reading: an E-command (AbortE) is handled at once, other
/// commands wait for the answer to complete.
struct Connection : std::enable_shared_from_this<Connection> {
  static constexpr std::size_t k_max_waiting = 1024;  ///< commands queued behind a paced answer

  ServerCore& server;
  tcp::socket socket;
  asio::streambuf input;
  asio::steady_timer pacing;
  Session session;
  std::string peer;
  std::deque<std::string> outbox;                    ///< lines to write, in order
  std::deque<std::pair<double, std::string>> paced;  ///< the current answer's lines held back, with their due time
  /// A command received while an answer is paced: acknowledged at once when its tag is readable
  /// (`&` says the server has it queued), executed after the answer.
  struct Waiting {
    std::string line;
    std::optional<Tag> acknowledged;
  };
  std::deque<Waiting> waiting;
  std::chrono::steady_clock::time_point acknowledged_at;  ///< when the paced command was acknowledged
  std::uint64_t pace_id = 0;                              ///< which pacing a timer belongs to
  bool pacing_now = false;
  bool draining = false;  ///< answered() is running the waiting commands
  bool reading = false;
  bool writing = false;
  bool input_closed = false;  ///< the client closed its side: finish, then close
  bool closed = false;

  Connection(ServerCore& s, tcp::socket sock)
      : server(s),
        socket(std::move(sock)),
        input(s.options.max_line_bytes),
        pacing(s.io),
        session(s.machine, s.session_options) {
    asio::error_code ec;
    const auto ep = socket.remote_endpoint(ec);
    peer = ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
  }

  void start() {
    server.log.write("connected", peer);
    maybe_read();
  }

  // Reads while an answer is paced (to see an AbortE), otherwise only once everything is
  // written: a client that does not read its answers stops being read.
  void maybe_read() {
    if (reading || closed || input_closed || session.ended()) return;
    if (pacing_now ? waiting.size() >= k_max_waiting : (writing || !outbox.empty() || !waiting.empty())) return;
    reading = true;
    auto self = shared_from_this();
    asio::async_read_until(socket, input, '\n', [self](const asio::error_code& ec, std::size_t n) {
      self->reading = false;
      if (self->closed) return;
      if (ec) {
        if (ec == asio::error::not_found) {  // longer than max_line_bytes
          const std::string line = format_error(Tag{true, 0}, ErrorCode::ProtocolError, "line too long");
          self->server.log.write("sent", line);
          asio::error_code ignored;
          asio::write(self->socket, asio::buffer(line + "\r\n"), ignored);
        }
        if (ec == asio::error::eof) {
          self->input_closed = true;
          self->maybe_close();
        } else {
          self->close("closed: " + ec.message());
        }
        return;
      }
      std::string line(asio::buffers_begin(self->input.data()),
                       asio::buffers_begin(self->input.data()) + static_cast<std::ptrdiff_t>(n));
      self->input.consume(n);
      while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.pop_back();
      if (!line.empty()) {  // a blank line is no command: nothing to answer
        self->server.log.write("received", line);
        self->received(std::move(line));
      }
      self->maybe_read();
    });
  }

  // `&` says the server has the command: it goes out before the command runs (a long scan
  // computes for a while), and before a paced answer completes.
  // Only the tag is read here; the session parses the line once, when it runs it.
  std::optional<Tag> acknowledge(const std::string& line) {
    const std::optional<Tag> tag = read_tag(line);
    if (tag) send(format_ack(*tag));
    return tag;
  }

  void received(std::string line) {
    if (!pacing_now) {  // the motion starts with the acknowledgement, not after the computing
      const auto started = std::chrono::steady_clock::now();
      const auto tag = acknowledge(line);
      return handle(line, tag, started);
    }
    if (line.front() != 'E') {
      const auto tag = acknowledge(line);
      waiting.push_back({std::move(line), tag});
      return;
    }
    const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - acknowledged_at).count();
    SessionReply reply = session.interrupt(line, elapsed_s);
    if (reply.interrupted) {  // the paced answer is replaced
      pacing_now = false;
      ++pace_id;
      pacing.cancel();
      paced.clear();
    }
    for (auto& l : reply.lines) send(std::move(l));
    if (!pacing_now) answered();
  }

  /// Runs a command whose motion starts at `started` (its `&` already sent when `acknowledged`).
  void handle(const std::string& line, std::optional<Tag> acknowledged,
              std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now()) {
    SessionReply reply = session.handle(line);
    if (acknowledged && !reply.lines.empty() && reply.lines.front() == format_ack(*acknowledged)) {
      reply.lines.erase(reply.lines.begin());
      if (!reply.due_s.empty()) reply.due_s.erase(reply.due_s.begin());
    }
    if (server.options.realtime && reply.motion_s > 0 && !reply.lines.empty()) {
      acknowledged_at = started;
      pace(std::move(reply));  // a `&` still in it is due at once
      return;
    }
    for (auto& l : reply.lines) send(std::move(l));
    answered();
  }

  // Holds the reply's lines until they are due (the motion started at `acknowledged_at`).
  void pace(SessionReply reply) {
    paced.clear();
    for (std::size_t i = 0; i < reply.lines.size(); ++i)
      paced.emplace_back(i < reply.due_s.size() ? reply.due_s[i] : reply.motion_s, std::move(reply.lines[i]));
    pacing_now = true;
    ++pace_id;
    release_due();
  }

  // Sends the paced lines that are due (in order) and waits for the next; the last ends the pacing.
  void release_due() {
    const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - acknowledged_at).count();
    while (!paced.empty() && paced.front().first <= elapsed_s) {
      send(std::move(paced.front().second));
      paced.pop_front();
    }
    if (paced.empty()) {
      pacing_now = false;
      answered();
      maybe_read();
      return;
    }
    pacing.expires_at(acknowledged_at + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                            std::chrono::duration<double>(paced.front().first)));
    auto self = shared_from_this();
    const std::uint64_t id = pace_id;
    pacing.async_wait([self, id](const asio::error_code& ec) {
      if (ec || self->closed || id != self->pace_id || !self->pacing_now) return;
      self->release_due();
    });
  }

  // A command's answer is complete: the commands that waited for it follow.
  void answered() {
    if (session.ended()) {
      waiting.clear();
      maybe_close();
      return;
    }
    if (draining) return;  // the loop below goes on (no recursion per waiting command)
    draining = true;
    while (!pacing_now && !waiting.empty() && !closed) {
      Waiting next = std::move(waiting.front());
      waiting.pop_front();
      handle(next.line, next.acknowledged);
    }
    draining = false;
    maybe_close();
  }

  void send(std::string line) {
    server.log.write("sent", line);
    outbox.push_back(std::move(line) + "\r\n");
    if (!writing) write_front();
  }

  void write_front() {
    if (closed) return;
    if (outbox.empty()) {
      writing = false;
      maybe_close();
      maybe_read();
      return;
    }
    writing = true;
    auto self = shared_from_this();
    asio::async_write(socket, asio::buffer(outbox.front()), [self](const asio::error_code& ec, std::size_t) {
      if (self->closed) return;
      if (ec) return self->close("write failed: " + ec.message());
      self->outbox.pop_front();
      self->write_front();
    });
  }

  // Closes once the session ended (or the client stopped sending) and every answer is written.
  void maybe_close() {
    if (closed || writing || !outbox.empty() || pacing_now) return;
    if (session.ended())
      close("session ended");
    else if (input_closed && waiting.empty())
      close("disconnected");
  }

  void close(const std::string& why) {
    if (closed) return;
    closed = true;
    asio::error_code ignored;
    pacing.cancel();
    socket.shutdown(tcp::socket::shutdown_both, ignored);
    socket.close(ignored);
    server.log.write(why, peer);
    server.busy = false;
    if (server.active.get() == this) server.active.reset();
    if (server.options.once) server.shutdown();
  }
};

void ServerCore::active_close() {
  auto keep = active;  // close() resets `active`
  keep->close("server shutdown");
}

void ServerCore::refuse(std::shared_ptr<tcp::socket> socket) {
  // The protocol serves one client: the newcomer learns why and is closed.
  auto line = std::make_shared<std::string>(
      format_error(Tag{true, 0}, ErrorCode::BadContext, "another client holds the session; one client at a time") +
      "\r\n");
  asio::error_code ec;
  const auto ep = socket->remote_endpoint(ec);
  log.write("refused", ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port()));
  asio::async_write(*socket, asio::buffer(*line), [socket, line](const asio::error_code&, std::size_t) {
    asio::error_code ignored;
    socket->shutdown(tcp::socket::shutdown_both, ignored);
    socket->close(ignored);
  });
}

void ServerCore::accept() {
  acceptor.async_accept([this](const asio::error_code& ec, tcp::socket socket) {
    if (ec) {
      if (ec != asio::error::operation_aborted && acceptor.is_open()) accept();
      return;
    }
    if (busy) {
      refuse(std::make_shared<tcp::socket>(std::move(socket)));
    } else {
      busy = true;
      asio::error_code ignored;
      socket.set_option(tcp::no_delay(true), ignored);  // one short line per answer: no Nagle wait
      active = std::make_shared<Connection>(*this, std::move(socket));
      active->start();
    }
    accept();
  });
}

}  // namespace

struct Server::Impl : ServerCore {
  using ServerCore::ServerCore;
};

Server::Server(Machine& machine, SessionOptions session_options, ServerOptions options)
    : m_impl(std::make_unique<Impl>(machine, std::move(session_options), std::move(options))) {}

Server::~Server() = default;

void Server::listen() {
  asio::error_code ec;
  const auto address = asio::ip::make_address(m_impl->options.host, ec);
  if (ec) throw std::runtime_error("bad host address '" + m_impl->options.host + "': " + ec.message());
  const tcp::endpoint endpoint(address, m_impl->options.port);
  auto& a = m_impl->acceptor;
  a.open(endpoint.protocol(), ec);
  if (!ec) a.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) a.bind(endpoint, ec);
  if (!ec) a.listen(asio::socket_base::max_listen_connections, ec);
  if (ec)
    throw std::runtime_error("cannot listen on " + m_impl->options.host + ":" + std::to_string(m_impl->options.port) +
                             ": " + ec.message());
  m_impl->log.write("listening", m_impl->options.host + ":" + std::to_string(port()));
}

std::uint16_t Server::port() const {
  asio::error_code ec;
  const auto ep = m_impl->acceptor.local_endpoint(ec);
  return ec ? 0 : ep.port();
}

void Server::run(bool handle_signals) {
  if (handle_signals) {
    m_impl->signals.add(SIGINT);
    m_impl->signals.add(SIGTERM);
    m_impl->signals.async_wait([this](const asio::error_code& ec, int signal) {
      if (ec) return;
      m_impl->log.write("signal", std::to_string(signal));
      m_impl->shutdown();
    });
  }
  m_impl->accept();
  m_impl->io.run();
  m_impl->log.write("stopped", m_impl->options.host);
}

void Server::stop() {
  asio::post(m_impl->io, [this] { m_impl->shutdown(); });
}

}  // namespace metron::machine::ipp
