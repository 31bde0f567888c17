#include "solid/coupled/server_solid.hpp"

#include <exception>
#include <string>
#include <vector>

#include "common/text/text.hpp"
#include "solid/coupled/solid_checkpoints.hpp"

namespace cosim::solid {

std::optional<protocol::Ending> ServerSolid::checkpoint_if_due(std::int64_t step) {
  return checkpoints_.write_if_due(step);
}

void ServerSolid::keep_start() {
  start_ = run_.model().state();
  start_memory_ = run_.coupler().reaction_memory();
}

std::optional<protocol::Ending> ServerSolid::iterate(const FluidSample& drive, std::int64_t step, int iteration,
                                                     IntervalResult& trial) {
  if (iteration > 0) run_.model().restore(start_);
  const std::string where = "iteration " + std::to_string(iteration) + " of step " + std::to_string(step);
  try {
    run_.coupler().set_reaction_memory(start_memory_);
    trial = run_.coupler().advance(drive, false, true);
  } catch (const std::exception& e) {
    return protocol::Ending{exit_code::unhealthy, "the implicit scheme's " + where + ": " + protocol::one_line(e.what()),
                            true};
  }
  if (trial.overspeed) {
    protocol::Ending e = run_.overspeed(step, *trial.overspeed);
    e.reason += " (the implicit scheme's " + where + ")";
    return e;
  }
  if (const std::string bad = run_.non_finite(trial); !bad.empty())
    return protocol::Ending{exit_code::unhealthy, "non-finite solid state in the implicit scheme's " + where + ": " + bad,
                            true};
  return std::nullopt;
}

void ServerSolid::save_start(protocol::CheckpointWriter& w) const {
  w.put("reaction_memory_velocity_au", start_memory_.velocity.data(), std::size_t(start_memory_.velocity.size()));
  w.put("reaction_memory_force_au", start_memory_.force.data(), std::size_t(start_memory_.force.size()));
}

void ServerSolid::restore_start(const protocol::CheckpointReader& r) {
  const Eigen::Index n = run_.num_cgps();
  const auto size = static_cast<std::size_t>(3 * n);
  start_memory_ = {};
  // An empty memory (the first free step) was written as empty arrays.
  if (r.doubles("reaction_memory_velocity_au").size() == size) {
    start_memory_.velocity =
        Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("reaction_memory_velocity_au", size).data(), 3, n);
    start_memory_.force = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("reaction_memory_force_au", size).data(), 3, n);
  }
}

}  // namespace cosim::solid
