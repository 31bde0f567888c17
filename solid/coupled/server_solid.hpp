// The solid server's model and coupler as a coupling scheme drives them (solid/schemes/
// scheme_solid.hpp): the run's physics (SolidRun), its checkpoints, and the start of the step
// being iterated (the model's state and the implicit reaction's memory).
#pragma once

#include <cstdint>
#include <optional>

#include "solid/coupled/solid_run.hpp"
#include "solid/schemes/scheme_solid.hpp"

namespace cosim::solid {

class SolidCheckpoints;

class ServerSolid final : public SchemeSolid {
 public:
  /// `checkpoints` may be constructed after this (only stored here).
  ServerSolid(SolidRun& run, SolidCheckpoints& checkpoints) : run_(run), checkpoints_(checkpoints) {}

  std::int64_t total_steps() const override { return run_.total_steps(); }
  std::int64_t rigid_steps() const override { return run_.rigid_steps(); }
  Eigen::Index num_cgps() const override { return run_.num_cgps(); }
  int time_ratio() const override { return run_.coupling().time_ratio; }
  Eigen::Matrix3Xd positions_lb() const override { return run_.coupler().positions_lb(); }
  std::int64_t total_substeps() const override { return run_.total_substeps(); }
  double solid_time_s(std::int64_t substeps) const override { return run_.solid_time_s(substeps); }

  std::optional<protocol::Ending> check(const cosimlcm::fluid_state_t& m) const override { return run_.check(m); }
  std::optional<protocol::Ending> interval(const FluidSample& sample, std::int64_t step, IntervalResult& r) override {
    return run_.interval(sample, step, r);
  }
  std::optional<protocol::Ending> commit(std::int64_t step, const IntervalResult& r, double bulk_velocity_lb) override {
    return run_.commit(step, r, bulk_velocity_lb);
  }
  std::optional<protocol::Ending> snapshot(std::int64_t step) override { return run_.snapshot(step); }
  std::optional<protocol::Ending> checkpoint_if_due(std::int64_t step) override;

  /// The model's state and the implicit reaction's memory (SolidCoupler::reaction_memory).
  void keep_start() override;
  /// From the kept start (the model restored for iterates after the first), the reaction
  /// integrated exactly over each substep (SolidCoupler::advance, implicit_reaction).
  std::optional<protocol::Ending> iterate(const FluidSample& drive, std::int64_t step, int iteration,
                                          IntervalResult& trial) override;
  void save_start(protocol::CheckpointWriter& w) const override;
  void restore_start(const protocol::CheckpointReader& r) override;

  /// The model's state at the start of the step being iterated (a checkpoint's state then).
  const SolidState& kept_start() const { return start_; }

 private:
  SolidRun& run_;
  SolidCheckpoints& checkpoints_;
  SolidState start_;                          ///< the committed state at the start of the step
  SolidCoupler::ReactionMemory start_memory_;  ///< the implicit reaction's, at the start
};

}  // namespace cosim::solid
