#include "solid/schemes/scheme_context.hpp"

#include "solid/coupled/solid_peer.hpp"
#include "solid/schemes/scheme_solid.hpp"

namespace cosim::solid {

FluidSample sample_from(const std::vector<double>& rho, const std::vector<std::vector<double>>& u) {
  FluidSample sample;
  const auto n = static_cast<Eigen::Index>(rho.size());
  sample.rho_lb.resize(n);
  sample.velocity_lb.resize(3, n);
  for (Eigen::Index l = 0; l < n; ++l) {
    const auto k = static_cast<std::size_t>(l);
    sample.rho_lb[l] = rho[k];
    for (Eigen::Index c = 0; c < 3; ++c) sample.velocity_lb(c, l) = u[k][static_cast<std::size_t>(c)];
  }
  return sample;
}

FluidSample sample_of(const cosimlcm::fluid_state_t& m) { return sample_from(m.rho_lb, m.velocity_lb); }

std::optional<protocol::Ending> SchemeContext::interval(const cosimlcm::fluid_state_t& m, std::int64_t step) {
  if (const auto e = solid.check(m)) return e;
  IntervalResult r;
  if (const auto e = solid.interval(sample_of(m), step, r)) return e;
  // The energy sentinel, before anything of this interval is published or recorded.
  if (const auto e = solid.commit(step, r, m.bulk_velocity_lb)) return e;
  publish(step, r.substeps, r.position_lb, r.impulse_lb);
  if (const auto e = solid.snapshot(step)) return e;
  return solid.checkpoint_if_due(step);
}

void SchemeContext::publish(std::int64_t step, int substeps, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& j,
                            int iteration, int pending_substeps) {
  peer.publish_state(step, substeps, solid.solid_time_s(solid.total_substeps() + pending_substeps), x, j, iteration);
}

}  // namespace cosim::solid
