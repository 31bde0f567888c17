// The solid's energy sentinel (DESIGN 6; common/watchdog/watchdog.hpp): after every LB interval, the
// energy of the sheets (kinetic + elastic + contact) against what the fluid's work explains.
// Transport-free; energies in joules.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "common/watchdog/watchdog.hpp"

namespace cosim::protocol {

/// Energy balance of the sheets: E(n) - E(0) = W(n) + (integration error), W the work the
/// fluid did on the CGPs. The work is taken with each substep's force at the velocity it was
/// computed from (F(v_k) . v_k dt, the power of the force law), not F . dx: a drag that the
/// substeps integrate unstably (dt_CG above m / (rho dA c)) then shows as energy the work
/// does not explain, as does an elastic or contact force that the step does not resolve.
/// The sentinel trips when the unexplained energy R = E - E(0) - W exceeds
/// growth x (the largest energy reached before + the work exchanged in either direction so
/// far, or `floor` if that is smaller): an energy that grows by an order of magnitude beyond
/// everything the run has seen.
class EnergyWatch {
 public:
  /// How a trip reads: the sentinel's name, what the energy is of, its unit, the cause and
  /// whether a smaller dt_CG may cure it. The defaults are the solid server's (its work is
  /// each substep's power, so what it does not explain is the substeps' doing).
  struct Wording {
    std::string sentinel = "energy_growth";
    std::string subject = "the sheets' energy";
    std::string unit = "J";
    std::string cause = "a force the substeps do not resolve (a smaller dt_CG may cure it)";
    bool dt_cure = true;
  };

  /// @param growth  watchdog.energy_growth
  /// @param floor   the smallest energy scale (the sheets at rest have none): tiny, positive
  EnergyWatch(double growth, double floor);
  EnergyWatch(double growth, double floor, Wording wording);

  /// The first call takes E(0); later calls add the interval's work and check.
  /// @param energy  E after the interval of `step`
  /// @param work    the fluid's work on the CGPs over that interval
  /// @post a Trip (wording's sentinel, dt_cure) when tripped; the state is not advanced then
  std::optional<Trip> check(std::int64_t step, double energy, double work);

  /// What a checkpoint keeps: E(0), the work so far, the work in either direction, the
  /// largest energy; `started` false before the first call.
  struct State {
    bool started = false;
    double energy0 = 0.0, work = 0.0, work_abs = 0.0, energy_max = 0.0;
  };
  State state() const { return st_; }
  /// The largest R / (energy scale) seen so far (how close a healthy run came to `growth`).
  double max_ratio() const { return max_ratio_; }
  void restore(const State& s) { st_ = s; }

 private:
  double growth_, floor_;
  Wording w_;
  State st_;
  double max_ratio_ = 0.0;
};

}  // namespace cosim::protocol
