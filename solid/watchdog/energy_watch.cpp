#include "solid/watchdog/energy_watch.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "common/text/text.hpp"

namespace cosim::protocol {

EnergyWatch::EnergyWatch(double growth, double floor) : EnergyWatch(growth, floor, Wording{}) {}

EnergyWatch::EnergyWatch(double growth, double floor, Wording wording)
    : growth_(growth), floor_(floor), w_(std::move(wording)) {}

std::optional<Trip> EnergyWatch::check(std::int64_t step, double energy, double work) {
  if (!st_.started) {
    st_.started = true;
    st_.energy0 = st_.energy_max = energy;
    return std::nullopt;
  }
  const double w = st_.work + work, w_abs = st_.work_abs + std::abs(work);
  const double unexplained = energy - st_.energy0 - w;
  const double scale = std::max(st_.energy_max, floor_) + w_abs;
  if (std::isfinite(unexplained / scale)) max_ratio_ = std::max(max_ratio_, unexplained / scale);
  if (!std::isfinite(energy) || !std::isfinite(work) || unexplained > growth_ * scale) {
    Trip t;
    t.sentinel = w_.sentinel;
    t.step = step;
    t.dt_cure = w_.dt_cure;
    const std::string unit = " " + w_.unit;
    t.diagnosis = "watchdog " + w_.sentinel + " at step " + std::to_string(step) + ": " + w_.subject + " " +
                  fmt("%.4g", energy) + unit + " is " + fmt("%.4g", unexplained) + unit +
                  " more than E(0) + the fluid's work explain (" + fmt("%.4g", st_.energy0) + " + " +
                  fmt("%.4g", w) + unit + "), " + fmt("%.3g", unexplained / scale) +
                  " times the energy scale so far " + fmt("%.4g", scale) + unit + ", above " +
                  (w_.sentinel == "energy_growth" ? "watchdog.energy_growth = " : "") + fmt("%.4g", growth_) +
                  ": " + w_.cause;
    return t;
  }
  st_.work = w;
  st_.work_abs = w_abs;
  st_.energy_max = std::max(st_.energy_max, energy);
  return std::nullopt;
}

}  // namespace cosim::protocol
