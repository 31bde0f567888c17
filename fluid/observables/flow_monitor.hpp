// Health observables of the fluid (DESIGN 4.4): mass, momentum, max Mach, rho range, NaN.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "fluid/solver/fluid_solver.hpp"

namespace cosim::fluid {

/// An interior cell; (-1, -1, -1) when no cell applies.
struct CellIndex {
  int x = -1, y = -1, z = -1;
};

/// One pass over the interior cells of a solver at step `step`. Lattice units.
/// Sums run over every cell (a NaN shows in them); extrema run over the finite cells only,
/// so that they still name a place when part of the field is lost.
/// Ties go to the cell with the smallest index x + nx (y + ny z), whatever the thread count.
struct FlowSummary {
  std::int64_t step = 0;
  double mass = 0;                   ///< sum of rho over interior cells (Eq. 7)
  std::array<double, 3> momentum{};  ///< sum of rho u, u with Guo's half-force shift (Eq. 8)
  double max_mach = 0;               ///< max |u| / c_s = |u| sqrt(3)
  CellIndex max_mach_cell;
  double rho_min = 0;
  CellIndex rho_min_cell;
  double rho_max = 0;
  CellIndex rho_max_cell;
  bool has_nan = false;  ///< some cell has a non-finite rho or u (NaN or infinity)
  CellIndex nan_cell;    ///< the first such cell (smallest index)
  CellState nan_state;   ///< rho and u at nan_cell, to name the quantity
};

/// rho and u (Eqs. 7-8, as FluidSolver::cell) of every interior cell of the current state,
/// reduced in one OpenMP pass over the populations; no allocation per cell.
FlowSummary summarize(const FluidSolver& solver);

/// What summarize() gathers before it adds up: the sums of each row of x (mass, rho u_x,
/// rho u_y, rho u_z) in row order, and the extrema and the first non-finite cell by linear
/// index in the whole grid. A block of a decomposed grid (fluid/mpi/) gives its rows; the
/// rows of all blocks in row order and the extrema merged in any order make the whole
/// grid's summary, bit for bit the one of summarize() (flow_summary()).
struct FlowPartials {
  static constexpr std::int64_t kNone = std::numeric_limits<std::int64_t>::max();
  std::vector<std::array<double, 4>> row_sums;
  double u2_max = -1.0;
  std::int64_t u2_max_cell = kNone;
  double rho_min = std::numeric_limits<double>::infinity();
  std::int64_t rho_min_cell = kNone;
  double rho_max = -std::numeric_limits<double>::infinity();
  std::int64_t rho_max_cell = kNone;
  std::int64_t nan_cell = kNone;
  CellState nan_state;
  /// The extrema and the first non-finite cell of both (ties to the smaller index: exact in
  /// any order); row_sums untouched.
  void merge_extrema(const FlowPartials& other);
};
/// The partials of a block's current state, or (previous) of the state its last step read
/// (@pre as FluidSolver::previous_state), `first_cell` the linear index in the whole grid of
/// the block's cell (0, 0, 0), `whole_ny` the whole grid's rows per plane (0: the block's,
/// a block of whole planes); row_sums in the block's row order.
FlowPartials flow_partials(const FluidSolver& block, bool previous, std::int64_t first_cell, int whole_ny = 0);
/// The summary of the whole grid of `shape` at `step` from the partials of all its rows.
FlowSummary flow_summary(const FlowPartials& all, const GridShape& shape, std::int64_t step);

struct HealthLimits {
  double mach_limit = 0.3;  ///< BGK loses accuracy and stability as Mach approaches 1
  double rho_floor = 0.0;   ///< rho <= rho_floor is unphysical
  /// The watchdog's density bounds ([watchdog] rho_min, rho_max; common/watchdog/watchdog.hpp):
  /// rho below rho_min or above rho_max is unhealthy. The defaults check nothing.
  double rho_min = 0.0;
  double rho_max = std::numeric_limits<double>::infinity();
};

/// Empty if healthy, else one line naming the step, the cell and the quantity, checked in
/// this order: a non-finite value ("step 1200: cell (14, 3, 7): u_x is NaN"), the density
/// floor ("... rho = -0.02 <= 0"), the density bounds ("... rho = 0.42 below
/// watchdog.rho_min = 0.5", "... above watchdog.rho_max = 1.5"), the Mach limit ("... Mach
/// 0.41 above the limit 0.3").
std::string health_problem(const FlowSummary& s, const HealthLimits& limits);

/// The watchdog's check of the state the last kernel read (FluidSolver::last_step_extrema:
/// the current state between begin_step() and finish_step(), else the state before the last
/// step) from the extrema the kernel gathered: no pass over memory of its own. Empty while
/// they are within `limits`; else health_problem() of a summarize() pass over that state
/// (FluidSolver::previous_state after a step), which names the step and the cell. The kernel
/// adds in another order than summarize(): within a relative 1e-12 of a limit the extrema only
/// send the state to that pass, whose verdict counts. @pre a kernel ran since the state was
/// last set
std::string kernel_state_problem(const FluidSolver& solver, const HealthLimits& limits);

/// Whether kernel extrema are within a relative 1e-12 of a limit or past it (or not finite):
/// the test kernel_state_problem() applies before it looks closer. The extrema of several
/// blocks combine exactly (min, max, and), so a decomposed grid asks the same of the whole.
bool kernel_extrema_suspect(const KernelExtrema& e, const HealthLimits& limits);

}  // namespace cosim::fluid
