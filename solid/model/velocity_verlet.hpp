// The CGP integrator (DESIGN 4.3 item 7): one velocity-Verlet substep of the CGP equation
// of motion (Eq. 20), written once for every elastic model.
#pragma once

#include <Eigen/Core>

namespace cosim::solid {

/// One velocity-Verlet substep of
///   M_l dV_l/dt = F_l^int(X) + F_l^ext,   dX_l/dt = V_l            (Eq. 20)
/// with the external force held constant over the substep (the fluid sample is frozen
/// during the A_T substeps of one LB interval, DESIGN 2.1):
///   V^{n+1/2} = V^n + dt/2 M^-1 (F^int(X^n) + F^ext)
///   X^{n+1}   = X^n + dt V^{n+1/2}
///   V^{n+1}   = V^{n+1/2} + dt/2 M^-1 (F^int(X^{n+1}) + F^ext)
/// Second order and symplectic for position-dependent forces; stable for
/// dt < 2 / omega_max of M^-1 K.
///
/// @param x           3 x N positions, advanced in place
/// @param v           3 x N velocities, advanced in place
/// @param inv_mass    N inverse masses; 0 holds a CGP (clamped: it keeps its zero velocity)
/// @param f_internal  in: F^int(X^n); out: F^int(X^{n+1}), to be handed to the next substep
/// @param f_external  3 x N, constant over the substep
/// @param internal_force  callable (const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) that
///                    writes F^int(x) into f (3 x N, already sized)
template <class InternalForce>
void velocity_verlet_substep(Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& v,
                             const Eigen::VectorXd& inv_mass, Eigen::Matrix3Xd& f_internal,
                             const Eigen::Matrix3Xd& f_external, double dt,
                             InternalForce&& internal_force) {
  const double half_dt = 0.5 * dt;
  const Eigen::Index n = x.cols();
  for (Eigen::Index l = 0; l < n; ++l) {
    v.col(l) += (half_dt * inv_mass[l]) * (f_internal.col(l) + f_external.col(l));
    x.col(l) += dt * v.col(l);
  }
  internal_force(static_cast<const Eigen::Matrix3Xd&>(x), f_internal);
  for (Eigen::Index l = 0; l < n; ++l)
    v.col(l) += (half_dt * inv_mass[l]) * (f_internal.col(l) + f_external.col(l));
}

}  // namespace cosim::solid
