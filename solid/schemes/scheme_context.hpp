// The solid as a coupling scheme (solid_scheme.hpp) sees it: the solid it drives (the
// server's or a library solid, scheme_solid.hpp), its session (SolidPeer), with the steps
// every scheme builds on.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <vector>

#include <Eigen/Core>

#include "cosimlcm/fluid_state_t.hpp"
#include "common/run/exit_codes.hpp"
#include "solid/coupling/solid_coupler.hpp"

namespace cosim::solid {

class SchemeSolid;
class SolidPeer;

/// rho_l and u_l of a message's arrays as a FluidSample (sizes checked by SolidRun::check).
FluidSample sample_from(const std::vector<double>& rho, const std::vector<std::vector<double>>& u);
/// The fluid after the step (the serial scheme's sample; the start of the next step).
FluidSample sample_of(const cosimlcm::fluid_state_t& m);

struct SchemeContext {
  SchemeSolid& solid;
  SolidPeer& peer;
  std::ostream& out;  ///< the run's report

  /// One LB interval driven by fluid_state_t(m) (section 5, steps 1-4; Eqs. 18-20 and 24),
  /// published as solid_state_t(step): the checks, the interval and its sentinels, the row
  /// of solid.h5, the snapshot and the checkpoint when due (SchemeSolid's).
  std::optional<protocol::Ending> interval(const cosimlcm::fluid_state_t& m, std::int64_t step);
  /// solid_state_t(step) of an interval of `substeps` with positions x and impulses j, as
  /// iterate `iteration`; `pending_substeps`: substeps of an iterate not yet on the solid's
  /// clock (they count in its solid_time_s).
  void publish(std::int64_t step, int substeps, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& j,
               int iteration = 0, int pending_substeps = 0);
};

}  // namespace cosim::solid
