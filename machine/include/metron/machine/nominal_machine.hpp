// SPDX-License-Identifier: GPL-3.0-or-later
// A dry-run backend: a machine whose part is wherever a program probes it. Every touch lands on
// its nominal point and every scan follows its nominal path, as a CMM package's offline mode
// takes hits at the nominals. It runs a program whose part the world does not hold (a shop
// program written for another part, another machine's coordinates) to its end, so that its
// logic, alignments, constructions and outputs can be followed (`metron run --machine nominal`,
// docs/language.md "Dry runs"). It measures nothing: every actual equals its nominal.
#pragma once
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "metron/machine/machine.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine {

class NominalMachine final : public Machine {
 public:
  /// The world gives the probe library, the default feeds and the control cycle; its part, its
  /// errors and its travel are not used (no collision, no axis limit, no noise).
  explicit NominalMachine(const MachineConfig& config);

  void submit(Command command) override;
  std::vector<Response> execute() override;
  [[nodiscard]] MachineState state() const override;
  [[nodiscard]] std::vector<Command> queued() const override;

 private:
  Response run(const Command& command);
  /// Straight move at `feed_mm_s`: the clock advances by the distance over the feed.
  void move_to(const Vec3& target_mm, double feed_mm_s);
  [[nodiscard]] const ToolInfo* active_tool() const;

  MachineConfig m_config;
  std::deque<Command> m_queue;
  std::map<std::string, ToolInfo> m_tools;
  std::string m_active;
  Vec3 m_position = Vec3::Zero();
  double m_time_s = 0;
  double m_positioning_feed;
  double m_measuring_feed;
  std::optional<Hit> m_last_hit;
  std::size_t m_executed = 0;
};

}  // namespace metron::machine
