// The solid a coupling scheme drives (solid_scheme.hpp): the solid server's model and
// coupler (solid/coupled/server_solid.hpp) or a user's solid on the solid library (sdk/),
// behind the same calls, so that every scheme of the registry runs either. Lattice units.
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "common/run/checkpoint_file.hpp"
#include "common/run/exit_codes.hpp"
#include "cosimlcm/fluid_state_t.hpp"
#include "solid/coupling/solid_coupler.hpp"

namespace cosim::solid {

class SchemeSolid {
 public:
  virtual ~SchemeSolid() = default;

  // ---- the run ----
  virtual std::int64_t total_steps() const = 0;
  virtual std::int64_t rigid_steps() const = 0;
  virtual Eigen::Index num_cgps() const = 0;
  /// A_T of this run.
  virtual int time_ratio() const = 0;
  /// The marker positions now (solid_state_t(0), and the closing solid_state_t(N, 0)).
  virtual Eigen::Matrix3Xd positions_lb() const = 0;
  /// The substeps on the solid's clock, and the solid time of `substeps`.
  virtual std::int64_t total_substeps() const = 0;
  virtual double solid_time_s(std::int64_t substeps) const = 0;

  // ---- one LB interval (section 5, steps 1-4) ----
  /// The checks of section 5 on an accepted fluid_state_t.
  virtual std::optional<protocol::Ending> check(const cosimlcm::fluid_state_t& m) const = 0;
  /// The interval of `step` driven by `sample` into `r` (the markers held during the
  /// spin-up), with its sentinels.
  virtual std::optional<protocol::Ending> interval(const FluidSample& sample, std::int64_t step, IntervalResult& r) = 0;
  /// The interval `r` of `step` is the fluid's: the energy sentinel, its substeps on the
  /// clock, its row of solid.h5 (`bulk_velocity_lb`: U_b of the fluid_state_t that began it).
  virtual std::optional<protocol::Ending> commit(std::int64_t step, const IntervalResult& r,
                                                 double bulk_velocity_lb) = 0;
  /// The output of `step` after it is published (the server's sheet snapshots).
  virtual std::optional<protocol::Ending> snapshot(std::int64_t step) = 0;
  /// The checkpoint of `step` when [coupling] checkpoint_every says so.
  virtual std::optional<protocol::Ending> checkpoint_if_due(std::int64_t step) = 0;

  // ---- a step's iterates (the implicit scheme) ----
  /// The state now is the start of a step's iterates: kept, for iterate() and checkpoints.
  virtual void keep_start() = 0;
  /// Iterate `iteration` of `step` from the kept start, driven by `drive`, into `trial`.
  virtual std::optional<protocol::Ending> iterate(const FluidSample& drive, std::int64_t step, int iteration,
                                                  IntervalResult& trial) = 0;
  /// What a checkpoint of a step being iterated keeps of the start beyond its state (the
  /// server's reaction memory), and reads back after a restart's keep_start().
  virtual void save_start(protocol::CheckpointWriter& w) const = 0;
  virtual void restore_start(const protocol::CheckpointReader& r) = 0;
};

}  // namespace cosim::solid
