// The grid of a fluid-only run as the run loop sees it (fluid/main.cpp): one solver in one
// process, or blocks over MPI ranks (fluid/mpi/distributed_fluid.hpp). The loop steps it,
// asks the watchdog's question and takes the whole grid for the monitor and the snapshots,
// the same calls either way; the leading process prints and writes.
#pragma once

#include <optional>
#include <string>

#include "fluid/flow_monitor.hpp"
#include "fluid/fluid_solver.hpp"
#include "fluid/scene_config.hpp"

namespace cosim::fluid {

class FluidDomain {
 public:
  virtual ~FluidDomain() = default;
  /// The process that prints and writes the outputs (rank 0; the only one of a serial run).
  virtual bool leads() const = 0;
  /// The initial state of the scene (initialize_flow). Collective.
  virtual void initialize(const FluidScene& scene) = 0;
  /// One LB step of the whole grid. Collective.
  virtual void step() = 0;
  /// kernel_state_problem() of the whole grid: the same text on every process. Collective.
  virtual std::string kernel_problem(const HealthLimits& limits) = 0;
  /// summarize() of the whole grid at the current state, on the leading process (nothing on
  /// the others). Collective.
  virtual std::optional<FlowSummary> summary() = 0;
  /// The whole grid at the current state (step count included), on the leading process;
  /// nullptr on the others: for the snapshots. Collective.
  virtual const FluidSolver* whole() = 0;
  /// The leading process's `text` on every process (a verdict they all act on). Collective.
  virtual std::string from_leader(const std::string& text) = 0;
  /// The header line of the decomposition ("" for one process).
  virtual std::string describe() const { return {}; }
};

/// The grid in this process: one FluidSolver.
class SerialDomain final : public FluidDomain {
 public:
  explicit SerialDomain(const FluidParams& params) : solver_(params) {}
  bool leads() const override { return true; }
  void initialize(const FluidScene& scene) override { initialize_flow(solver_, scene); }
  void step() override { solver_.step(); }
  std::string kernel_problem(const HealthLimits& limits) override {
    return kernel_state_problem(solver_, limits);
  }
  std::optional<FlowSummary> summary() override { return summarize(solver_); }
  const FluidSolver* whole() override { return &solver_; }
  std::string from_leader(const std::string& text) override { return text; }

 private:
  FluidSolver solver_;
};

}  // namespace cosim::fluid
