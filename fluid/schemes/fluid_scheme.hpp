// The fluid's side of a coupling scheme (protocol/coupling_scheme.hpp; protocol/README.md
// sections 5, 13, 14), as the solid's (solid/schemes/solid_scheme.hpp): it answers each
// solid_state_t the step driver (fluid/coupled/step_driver.hpp) hands it, which owns the
// loop, the waiting, the interrupt path, timing and progress. A scheme says which
// solid_state_t it awaits and what each drives (LB steps, the fluid_state_t published), what
// it keeps for a restart, and how the coordinator orders and bounds the solid's messages.
// One class per scheme, one file each, chosen by name from the registry (registry.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "common/run/checkpoint_file.hpp"
#include "protocol/coupling_scheme.hpp"

namespace cosim::fluid {

class Coordinator;
class FluidRun;
class SchemeContext;

/// What a scheme's answer to one solid_state_t leaves: the run ended (its exit code), or the
/// step the progress line reports (with the iteration, in a scheme that iterates).
struct Reply {
  std::optional<int> exit;  ///< the run ended: stop_t or end() done, the exit code
  std::int64_t now = -1;    ///< the step reached; -1: no progress line
  int iteration = -1;       ///< the iterate published, or -1
};

class FluidScheme {
 public:
  explicit FluidScheme(const protocol::MessageOrder& order) : order_(order) {}
  virtual ~FluidScheme() = default;

  /// The scheme's row of the protocol's name table.
  const protocol::MessageOrder& order() const { return order_; }

  // ---- the message order (the step driver's calls) ----
  /// The run's LB steps begin at `first_step` (0, or a restart's step).
  virtual void start(std::int64_t first_step, SchemeContext& ctx) = 0;
  /// The committed LB step whose solid_state_t is awaited.
  virtual std::int64_t step() const = 0;
  /// The run's last LB step is committed.
  virtual bool done() const = 0;
  /// What runs before the wait for the awaited solid_state_t (the serial scheme's bulk of
  /// the step); the exit code of a trip.
  virtual std::optional<int> before_wait(SchemeContext& ctx) {
    (void)ctx;
    return std::nullopt;
  }
  /// The awaited solid_state_t `m`, taken from the coordinator: what it drives.
  virtual Reply on_solid_state(const cosimlcm::solid_state_t& m, SchemeContext& ctx) = 0;
  /// The run ends (a lost peer, a signal) while step() is awaited: the checkpoint of the
  /// committed state (FluidRun::checkpoint's line), or why there is none.
  virtual std::string keep(SchemeContext& ctx, const std::string& reason);

  /// What the coordinator orders solid_state_t by: its step, or its seq where a step has
  /// several messages (the name table's).
  std::int64_t key_of(const cosimlcm::solid_state_t& m) const { return order_.several_per_step ? m.seq : m.step; }
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

 private:
  const protocol::MessageOrder& order_;
};

/// The fluid's side of the scheme named in the scene (the registry: fluid/schemes/registry.cpp).
std::unique_ptr<FluidScheme> make_fluid_scheme(const protocol::SchemeSettings& settings, std::int64_t total_steps,
                                               std::int64_t rigid_steps);

}  // namespace cosim::fluid
