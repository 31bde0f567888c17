// The fluid's side of a coupling scheme (protocol/coupling_scheme.hpp; protocol/README.md
// sections 5, 13, 14): its message order (which solid_state_t each LB step waits for, which
// fluid_state_t it publishes), what it keeps for a restart, and how the coordinator orders
// and bounds the solid's messages. One class per scheme, one file each, chosen by name from
// the registry below; the solid's side is solid/schemes/.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <ostream>
#include <vector>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "common/run/checkpoint_file.hpp"
#include "protocol/coupling_scheme.hpp"

namespace cosim::fluid {

class Coordinator;
class FluidRun;

class FluidScheme {
 public:
  virtual ~FluidScheme() = default;

  /// The LB steps of the run from `first_step` (0, or a restart's step) to the end, after
  /// the handshake and the restore; the exit code (the coordinator ended the run).
  virtual int run(Coordinator& coordinator, FluidRun& run, std::int64_t first_step) = 0;

  /// What the coordinator orders solid_state_t by: its step (one message per LB step).
  virtual std::int64_t key_of(const cosimlcm::solid_state_t& m) const { return m.step; }
  /// The highest step of a solid_state_t the coordinator accepts now (the step window of
  /// protocol/README.md 8a), with `awaited_key` and the committed LB step `awaited_step`.
  virtual std::int64_t highest_solid_step(std::int64_t awaited_key, std::int64_t awaited_step,
                                          std::int64_t total_steps) const;
  /// The step asked for again when the awaited solid_state_t is missing.
  virtual std::vector<std::int64_t> resend_steps(std::int64_t awaited_key, std::int64_t awaited_step) const {
    (void)awaited_step;
    return {awaited_key};
  }
  /// Whether the solid_state_t of a restart's step was computed with the checkpoint's A_T
  /// (it is the message in flight, published again); else with the run's.
  virtual bool restart_message_has_checkpoint_ratio() const { return true; }

  /// What a checkpoint of `step` keeps for the scheme: the counters a restart continues
  /// with (fluid_seq), and messages in flight.
  virtual void write_checkpoint(protocol::CheckpointWriter& w, std::int64_t step, const Coordinator& c) const;
  /// A restart: the key of the first solid_state_t it awaits, and the checkpoint's
  /// fluid_state_t to publish again, if the scheme keeps one (throws, one line, if missing).
  virtual std::int64_t restart_key(const protocol::CheckpointReader& r) const { return r.int64_attr("step"); }
  virtual std::optional<cosimlcm::fluid_state_t> read_checkpoint(const protocol::CheckpointReader& r,
                                                                 std::int64_t step) const {
    (void)r;
    (void)step;
    return std::nullopt;
  }

  /// Lines of its own for the run's summary.
  virtual void summary(std::ostream& out, std::int64_t steps) const {
    (void)out;
    (void)steps;
  }
};

/// The fluid's side of the scheme named in the scene (the registry: fluid/schemes/registry.cpp).
std::unique_ptr<FluidScheme> make_fluid_scheme(const protocol::SchemeSettings& settings, std::int64_t total_steps,
                                               std::int64_t rigid_steps);

}  // namespace cosim::fluid
