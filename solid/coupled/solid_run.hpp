// The solid's physics in a coupled run (DESIGN 2.1, 4.2, 6): the model named by the scene, its
// SolidCoupler (the A_T substeps of one LB interval, Eqs. 18-20 and 24), the watchdog's
// sentinels, the rows of solid.h5 and the sheet snapshots. No transport and no coupling
// scheme: the schemes (solid/schemes/) decide which interval a fluid_state_t drives, the
// session (solid_peer.hpp) carries the messages.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "solid/watchdog/energy_watch.hpp"
#include "common/run/exit_codes.hpp"
#include "protocol/units.hpp"
#include "solid/io/coupled_series.hpp"
#include "solid/io/sheet_snapshots.hpp"
#include "solid/coupling/solid_coupler.hpp"
#include "solid/model/solid_model.hpp"
#include "solid/config/solid_scene.hpp"

namespace cosim::solid {

using protocol::Ending;
namespace exit_code = protocol::exit_code;

class SolidRun {
 public:
  /// @pre scene.coupled()
  explicit SolidRun(const SolidScene& scene);

  // ---- set-up ----

  /// Builds the model (model_registry), its coupler with marker_areas_lb and the solid's
  /// frame on the lattice, and the watchdog. An ending (2) for a model that cannot be built.
  std::optional<Ending> build();
  /// The scene, the model, the sheets, the units and the coupling settings, on `out`.
  void print_header(std::ostream& out, const std::string& channel_prefix) const;
  /// The output folder and the snapshot writer; an ending (1) on an output error.
  std::optional<Ending> open_output();
  /// hello_t of this solid (section 6). Throws std::runtime_error for a scene file that
  /// cannot be hashed.
  cosimlcm::hello_t hello(const std::string& token) const;
  /// The run's length, from the welcome_t: N LB steps, the first `rigid_steps` rigid, and
  /// `final_step`, the last step a fluid_state_t of the run may carry (the scheme's).
  void set_length(std::int64_t total_steps, std::int64_t rigid_steps, std::int64_t final_step);

  // ---- one LB interval ----

  /// The checks of section 5 on an accepted fluid_state_t: sizes (2), finite and rho > 0 (3).
  std::optional<Ending> check(const cosimlcm::fluid_state_t& m) const;
  /// The interval of `step` driven by `sample` (rigid during the spin-up) into `r`, with the
  /// watchdog's speed sentinel and the finiteness of what the fluid gets.
  std::optional<Ending> interval(const FluidSample& sample, std::int64_t step, IntervalResult& r);
  /// An interval `r` of `step` that the fluid gets, before anything of it is published: the
  /// energy sentinel, its substeps on the solid's clock and its row of solid.h5
  /// (`bulk_velocity_lb`: U_b of the fluid_state_t that began it).
  std::optional<Ending> commit(std::int64_t step, const IntervalResult& r, double bulk_velocity_lb);
  /// Step 0: its row and the energy sentinel's reference E(0).
  void start();
  /// The energy sentinel's reference: the sheets' energy now is E(0) (an older checkpoint
  /// of `step` kept none).
  void reference_energy(std::int64_t step);
  /// OUTPUT/sheets_NNNNNN.h5 and sheets.xmf at step 0, every [output] sheets_every LB steps
  /// and the last step; an output error ends the run (1).
  std::optional<Ending> snapshot(std::int64_t step);

  // ---- diagnoses ----

  /// The watchdog's cgp_speed sentinel tripped within the interval of `step` (DESIGN 6).
  Ending overspeed(std::int64_t step, const IntervalResult::Overspeed& o) const;
  /// The first CGP with a non-finite position or velocity, or else a non-finite position or
  /// impulse of `r` for the fluid, as a diagnosis; "" if none.
  std::string non_finite(const IntervalResult& r) const;
  /// The first CGP with a non-finite position or velocity, as a diagnosis; "" if none.
  std::string non_finite_state() const;
  /// The watchdog's margins and the peak memory, for the end of the run.
  void print_margins(std::ostream& out) const;

  // ---- state ----

  SolidModel& model() { return *model_; }
  SolidCoupler& coupler() { return *coupler_; }
  protocol::EnergyWatch& energy_watch() { return *energy_watch_; }
  bool built() const { return model_ != nullptr; }
  Eigen::Index num_cgps() const { return n_; }
  const protocol::UnitConverter& units() const { return units_; }
  const SolidScene& scene() const { return s_; }
  const CouplingSettings& coupling() const { return c_; }
  std::int64_t total_steps() const { return total_steps_; }
  std::int64_t rigid_steps() const { return rigid_steps_; }

  /// The substeps taken so far (the solid's clock: solid_time_s = substeps x dt_CG).
  std::int64_t total_substeps() const { return total_substeps_; }
  void set_total_substeps(std::int64_t n) { total_substeps_ = n; }
  double solid_time_s(std::int64_t substeps) const { return static_cast<double>(substeps) * units_.dt_cg_s(); }

  CoupledSeries& series() { return series_; }
  const CoupledSeries& series() const { return series_; }
  SheetSnapshotWriter* snapshots() const { return snapshots_.get(); }

 private:
  /// A row of solid.h5 for `step`; `r` is the interval that produced it (null: step 0).
  void record(std::int64_t step, const IntervalResult* r, double bulk_velocity_lb);
  /// Kinetic + elastic (+ contact) energy of the sheets, J.
  double sheet_energy_J() const;
  /// The fastest CGP and its speed in c, for a diagnosis.
  std::string fastest_cgp() const;
  /// The CGP with the smallest mass per area (kg, m^2) for hello_t's added-mass fields.
  std::pair<double, double> light_cgp() const;
  /// The model's stable substep in seconds (the largest double for a model without dynamics).
  double stable_dt_cg_s() const;
  /// The CGPs the model holds: clamped rows; all of a model without dynamics.
  std::vector<bool> held_cgps() const;

  const SolidScene& s_;
  const CouplingSettings c_;
  const protocol::UnitConverter units_;
  std::unique_ptr<SolidModel> model_;
  std::unique_ptr<SolidCoupler> coupler_;
  std::optional<protocol::EnergyWatch> energy_watch_;  ///< the watchdog's energy sentinel
  Eigen::Index n_ = 0;
  std::int64_t total_steps_ = 0, rigid_steps_ = 0, final_step_ = -1;
  std::int64_t total_substeps_ = 0;
  CoupledSeries series_;
  std::unique_ptr<SheetSnapshotWriter> snapshots_;  ///< [output] sheets_every > 0
};

}  // namespace cosim::solid
