// The solid's side of one LB interval of the serial staggered scheme (DESIGN 2.1, 4.2):
// A_T CGP substeps with the fluid sample frozen (Eq. 17 keeps t fixed), each applying the
// reaction of the momentum-exchange force with the CGP's current velocity (Eqs. 18-20),
// and the sum of the impulses handed to the fluid (Eq. 24).
#pragma once

#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "protocol/units.hpp"
#include "solid/coupling/reaction_law.hpp"
#include "solid/model/sheet_spec.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::solid {

/// rho_l and u_l of the fluid at each CGP (Eq. 17), lattice units.
struct FluidSample {
  Eigen::VectorXd rho_lb;
  Eigen::Matrix3Xd velocity_lb;
};

/// What the solid sends after one LB interval.
struct IntervalResult {
  /// X_l where the fluid spreads J_l: the time average of the CGP positions over the
  /// interval (trapezoid rule over the substep boundaries, second order), lattice units.
  Eigen::Matrix3Xd position_lb;
  /// J_l: impulse given to the fluid over the interval, lattice momentum units.
  Eigen::Matrix3Xd impulse_lb;
  /// The impulse the CGPs received over the interval, sum over substeps and CGPs of the
  /// reaction force times dt_CG, converted from atomic units on its own path (the ledger's
  /// other side: it must equal -sum_l J_l), lattice momentum units.
  Eigen::Vector3d received_impulse_lb = Eigen::Vector3d::Zero();
  int substeps = 0;
  /// The work of the fluid's forces on the CGPs over the interval, hartree: the sum over the
  /// substeps of F(v_k) . v_k dt_CG, each force at the velocity it was computed from (the
  /// power of the force law; solid/watchdog/energy_watch.hpp says why not F . dx).
  double fluid_work_au = 0.0;
  /// A CGP faster than the speed limit (SolidCoupler::set_speed_limit) after a substep: the
  /// interval stopped there (the watchdog's cgp_speed sentinel, DESIGN 6); position_lb and
  /// impulse_lb are then not filled.
  struct Overspeed {
    int substep = 0;       ///< 1 .. A_T: after which substep
    Eigen::Index cgp = 0;  ///< the fastest CGP
    double speed_lb = 0.0;  ///< its speed, c
    /// dt_CG over the relaxation time T = m / (2 rho dA c) of the fluid's reaction on it
    /// (Eqs. 18-20): the force held over a substep is explicit Euler for the drag, which
    /// diverges above 2.
    double dt_over_relaxation = 0.0;
  };
  std::optional<Overspeed> overspeed;
};

/// Where the solid's frame sits on the lattice: X_lb = X_bohr / dx + origin_lb. With the
/// plate surface at y = 0 in the solid's frame and the fluid's half-way bounce-back wall
/// at lattice y = -1/2, origin_lb = (0, -1/2, 0).
class SolidCoupler {
 public:
  /// @param marker_area_lb  dA_l of each CGP (Eq. 19), in dx^2
  SolidCoupler(SolidModel& model, const protocol::UnitConverter& units,
               std::vector<double> marker_area_lb, const Eigen::Vector3d& origin_lb);

  /// One LB interval with the sample frozen. rigid (the spin-up): no CGP dynamics, U_B = 0,
  /// J_l = g dA. Otherwise A_T substeps of dt_CG: at each, U_B = the CGP's velocity,
  /// g = 2 rho (U_B - u) (momentum_exchange_force, fluid/ib/immersed_boundary.hpp), the CGP
  /// gets -g dA (B_F, Eq. 32) for the substep and J_l accumulates g dA / A_T.
  /// Throws std::invalid_argument for a sample of the wrong size or a non-finite value.
  ///
  /// implicit_reaction (coupling.scheme = "implicit", protocol/README.md 13): the reaction on
  /// a free CGP is the drag of Eqs. 18-20 at its velocity at the end of the substep
  /// (backward Euler), F = D (u - V*) / (1 + h), D = 2 rho dA, h = dt_CG / T,
  /// T = m / (D c), V* = V + dt_CG / m F_other, with F_other the CGP's other forces (elastic,
  /// contact) of the previous substep, m dV / dt_CG - F (reaction_memory()). Any h is stable
  /// (the held force of the serial scheme diverges above h = 2), and a CGP that its other
  /// forces hold at rest gets the full drag D u.
  IntervalResult advance(const FluidSample& sample, bool rigid, bool implicit_reaction = false);

  /// The watchdog's limit on a CGP's speed, c (watchdog.max_cgp_speed; a displacement of
  /// speed / A_T dx per substep), checked after every substep; +infinity: none.
  void set_speed_limit(double speed_lb) { speed_limit_lb_ = speed_lb; }
  /// The largest CGP speed after a substep so far, c (checked only with a speed limit).
  double max_speed_lb() const { return max_speed_lb_; }

  /// What the implicit reaction remembers of the last substep: each CGP's velocity at its
  /// start and the reaction it got (atomic units); empty before the first implicit interval
  /// (the other forces then start at 0). Kept by the implicit scheme with the state it goes
  /// back to.
  struct ReactionMemory {
    Eigen::Matrix3Xd velocity;
    Eigen::Matrix3Xd force;
  };
  const ReactionMemory& reaction_memory() const { return memory_; }
  void set_reaction_memory(ReactionMemory m) { memory_ = std::move(m); }

  /// The law of the fluid's force on the CGPs ([reaction] law; solid/coupling/reaction_law.hpp);
  /// momentum_exchange by default. Every law applies in the rigid steps too, with U_B = 0.
  /// @pre not ReactionLaw other than MomentumExchange with implicit_reaction (the scene's
  /// parser refuses that pair)
  void set_reaction_law(ReactionLaw law) { law_ = law; }
  ReactionLaw reaction_law() const { return law_; }

  /// The CGPs whose velocity the model holds (clamped; every CGP of a model without
  /// dynamics): their reaction is not integrated as a drag (implicit_reaction).
  void set_held(std::vector<bool> held) { held_ = std::move(held); }

  /// The CGP positions in lattice units (what the first SOLID_STATE carries).
  Eigen::Matrix3Xd positions_lb() const;
  /// Total momentum of the free (non-clamped) CGPs, lattice units.
  Eigen::Vector3d momentum_lb() const;

 private:
  SolidModel& model_;
  protocol::UnitConverter units_;
  std::vector<double> area_;
  Eigen::Vector3d origin_;
  Eigen::Matrix3Xd force_au_;
  /// The substeps' watchdog check: fills r.overspeed and returns true for a CGP above the
  /// speed limit after substep k (0-based).
  bool over_speed_limit(int k, const FluidSample& sample, IntervalResult& r);
  std::vector<bool> held_;
  ReactionMemory memory_;
  ReactionLaw law_ = ReactionLaw::MomentumExchange;
  double speed_limit_lb_ = std::numeric_limits<double>::infinity();
  double max_speed_lb_ = 0.0;
};

/// The solid's frame on the lattice: its plate surface y = 0 is the fluid's half-way
/// bounce-back wall at lattice y = -1/2; x and z: lattice = physical / dx
/// (protocol/README.md section 4). origin_lb of the solid server's coupler.
inline Eigen::Vector3d solid_origin_lb() { return {0.0, -0.5, 0.0}; }

/// The flat sheets' CGP positions (flat_sheet_positions, sheet by sheet) on the lattice of
/// `units`: X_lb = X_bohr / dx + solid_origin_lb(), the positions the solid server's
/// first solid_state_t carries.
Eigen::Matrix3Xd marker_positions_lb(const std::vector<SheetSpec>& sheets, const protocol::UnitConverter& units);

/// dA_l of every CGP of the config's sheets (its cell, h_w h_h), in dx^2 of `units`.
std::vector<double> marker_areas_lb(const std::vector<SheetSpec>& sheets,
                                    const protocol::UnitConverter& units);

}  // namespace cosim::solid
