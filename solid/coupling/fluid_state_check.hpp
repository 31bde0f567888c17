// The checks of section 5 on an accepted fluid_state_t (protocol/README.md), the same for
// the solid server (SolidRun::check) and for solids built on the solid library (sdk/): the
// step within the run, the sizes (exit code 2), finite values and rho > 0 (3), each a
// one-line reason naming the field, the value and the CGP.
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "cosimlcm/fluid_state_t.hpp"
#include "common/run/exit_codes.hpp"
#include "solid/model/solid_config.hpp"

namespace cosim::solid {

/// `m` against a solid of `num_cgps` CGPs (described by `config`) in a run of `total_steps`
/// whose last fluid_state_t carries `final_step`; nothing if it passes.
std::optional<protocol::Ending> check_fluid_state(const cosimlcm::fluid_state_t& m, Eigen::Index num_cgps,
                                                  std::int64_t final_step, std::int64_t total_steps,
                                                  const SolidConfig& config);

}  // namespace cosim::solid
