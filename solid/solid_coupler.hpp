// The solid's side of one LB interval of the serial staggered scheme (DESIGN 2.1, 4.2):
// A_T CGP substeps with the fluid sample frozen (Eq. 17 keeps t fixed), each applying the
// reaction of the momentum-exchange force with the CGP's current velocity (Eqs. 18-20),
// and the sum of the impulses handed to the fluid (Eq. 24).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "protocol/units.hpp"
#include "solid/sheet_spec.hpp"
#include "solid/solid_model.hpp"

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
  /// g = 2 rho (U_B - u) (momentum_exchange_force, fluid/immersed_boundary.hpp), the CGP
  /// gets -g dA (B_F, Eq. 32) for the substep and J_l accumulates g dA / A_T.
  /// Throws std::invalid_argument for a sample of the wrong size or a non-finite value.
  IntervalResult advance(const FluidSample& sample, bool rigid);

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
};

/// dA_l of every CGP of the config's sheets (its cell, h_w h_h), in dx^2 of `units`.
std::vector<double> marker_areas_lb(const std::vector<SheetSpec>& sheets,
                                    const protocol::UnitConverter& units);

}  // namespace cosim::solid
