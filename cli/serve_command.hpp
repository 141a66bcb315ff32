// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <vector>

#include "commands.hpp"

namespace metron::cli {

/// serve (serve_command.cpp): the I++ DME server on the virtual CMM (docs/ipp-dme.md).
void add_serve_command(CLI::App& app, std::vector<Command>& commands);

}  // namespace metron::cli
