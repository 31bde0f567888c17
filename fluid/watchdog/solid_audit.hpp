// What the coordinator can tell of the solid from the exchanged data alone, for the
// diagnosis of a sentinel on the markers (DESIGN 6; fluid/watchdog/marker_watch.hpp): when
// cgp_speed, marker_mach or marker_density trips, the fault may be the solid's, and then the
// message names the solid and the quantity instead of advising dt_CG, the inlet or the grid.
//   - motion against impulses: J_l = g(U_l, u_l) dA_l with the mean velocity U_l of the
//     marker over the step (the reaction law, protocol/README.md 5; Eqs. 18-19, 24); for the
//     laws linear in U_l (momentum_exchange, per_substep_over_time_ratio) the impulse gives
//     U_l = u_l + J_l / (2 rho_l dA_l'), dA_l' taken from the spin-up, where the markers are
//     held (J_l = -2 rho_l u_l dA_l'); the positions give X_l(n) - X_l(n - 1). Half an LB
//     step apart, the two agree within the change of U over a step; a solid whose positions
//     jump (e.g. reported in um instead of dx) or stand still while its impulses say they
//     move disagrees by far more.
//   - energy: the fluid's work on the solid, W = -sum J_l . (X_l(n) - X_l(n - 1)) (the solid
//     receives -J_l): markers that speed up while the fluid takes energy from them get it
//     from the solid itself (e.g. a reaction of the wrong sign on the markers).
// Transport-free, lattice units; O(markers) per step.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

namespace cosim::protocol {

class SolidAudit {
 public:
  using Vec3 = std::array<double, 3>;

  /// @param rigid_steps     the spin-up's LB steps (markers held)
  /// @param linear_in_motion  the scene's reaction law makes J_l linear in U_l with the
  ///                        momentum-exchange form (else the motion is not compared)
  SolidAudit(std::int64_t rigid_steps, bool linear_in_motion);

  /// solid_state_t(step): positions X_l and impulses J_l, and the sample it answered
  /// (fluid_state_t(step): rho_l and u_l as published; empty at step 0).
  void observe(std::int64_t step, const std::vector<Vec3>& x, const std::vector<Vec3>& j,
               const std::vector<double>& rho, const std::vector<Vec3>& u);

  /// One clause naming the solid and the quantity when the data show the solid at fault
  /// (its motion and impulses disagree at the last step, or its markers sped up over the
  /// last steps while the fluid took energy from them), else nothing.
  /// @param fallback_area_lb  dA of the lightest CGP (hello_t), dx^2, for a scene without
  ///                          a spin-up; 0: none
  std::optional<std::string> blame(double fallback_area_lb) const;

  /// The fluid's work on the solid so far, rho_air dx^3 c^2.
  double work() const { return work_; }

 private:
  struct Record {
    std::int64_t step = 0;
    std::vector<Vec3> x, j, u;
    std::vector<double> rho, work;  ///< work: each marker's -J_l . dX_l of this step
  };
  std::optional<std::string> motion_disagrees(const Record& now, const Record& before, double fallback_area_lb) const;
  std::optional<std::string> energy_from_solid() const;

  std::int64_t rigid_steps_;
  bool linear_;
  std::vector<double> area_num_, area_den_;  ///< sums for dA_l' over the held steps
  std::deque<Record> last_;                  ///< the last kWindow + 1 states
  double work_ = 0.0;
};

}  // namespace cosim::protocol
