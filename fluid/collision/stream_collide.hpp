// The fused stream-and-collide kernel: pull streaming (Eq. 9) and BGK collision with Guo
// forcing (Eqs. 10-11, 26) over all interior cells of a block.
#pragma once

#include <array>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "fluid/lattice/population_field.hpp"

namespace cosim::fluid {

/// dst(x) = collide(f_q(x) = src_q(x - c_q)), for every interior cell, with a force
/// density F (lattice units) that is uniform over the block. `src` holds post-collision
/// populations with its ghost layer filled (BoundaryConditions::fill_ghosts); `dst` gets
/// the post-collision populations of the next step. Two grids, structure of arrays,
/// OpenMP over rows of x, vectorised along x in groups of kLanes cells (fluid/lattice/lanes.hpp);
/// large fields are written with non-temporal stores (uses_streaming_stores).
enum class Stores {
  Auto,       ///< Streaming for large fields where the target has them (see below)
  Cached,     ///< ordinary stores
  Streaming,  ///< non-temporal stores (ordinary where the target has none)
};

/// Outflow faces normal to x whose ghosts the kernel writes itself: when it stores a row's
/// boundary cell (x = 0 or nx - 1) it also stores the outflow ghost of that row (x = -1 or
/// nx) from the post-collision populations still in registers (outflow_ghost in
/// fluid/boundary/boundary.hpp, the arithmetic of the ghost fill), instead of a separate pass that
/// reads the boundary cells back from memory. BoundaryConditions::kernel_outflow() says
/// which faces; default: none.
struct KernelOutflow {
  bool x_min = false, x_max = false;
  double rho_x_min = 1.0, rho_x_max = 1.0;  ///< reference densities (FaceSpec::outflow_density)
  /// The x = nx ghosts hold values that no fill after the kernel rewrites (an inlet's,
  /// BoundaryConditions::fill_static_ghosts): where the kernel stores whole lines that take
  /// in a row's x = nx ghost (non-temporal stores of a partial last line) it keeps them.
  /// Elsewhere it stores zeros there (and in the padding past them).
  bool keep_x_max_ghosts = false;
};

/// What the kernel saw of the state it read, over the interior cells: the extrema of rho
/// (Eq. 7) and of u.u (u with Guo's shift by the uniform force, as FluidSolver::cell) of the
/// pulled populations, and whether every rho and u.u was finite. Gathered as the kernel
/// collides, so the watchdog can check every step without a pass over memory of its own
/// (fluid/observables/flow_monitor.hpp, kernel_state_problem). Its sums run in the kernel's order, not
/// in summarize()'s: the two can differ in the last bits.
struct KernelExtrema {
  double rho_min = std::numeric_limits<double>::infinity();
  double rho_max = -std::numeric_limits<double>::infinity();
  double u2_max = 0.0;
  bool finite = true;
  /// Those of the cells of `part` too (a step in parts: the extrema of the whole).
  void merge(const KernelExtrema& part) {
    rho_min = std::min(rho_min, part.rho_min);
    rho_max = std::max(rho_max, part.rho_max);
    u2_max = std::max(u2_max, part.u2_max);
    finite = finite && part.finite;
  }
};

/// How the rows are shared among the OpenMP threads. Static: each thread one contiguous
/// part (the fastest on cores of its own). Dynamic: 64 chunks of whole rows, handed out as
/// threads come free, for steps that share the cores with another busy process (the parallel
/// coupling scheme's solid, protocol/README.md 14): a thread the scheduler holds back no
/// longer holds up the step. Measured in docs/results/kernel-step-20261122.md (bench --schedule).
enum class RowSchedule { Static, Dynamic };

/// The arithmetic the kernel collides in (Precision): Double for the modes "double" and
/// "mixed", Float for "single" and "half". The double store computes in double only, the
/// half store in float only.
enum class Arithmetic { Double, Float };
constexpr Arithmetic arithmetic_of(Precision p) {
  return float_arithmetic(p) ? Arithmetic::Float : Arithmetic::Double;
}

/// `extrema`, if given, receives the KernelExtrema of `src`. `arithmetic`: Double only
/// (std::invalid_argument otherwise).
void stream_collide(const PopulationField& src, PopulationField& dst, double tau,
                    const std::array<double, 3>& force, Stores stores = Stores::Auto,
                    const KernelOutflow& outflow = {}, KernelExtrema* extrema = nullptr,
                    RowSchedule schedule = RowSchedule::Static, Arithmetic arithmetic = Arithmetic::Double);
/// The same for the float store. Arithmetic::Double ("mixed"): loads convert to double, the
/// collision is the double one, stores round to float. Arithmetic::Float ("single"): loads,
/// collision and stores in float, groups twice as wide; the per-call constants (1/tau, the
/// force, Guo's source terms) computed in double and rounded once to float.
void stream_collide(const PopulationFieldSingle& src, PopulationFieldSingle& dst, double tau,
                    const std::array<double, 3>& force, Stores stores = Stores::Auto,
                    const KernelOutflow& outflow = {}, KernelExtrema* extrema = nullptr,
                    RowSchedule schedule = RowSchedule::Static, Arithmetic arithmetic = Arithmetic::Double);
/// The same for the half store ("half"): Arithmetic::Float only (std::invalid_argument
/// otherwise); the single mode's float kernel, each load decoding f_q = w_q + code 2^-15 and
/// each store encoding (f_q - w_q) 2^15 (fluid/lattice/half.hpp).
void stream_collide(const PopulationFieldHalf& src, PopulationFieldHalf& dst, double tau,
                    const std::array<double, 3>& force, Stores stores = Stores::Auto,
                    const KernelOutflow& outflow = {}, KernelExtrema* extrema = nullptr,
                    RowSchedule schedule = RowSchedule::Static, Arithmetic arithmetic = Arithmetic::Float);

/// Where a field keeps the post-collision populations f*_q(x) of its state.
///  - Canonical: at A[q](x), the two-grid layout; a step pulls f_q(x) = A[q](x - c_q), the
///    ghosts filled by BoundaryConditions (fill_ghosts).
///  - Swapped: at A[opp q](x + c_q), where an in-place step from Canonical leaves them; a
///    step then finds f_q(x) = f*_q(x - c_q) at A[opp q](x). For interior x whose x - c_q is
///    a ghost, that slot holds the ghost's value (in-place ghost fill, FluidSolver).
/// The map (q, x) -> (opp q, x + c_q) is its own inverse: swapping the two slots of every
/// pair turns one layout into the other (FluidSolver, convert_layout).
enum class PopulationLayout { Canonical, Swapped };

/// The x faces whose ghosts the in-place kernel writes itself, row by row, into the layout
/// the step leaves (BoundaryConditions::in_place_x_faces): after a row is collided, from its
/// own post-collision populations as stored (still in L1): a periodic face copies the row's
/// other end, an outflow the non-equilibrium extrapolation of its boundary cell
/// (outflow_ghost), an inlet the equilibria of `inlet`. Each ghost slot a row writes lies in
/// a row that no cell of the step touches there. Other (walls, free slip, halo): not written.
struct InPlaceXFaces {
  enum class Kind { Other, Periodic, Outflow, Inlet };
  Kind kind[2] = {Kind::Other, Kind::Other};  ///< x_min, x_max
  double rho_out[2] = {1.0, 1.0};             ///< Outflow: reference densities
  const double* inlet[2] = {nullptr, nullptr};  ///< Inlet: ny x 19, ghost of (q, y) (cx inward)
  bool all() const { return kind[0] != Kind::Other && kind[1] != Kind::Other; }
};

/// The rows (y + ny z) that a call of stream_collide_in_place steps: every row of the block
/// where `rows` is null, else rows[0 .. count - 1]. A cell's collision does not depend on
/// which others run in the same call: stepping the rows of a step in two calls gives the
/// bits of one (the split coupled step, FluidSolver::step_reading).
struct KernelRows {
  const std::int32_t* rows = nullptr;
  std::ptrdiff_t count = 0;
};

/// One step in place (the AA pattern): pull (Eq. 9) and collide as stream_collide, on one
/// field. From Canonical (ghosts filled) the state ends Swapped; from Swapped (its ghost slots
/// filled) it ends Canonical (ghosts not filled, but for x_faces). Same collision arithmetic, bit for bit, as
/// stream_collide; no outflow ghosts (the solver fills them); ordinary stores.
/// With `x_faces`, the ghosts of those x faces too (only where x_faces->all()).
/// `arithmetic` as stream_collide; `rows`: the rows stepped (KernelRows; all by default).
void stream_collide_in_place(PopulationField& f, PopulationLayout layout, double tau,
                             const std::array<double, 3>& force, KernelExtrema* extrema = nullptr,
                             RowSchedule schedule = RowSchedule::Static, const InPlaceXFaces* x_faces = nullptr,
                             Arithmetic arithmetic = Arithmetic::Double, KernelRows rows = {});
void stream_collide_in_place(PopulationFieldSingle& f, PopulationLayout layout, double tau,
                             const std::array<double, 3>& force, KernelExtrema* extrema = nullptr,
                             RowSchedule schedule = RowSchedule::Static, const InPlaceXFaces* x_faces = nullptr,
                             Arithmetic arithmetic = Arithmetic::Double, KernelRows rows = {});
void stream_collide_in_place(PopulationFieldHalf& f, PopulationLayout layout, double tau,
                             const std::array<double, 3>& force, KernelExtrema* extrema = nullptr,
                             RowSchedule schedule = RowSchedule::Static, const InPlaceXFaces* x_faces = nullptr,
                             Arithmetic arithmetic = Arithmetic::Float, KernelRows rows = {});

/// Population fields from the size of the CPU's last-level cache on (bytes, 19 populations
/// with ghosts, either precision) are written with non-temporal stores: they cannot stay in
/// cache between steps, and skipping the read for ownership cuts the traffic per update from
/// 456 to 304 bytes. Smaller fields are reused from cache, where ordinary stores are faster
/// (measured: docs/results/kernel-levels-20261202.md, on a CPU with 32 MiB of L3). The L3 size as the Linux
/// kernel describes it (sysfs), this where it does not.
constexpr std::size_t kStreamingStoresFrom = std::size_t(32) << 20;
/// The threshold in use: the L3 size of this CPU, or kStreamingStoresFrom.
std::size_t streaming_stores_from();

/// Whether stream_collide(..., stores) writes fields of this layout with non-temporal
/// stores (never where the target has none, see kHasStreamingStores in fluid/lattice/lanes.hpp).
bool uses_streaming_stores(const GridLayout& layout, Stores stores = Stores::Auto,
                           std::size_t value_bytes = sizeof(double));

}  // namespace cosim::fluid
