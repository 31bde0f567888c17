// The solid's side of a coupling scheme (protocol/README.md sections 5, 13, 14; DESIGN 2.1),
// a strategy chosen by name ([coupling] scheme) from one registry (registry.cpp):
//
//   - its message order: what each fluid_state_t drives (which intervals or iterates the
//     solid runs) and which solid_state_t it publishes;
//   - what the inbox orders fluid_state_t by (the step, or the fluid's seq), the first one
//     awaited, and its part of the window of steps a message may carry;
//   - when the solid has sent its part of the run's last step (for stop_t);
//   - what a checkpoint keeps of it, and what a restart from one awaits.
//
// A new scheme is one file here (a class and its factory) and one line of the registry; the
// fluid's side is the fluid's (protocol/coupling_scheme.hpp has the names both sides share).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "common/run/checkpoint_file.hpp"
#include "protocol/coupling_scheme.hpp"
#include "common/run/exit_codes.hpp"
#include "solid/schemes/scheme_context.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::solid {

using protocol::Ending;

class SolidScheme {
 public:
  virtual ~SolidScheme() = default;

  /// The scheme's row of the protocol's name table (protocol/coupling_scheme.hpp).
  virtual const protocol::MessageOrder& order() const = 0;
  /// The scheme's name ([coupling] scheme, hello_t.scheme).
  std::string_view name() const { return order().name; }

  // ---- the message order ----

  /// What the inbox orders fluid_state_t by, from its seq and step: the step (one message
  /// per step), or the seq where a step has several (the name table's).
  std::int64_t key(std::int64_t seq, std::int64_t step) const { return order().several_per_step ? seq : step; }
  /// The key of the first fluid_state_t awaited after the handshake (the name table's).
  std::int64_t first_key(std::int64_t rigid_steps) const { return order().first_fluid_key(rigid_steps); }
  /// The step that resend_t asks for (and a timeout names) while `awaited_key` is awaited
  /// and `last_step` was the last solid_state_t's: fluid_state_t(n + 1) answers
  /// solid_state_t(n) unless the scheme says otherwise.
  virtual std::int64_t awaited_step(std::int64_t /*awaited_key*/, std::int64_t last_step) const {
    return last_step + 1;
  }
  /// The window of steps a fluid_state_t may carry: from this one ...
  virtual std::int64_t lowest_fluid_step() const { return 1; }
  /// ... to this one, of a run of N = `total_steps`: the last step of any state message, in
  /// either direction (the name table's).
  std::int64_t final_step(std::int64_t total_steps) const { return order().final_step(total_steps); }
  /// What the message checks allow for a state message's iteration: [0, this).
  virtual int iterations_allowed() const { return 1; }
  /// The solid has sent its part of the run's last step: a success stop_t fits from then on.
  bool at_end(std::int64_t last_step, std::int64_t total_steps) const {
    return total_steps > 0 && last_step >= final_step(total_steps);
  }

  /// What the accepted fluid_state_t `m` drives: intervals or iterates of the solid, and the
  /// solid_state_t published for them. An ending stops the run.
  virtual std::optional<Ending> on_fluid_state(const cosimlcm::fluid_state_t& m, SchemeContext& ctx) = 0;

  // ---- checkpoints (DESIGN 2.4; protocol/README.md section 10) ----

  /// What a checkpoint written now restarts from when it is not the solid's state after the
  /// last interval and the last solid_state_t sent: the solid's kept start
  /// (SchemeSolid::keep_start) and this solid_state_t in flight.
  struct RestartPoint {
    const cosimlcm::solid_state_t* in_flight = nullptr;
  };
  virtual std::optional<RestartPoint> restart_point() const { return std::nullopt; }
  /// The scheme's own attributes and arrays of a checkpoint.
  virtual void save(protocol::CheckpointWriter& /*w*/, const SchemeContext& /*ctx*/) const {}
  /// A restart from the checkpoint `r` of `step`: the model holds its state, `in_flight` is
  /// its solid_state_t (with this run's token), published again after this; `ratio_changed`:
  /// the checkpoint ran another A_T. Returns the key to await. Throws (one line) for a
  /// checkpoint the scheme cannot continue from.
  virtual std::int64_t restore(const protocol::CheckpointReader& /*r*/, std::int64_t step, bool /*ratio_changed*/,
                               cosimlcm::solid_state_t& /*in_flight*/, SchemeContext& /*ctx*/) {
    return step + 1;
  }

  // ---- reports ----

  /// What the handshake line says of the scheme (", parallel scheme"), or nothing.
  virtual std::string announcement() const { return ""; }
  /// Lines for the end of the run (the implicit scheme's iterations), or nothing.
  virtual void report(std::ostream& /*out*/) const {}
};

/// The scheme of `settings` (its name, protocol::scheme_name), from the registry. Throws
/// std::invalid_argument for a scheme no entry builds, naming those that exist.
std::unique_ptr<SolidScheme> make_solid_scheme(const protocol::SchemeSettings& settings);

}  // namespace cosim::solid
