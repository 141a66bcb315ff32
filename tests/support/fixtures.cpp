// SPDX-License-Identifier: GPL-3.0-or-later
#include "fixtures.hpp"

#include "scratch.hpp"

#include <time.h>
#include <unistd.h>

#include <stdexcept>

namespace metron::test_support {

std::filesystem::path source_dir() { return METRON_SOURCE_DIR; }

machine::World world_file(const std::string& name) {
  auto w = machine::load_world((source_dir() / "programs" / "worlds" / name).string());
  if (!w) throw std::runtime_error(w.error().message);
  return *w;
}

std::filesystem::path out_dir(const std::string& prefix, const std::string& name) {
  const std::filesystem::path d = scratch_root(prefix) / name;
  std::filesystem::create_directories(d);
  return d;
}

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace metron::test_support
