// The states of a coupled run, as both peers see them (DESIGN 2.2; protocol/README.md
// sections 5-8, 13, 14): the coordinator's state machine, in one place.
//
//   Handshake --accepted--> SpinUp --(step >= rigid_steps)--> FreeRun <--> Iterate
//       |                     |                                  |           |
//       +--- refused, lost, stopped, error, last step done ---> Stopping --> Done
//
//   Handshake  hello_t / welcome_t (section 6)
//   SpinUp     LB steps with the sheets held rigid: exchanged in the serial order in every
//              scheme, never iterated
//   FreeRun    the scheme's LB steps (serial, parallel, or an implicit step's first iterate)
//   Iterate    another sub-iteration of the same LB step (the implicit scheme, section 13)
//   Stopping   stop_t published or received: outputs and the closing lines
//   Done       the exit code is known
#pragma once

#include <stdexcept>
#include <string>

namespace cosim::protocol {

enum class RunPhase { Handshake, SpinUp, FreeRun, Iterate, Stopping, Done };

inline const char* phase_name(RunPhase p) {
  switch (p) {
    case RunPhase::Handshake: return "handshake";
    case RunPhase::SpinUp: return "spin-up";
    case RunPhase::FreeRun: return "free run";
    case RunPhase::Iterate: return "iterate";
    case RunPhase::Stopping: return "stopping";
    case RunPhase::Done: return "done";
  }
  return "?";
}

/// Whether the diagram above has the transition `from` -> `to` (staying in SpinUp, FreeRun
/// or Iterate from one LB step to the next included).
inline bool transition_allowed(RunPhase from, RunPhase to) {
  using P = RunPhase;
  switch (to) {
    case P::Handshake: return false;
    case P::SpinUp: return from == P::Handshake || from == P::SpinUp;
    case P::FreeRun: return from == P::Handshake || from == P::SpinUp || from == P::FreeRun || from == P::Iterate;
    case P::Iterate: return from == P::FreeRun || from == P::Iterate;
    case P::Stopping: return from != P::Done && from != P::Stopping;
    case P::Done: return from == P::Stopping;
  }
  return false;
}

/// The current state; every move is checked against the diagram.
class PhaseMachine {
 public:
  RunPhase phase() const { return phase_; }
  /// @throws std::logic_error naming both states for a transition the diagram does not have.
  void enter(RunPhase next) {
    if (!transition_allowed(phase_, next))
      throw std::logic_error(std::string("coupled run: no transition from ") + phase_name(phase_) + " to " +
                             phase_name(next));
    phase_ = next;
  }
  /// Stopping, unless the run is stopping or done already (an error while stopping).
  void stop() {
    if (phase_ != RunPhase::Stopping && phase_ != RunPhase::Done) enter(RunPhase::Stopping);
  }
  /// Done (through Stopping), once.
  void done() {
    stop();
    if (phase_ != RunPhase::Done) enter(RunPhase::Done);
  }

 private:
  RunPhase phase_ = RunPhase::Handshake;
};

}  // namespace cosim::protocol
