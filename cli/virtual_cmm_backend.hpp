// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <optional>
#include <string>

#include <tl/expected.hpp>

#include "metron/interpreter/session.hpp"
#include "metron/machine/compensation/compensated_machine.hpp"
#include "metron/machine/virtual_cmm.hpp"

// The composition root's choice of backend: the virtual CMM of a world file. Header-only so the
// end-to-end tests build the same backend as `metron run`; a real controller would be another
// BackendFactory here.
namespace metron::cli {

/// The virtual CMM for a world file (none: the embedded default) and a seed (none: the world's).
inline tl::expected<interpreter::Backend, std::string> virtual_cmm_backend(const std::optional<std::string>& world_path,
                                                                           std::optional<std::uint64_t> seed) {
  auto cmm = machine::open_virtual_cmm(world_path, seed);
  if (!cmm) return tl::unexpected(cmm.error().message);
  const std::uint64_t run_seed = (*cmm)->seed();
  // The controller's compensation (docs/error-space.md): none until `--compensation` or a
  // program's CALL/EXTERN,SYS,'COMPENSATION file' gives a map; without one it is the identity.
  return interpreter::Backend{std::make_unique<machine::CompensatedMachine>(std::move(*cmm), nullptr),
                              world_path ? *world_path : std::string("<default>"), run_seed};
}

}  // namespace metron::cli
