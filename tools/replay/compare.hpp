// cosim-replay's comparison of a message the replayed server published with the logged
// one of the same seq (docs/replay.md): bit for bit, field by field and CGP by CGP, with the
// first difference and the largest absolute and relative ones.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "tools/replay/replay.hpp"

namespace cosim::replay {

/// A value that differs, with its place in the message.
struct FieldDiff {
  std::string field;     ///< e.g. "velocity_lb[17][2]"
  std::int64_t cgp = -1; ///< -1: a field of the whole message
  double replay = 0.0, logged = 0.0, abs = 0.0, rel = 0.0;
};

/// Which message: the sender's seq, its step and sub-iteration.
struct MessageKey {
  std::int64_t seq = 0, step = 0;
  std::int32_t iteration = 0;
};

/// One message's comparison (one step's, in a scheme without sub-iterations).
struct StepResult {
  std::int64_t seq = 0, step = 0, values = 0, differing = 0;
  std::int32_t iteration = 0;
  std::optional<FieldDiff> first, max_abs, max_rel;
};

/// fluid_state_t (protocol/README.md section 3), the logged one of the same seq: step,
/// iteration, num_cgps, bulk_velocity_lb, then per CGP rho_lb, velocity_lb, rho_start_lb,
/// velocity_start_lb.
void compare(const cosimlcm::fluid_state_t& a, const cosimlcm::fluid_state_t& b, StepResult& r);

/// solid_state_t (section 3), the logged one of the same seq: step, iteration, substeps,
/// solid_time_s, num_cgps, then per CGP position_lb and impulse_lb.
void compare(const cosimlcm::solid_state_t& a, const cosimlcm::solid_state_t& b, StepResult& r);

/// What is compared, as the report names it.
const char* compared_fields(Side side);

/// "velocity_lb[17][2]: replay X, log Y (abs A, rel R)".
std::string describe(const FieldDiff& d);

}  // namespace cosim::replay
