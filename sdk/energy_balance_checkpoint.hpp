// The energy balance's state (sdk/energy_balance.hpp) in a library solid's checkpoint:
// the watch, the end positions and the step not yet checked, in lattice units, so that a
// restart continues the balance (and solid.h5's fluid_work_J) bit for bit. IO only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>

#include "common/run/checkpoint_file.hpp"
#include "sdk/energy_balance.hpp"
#include "solid/watchdog/energy_watch_checkpoint.hpp"

namespace cosim::sdk {

inline void save_balance(protocol::CheckpointWriter& w, const EnergyBalance::Saved& s) {
  protocol::save_energy_watch(w, s.watch, "balance_", "_lb");
  w.put("balance_end_lb", s.end.data(), static_cast<std::size_t>(s.end.size()));
  w.attr("balance_pending", static_cast<std::int64_t>(s.pending ? 1 : 0));
  if (!s.pending) return;
  w.attr("balance_pending_step", s.pending->step);
  w.attr("balance_pending_energy_lb", s.pending->energy);
  w.put("balance_pending_x_lb", s.pending->x.data(), static_cast<std::size_t>(s.pending->x.size()));
  w.put("balance_pending_j_lb", s.pending->j.data(), static_cast<std::size_t>(s.pending->j.size()));
}

/// What save_balance() wrote for `markers` markers, or none (a checkpoint of a solid that
/// reports no energy, or an older library's). @throws std::runtime_error for arrays of
/// another marker count
inline std::optional<EnergyBalance::Saved> read_balance(const protocol::CheckpointReader& r, Eigen::Index markers) {
  const auto watch = protocol::read_energy_watch(r, "balance_", "_lb");
  if (!watch) return std::nullopt;
  const auto n = static_cast<std::size_t>(3 * markers);
  const auto matrix = [&](const char* name) {
    return Eigen::Matrix3Xd(Eigen::Map<const Eigen::Matrix3Xd>(r.doubles(name, n).data(), 3, markers));
  };
  EnergyBalance::Saved s{*watch, matrix("balance_end_lb"), std::nullopt};
  if (r.int64_attr("balance_pending") != 0)
    s.pending = EnergyBalance::Step{r.int64_attr("balance_pending_step"), matrix("balance_pending_x_lb"),
                                    matrix("balance_pending_j_lb"), r.double_attr("balance_pending_energy_lb")};
  return s;
}

}  // namespace cosim::sdk
