// SPDX-License-Identifier: GPL-3.0-or-later
// `metron serve`: the virtual CMM behind an I++ DME server (docs/ipp-dme.md).
#include "serve_command.hpp"

#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "metron/machine/ipp/server.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/machine/world.hpp"

namespace metron::cli {
namespace {

struct ServeArgs {
  std::optional<std::string> world;
  std::optional<std::uint64_t> seed;
  machine::ipp::ServerOptions server;
  double probe_diameter_mm = 2.0;
  std::vector<std::string> tools;  ///< NAME=DIAMETER, offered beside Probe1
};

int serve_cmd(const ServeArgs& args) {
  auto loaded = machine::load_world_or_default(args.world);
  if (!loaded) {
    std::cerr << "error: " << loaded.error().message << "\n";
    return 2;
  }
  machine::World world = std::move(*loaded);
  auto cmm = machine::make_virtual_cmm(world, args.seed.value_or(world.seed));
  machine::ipp::SessionOptions session;
  session.tools = {machine::DefineTool{"Probe1", args.probe_diameter_mm, -Vec3::UnitZ(), 50.0}};
  for (const auto& t : args.tools) {
    // NAME=DIAMETER: a further probe (stylus along -Z, 50 mm), e.g. named as a program's SNSDEF.
    const auto eq = t.find('=');
    double d = 0;
    try {
      if (eq != std::string::npos) d = std::stod(t.substr(eq + 1));
    } catch (const std::exception&) {
      d = 0;
    }
    if (eq == 0 || eq == std::string::npos || !(d > 0) || !std::isfinite(d)) {
      std::cerr << "error: --tool " << t << ": expected NAME=DIAMETER (mm, positive)\n";
      return 2;
    }
    session.tools.push_back(machine::DefineTool{t.substr(0, eq), d, -Vec3::UnitZ(), 50.0});
  }
  session.max_speed_mm_s = world.machine.max_speed_mm_s;
  session.max_acceleration_mm_s2 = world.machine.max_acceleration_mm_s2;
  session.home_mm = world.machine.home_mm;
  machine::ipp::Server server(*cmm, session, args.server);
  try {
    server.listen();
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  // The first line tells scripts and tests the port (--port 0 picks a free one).
  std::cout << "metron serve: I++ DME on " << args.server.host << ":" << server.port() << " (world " << world.name
            << (args.server.realtime ? ", real-time pacing" : ", simulated time") << ")" << std::endl;
  server.run();
  std::cout << "metron serve: stopped" << std::endl;
  return 0;
}

}  // namespace

void add_serve_command(CLI::App& app, std::vector<Command>& commands) {
  auto args = std::make_shared<ServeArgs>();
  auto* sub = app.add_subcommand("serve", "serve the virtual CMM to I++ DME clients over TCP (docs/ipp-dme.md)");
  sub->add_option("--world", args->world, "world description (JSON/YAML); default: the built-in world");
  sub->add_option("--seed", args->seed, "seed of every random draw (default: the world's)");
  sub->add_option("--port", args->server.port, "TCP port (I++ DME: 1294; 0: any free port)")->capture_default_str();
  sub->add_option("--host", args->server.host, "address to listen on")->capture_default_str();
  sub->add_flag("--realtime", args->server.realtime, "pace the answers by the simulated motion time");
  sub->add_option("--log", args->server.log_path, "append every exchange to this file");
  sub->add_flag("--once", args->server.once, "stop when the first client disconnects");
  sub->add_option("--probe-diameter", args->probe_diameter_mm, "ball diameter of the tool Probe1 [mm]")
      ->capture_default_str();
  sub->add_option("--tool", args->tools, "a further probe NAME=DIAMETER [mm] (stylus along -Z), repeatable");
  commands.push_back({sub, [args] { return serve_cmd(*args); }});
}

}  // namespace metron::cli
