#include "sdk/energy_balance.hpp"

namespace cosim::sdk {

namespace {

protocol::EnergyWatch::Wording wording() {
  protocol::EnergyWatch::Wording w;
  w.sentinel = "energy_balance";
  w.subject = "the solid's energy (Solid::energy_lb)";
  w.unit = "rho_air dx^3 c^2";
  w.cause =
      "the solid gains energy that the fluid's work on its markers (-J_l . dX_l, from its own impulses and "
      "positions) does not give it: its energy, its motion and its impulses disagree (e.g. its markers receive "
      "+g dA instead of -g dA, protocol/README.md 5), a fault of the solid, not of dt_CG or the flow";
  w.dt_cure = false;
  return w;
}

}  // namespace

EnergyBalance::EnergyBalance(double energy0, const Eigen::Matrix3Xd& held)
    : watch_(kGrowth, kFloor, wording()), end_(held) {
  watch_.check(0, energy0, 0.0);
}

std::optional<protocol::Trip> EnergyBalance::add(std::int64_t step, const Eigen::Matrix3Xd& x,
                                                 const Eigen::Matrix3Xd& j, double energy) {
  std::optional<protocol::Trip> trip;
  if (pending_) {
    const Eigen::Matrix3Xd end = 0.5 * (pending_->x + x);
    // -sum_l J_l . dX_l: the reaction -g dA on the markers (Eqs. 18-19, 24).
    const double work = -(pending_->j.array() * (end - end_).array()).sum();
    trip = watch_.check(pending_->step, pending_->energy, work);
    end_ = end;
  }
  pending_ = Step{step, x, j, energy};
  return trip;
}

}  // namespace cosim::sdk
