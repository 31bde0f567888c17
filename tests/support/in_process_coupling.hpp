// The coupled scheme of DESIGN 2.1 in one process, without transport: the fluid spreads the
// impulses J_l at X_l and steps, interpolates rho_l and u_l at X_l; the solid takes A_T
// substeps with that sample frozen (SolidCoupler::advance) and returns the next X_l and J_l.
// Shared by the ledger test (test_coupling.cpp) and the sheet-in-air tests.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "fluid/solver/fluid_solver.hpp"
#include "fluid/ib/immersed_boundary.hpp"
#include "solid/coupling/solid_coupler.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::test {

class InProcessCoupling {
 public:
  InProcessCoupling(fluid::FluidSolver& fluid, solid::SolidModel& model, solid::SolidCoupler& coupler)
      : fluid_(fluid), ib_(fluid), model_(model), coupler_(coupler),
        n_(static_cast<std::size_t>(model.num_cgps())), x_(n_), j_(n_), samples_(n_),
        position_(coupler.positions_lb()), impulse_(Eigen::Matrix3Xd::Zero(3, model.num_cgps())) {}

  /// One LB step: spread the impulses in flight, step the fluid, sample it, advance the
  /// solid (rigid: the spin-up's interval). Returns the interval; `applied` (if given) gets
  /// the sum of what the fluid's nodes received.
  solid::IntervalResult step(bool rigid = false, Eigen::Vector3d* applied = nullptr) {
    if (applied) applied->setZero();
    for (std::size_t l = 0; l < n_; ++l) {
      const auto c = static_cast<Eigen::Index>(l);
      x_[l] = {position_(0, c), position_(1, c), position_(2, c)};
      j_[l] = {impulse_(0, c), impulse_(1, c), impulse_(2, c)};
      if (applied)
        ib_.spread(x_[l], j_[l], [&](int, int, int, const fluid::Vec3& f) {
          *applied += Eigen::Vector3d(f[0], f[1], f[2]);
        });
    }
    ib_.spread(fluid_, x_, j_);
    fluid_.step();
    ib_.sample(fluid_, x_, samples_);
    solid::FluidSample sample;
    sample.rho_lb.resize(model_.num_cgps());
    sample.velocity_lb.resize(3, model_.num_cgps());
    for (std::size_t l = 0; l < n_; ++l) {
      const auto c = static_cast<Eigen::Index>(l);
      sample.rho_lb[c] = samples_[l].rho;
      sample.velocity_lb.col(c) = Eigen::Vector3d(samples_[l].u[0], samples_[l].u[1], samples_[l].u[2]);
    }
    solid::IntervalResult r = coupler_.advance(sample, rigid);
    position_ = r.position_lb;
    impulse_ = r.impulse_lb;
    return r;
  }

  /// The impulses sent by the solid and not yet applied to the fluid.
  const Eigen::Matrix3Xd& impulse_in_flight() const { return impulse_; }

 private:
  fluid::FluidSolver& fluid_;
  const fluid::ImmersedBoundary ib_;
  solid::SolidModel& model_;
  solid::SolidCoupler& coupler_;
  std::size_t n_;
  std::vector<fluid::Vec3> x_, j_;
  std::vector<fluid::MarkerSample> samples_;
  Eigen::Matrix3Xd position_, impulse_;
};

}  // namespace cosim::test
