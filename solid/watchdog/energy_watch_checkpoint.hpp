// The energy watch's state in a checkpoint file (common/run/checkpoint_file.hpp): the
// solid server's (energies in J) and the solid library's energy balance (lattice units)
// keep it under their own names, so that a restart continues the watch bit for bit.
// IO only.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "common/run/checkpoint_file.hpp"
#include "solid/watchdog/energy_watch.hpp"

namespace cosim::protocol {

/// Attributes PREFIXenergy_started, PREFIXenergy0UNIT, PREFIXworkUNIT, PREFIXwork_absUNIT,
/// PREFIXenergy_maxUNIT (e.g. "watchdog_", "_J": watchdog_energy0_J).
inline void save_energy_watch(CheckpointWriter& w, const EnergyWatch::State& s, const std::string& prefix,
                              const std::string& unit) {
  w.attr(prefix + "energy_started", static_cast<std::int64_t>(s.started ? 1 : 0));
  w.attr(prefix + "energy0" + unit, s.energy0);
  w.attr(prefix + "work" + unit, s.work);
  w.attr(prefix + "work_abs" + unit, s.work_abs);
  w.attr(prefix + "energy_max" + unit, s.energy_max);
}

/// The state save_energy_watch() wrote, or none in a checkpoint without it (an older one).
inline std::optional<EnergyWatch::State> read_energy_watch(const CheckpointReader& r, const std::string& prefix,
                                                           const std::string& unit) {
  if (!r.has(prefix + "energy_started")) return std::nullopt;
  EnergyWatch::State s;
  s.started = r.int64_attr(prefix + "energy_started") != 0;
  s.energy0 = r.double_attr(prefix + "energy0" + unit);
  s.work = r.double_attr(prefix + "work" + unit);
  s.work_abs = r.double_attr(prefix + "work_abs" + unit);
  s.energy_max = r.double_attr(prefix + "energy_max" + unit);
  return s;
}

}  // namespace cosim::protocol
