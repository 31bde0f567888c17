// The energy balance of a library solid that reports its energy (Solid::energy_lb, the
// solid library's optional hook): the energy it gains against the work of the fluid's
// reaction on its markers, from what the protocol carries (J_l and the mean positions X_l).
// Physics only: lattice units, no transport, no files.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>

#include "common/watchdog/watchdog.hpp"
#include "solid/watchdog/energy_watch.hpp"

namespace cosim::sdk {

/// E(n) - E(0) against W(n), the work of the reaction -g_l dA_l (Eqs. 18-19) on the
/// markers. The marker receives -g dA while the fluid receives J_l = the substeps' mean of
/// g dA (Eq. 24), so over LB step n the work is -J_l(n) . (X_l^end(n) - X_l^end(n - 1)),
/// exact for a g constant over the step; the end positions are not exchanged, they are
/// taken as the mean of two consecutive mean positions, (X_l(n) + X_l(n + 1)) / 2, and
/// X_l^end before the first free step is the held position. Step n is therefore checked
/// when step n + 1 has come. The check is protocol::EnergyWatch's with growth kGrowth: a
/// reaction of the wrong sign on the markers gains them what the fluid's impulses say it
/// took (E - E(0) = -W), an unexplained energy of about the whole energy scale (ratio 1).
class EnergyBalance {
 public:
  /// The unexplained energy allowed, in units of the energy scale (EnergyWatch).
  static constexpr double kGrowth = 0.5;
  /// The smallest energy scale, rho_air dx^3 c^2 (a sheet at rest has none).
  static constexpr double kFloor = 1e-12;

  /// @param energy0  E after start() (finite)
  /// @param held     the markers' positions before the first free step, 3 x N
  EnergyBalance(double energy0, const Eigen::Matrix3Xd& held);

  /// The answer of free LB step `step` (mean positions X_l, impulses J_l) and E after it;
  /// checks the step before. @post the trip "energy_balance" naming both energies, or none
  std::optional<protocol::Trip> add(std::int64_t step, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& j,
                                    double energy);
  /// The work W of the steps checked so far.
  double work() const { return watch_.state().work; }
  /// The largest unexplained energy over the energy scale seen (how close the run came).
  double max_ratio() const { return watch_.max_ratio(); }

  /// The answer added last, checked when the next comes.
  struct Step {
    std::int64_t step = 0;
    Eigen::Matrix3Xd x, j;
    double energy = 0.0;
  };
  /// What a checkpoint keeps, so that a restart continues the balance bit for bit.
  struct Saved {
    protocol::EnergyWatch::State watch;
    Eigen::Matrix3Xd end;
    std::optional<Step> pending;
  };
  Saved saved() const { return {watch_.state(), end_, pending_}; }
  /// @pre s.end has this balance's marker count
  void restore(const Saved& s) {
    watch_.restore(s.watch);
    end_ = s.end;
    pending_ = s.pending;
  }

 private:
  protocol::EnergyWatch watch_;
  Eigen::Matrix3Xd end_;         ///< X_l^end before the pending step
  std::optional<Step> pending_;  ///< the last step added, checked with the next
};

}  // namespace cosim::sdk
