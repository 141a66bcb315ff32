// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Fixtures shared by the tests and benchmarks (metron_test_support): the project's worlds, a
// scratch directory per test process, and a thread CPU clock.
#include <filesystem>
#include <string>

#include "metron/machine/world.hpp"

namespace metron::test_support {

/// The source tree (METRON_SOURCE_DIR): programs/, docs/ ...
std::filesystem::path source_dir();

/// A world of programs/worlds/ by file name; throws std::runtime_error when it does not load.
machine::World world_file(const std::string& name);

/// A fresh directory `<temp>/<prefix>_<pid>/<name>` (created, not emptied): one per test process,
/// so parallel ctest runs do not share outputs.
std::filesystem::path out_dir(const std::string& prefix, const std::string& name);

/// CPU time of the calling thread (s): separates a computation's cost from preemption on a
/// loaded machine.
double thread_cpu_s();

}  // namespace metron::test_support
