// The solid-model interface of the solid server (DESIGN 2.5): what the coupling needs from
// any model of the sheets, and nothing more. Models are chosen by name in
// model_registry.cpp.
//
// Units. cosim::solid works in Hartree atomic units throughout (DESIGN 3): lengths in bohr
// (a_0), masses in electron masses (m_e), time in atomic time units (t_AU = hbar / E_h),
// velocities in bohr / t_AU, forces in E_h / bohr, energies in hartree (E_h). Conversions
// to lattice and SI units live in protocol/units.hpp only.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "solid/model/solid_observables.hpp"
#include "solid/model/solid_state.hpp"

namespace cosim::solid {

/// A model of all sheets of a scene as one array of coarse-grained particles (CGPs), one
/// column per CGP, ordered as SolidConfig says (sheet by sheet, SheetSpec index order).
/// Each substep integrates the CGP equation of motion (Eq. 20)
///   M_l dV_l/dt = F_l^int(X) + F_l^ext,   dX_l/dt = V_l,
/// with F^int the model's internal (elastic, contact) forces and F^ext the external forces
/// handed in by the caller (the fluid's, -J_l / dt_LB per LB interval, DESIGN 2.1).
/// Clamped CGPs stay at their reference positions with zero velocity.
class SolidModel {
 public:
  virtual ~SolidModel() = default;

  /// The name this model is registered under (model_registry.cpp).
  virtual std::string_view name() const = 0;
  virtual Eigen::Index num_cgps() const = 0;
  /// 3 x num_cgps(), bohr. The references of positions(), velocities() and masses() stay
  /// valid, and show the current state, for the model's lifetime (the coupler reads them once
  /// per LB interval, not once per substep).
  virtual const Eigen::Matrix3Xd& positions() const = 0;
  /// 3 x num_cgps(), bohr / t_AU.
  virtual const Eigen::Matrix3Xd& velocities() const = 0;
  /// num_cgps() lumped masses, m_e.
  virtual const Eigen::VectorXd& masses() const = 0;
  /// Largest stable substep, t_AU: 2 / omega_max of M^-1 K for velocity Verlet;
  /// +infinity for a model without dynamics.
  virtual double stable_time_step() const = 0;
  /// Advance by one substep dt (t_AU) under external forces (3 x num_cgps(), E_h / bohr)
  /// held constant over the substep. Throws std::invalid_argument on a wrong shape or a
  /// non-positive dt.
  virtual void substep(double dt, const Eigen::Matrix3Xd& external_forces) = 0;
  virtual SolidObservables observables() const = 0;
  /// What a user should see at start-up, several lines of "key: value" text (for an
  /// elastic model: bending rigidity, first eigenfrequencies in vacuum, stable dt).
  virtual std::string startup_report() const = 0;
  /// The lowest eigenfrequencies of the sheets in vacuum (clamped, no fluid), ascending,
  /// Hz: at least three for an elastic model, empty for a model without dynamics.
  virtual std::vector<double> vacuum_eigenfrequencies_hz() const = 0;
  /// Checkpoint and restart; restore() throws std::invalid_argument when the state does
  /// not fit this model (other model, other CGP count).
  virtual SolidState state() const = 0;
  virtual void restore(const SolidState& state) = 0;
};

}  // namespace cosim::solid
