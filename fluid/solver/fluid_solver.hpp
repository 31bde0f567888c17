// The lattice Boltzmann fluid of one block: one population grid, or two (Propagation; double or single
// precision store), boundaries, forcing.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "fluid/boundary/boundary.hpp"
#include "fluid/lattice/grid_layout.hpp"
#include "fluid/lattice/population_field.hpp"
#include "fluid/collision/stream_collide.hpp"

namespace cosim::fluid {

/// How a step moves the populations (FluidParams::propagation).
///  - TwoGrid: pull from one grid into the other (stream_collide), the reference.
///  - InPlace (the default): one grid, the AA pattern (stream_collide_in_place): the state alternates
///    between PopulationLayout::Canonical and Swapped from step to step; same bits as
///    TwoGrid. Readers of the whole field (state(), copy_state()) get it Canonical (a pass
///    that swaps it back, where it was Swapped). Not kept: previous_state(), and the state
///    between begin_step() and finish_step() (readers throw there; add_force of a cell not
///    forced before begin_step() throws: its pulled populations were not saved).
enum class Propagation { TwoGrid, InPlace };
const char* propagation_name(Propagation p);

/// Plain typed parameters of the solver (lattice units). Scene parsing lives elsewhere.
struct FluidParams {
  GridShape shape;
  double tau = 1.0;                            ///< BGK relaxation time (the paper's phi)
  std::array<FaceSpec, kFaces> faces{};        ///< x_min, x_max, y_min, y_max, z_min, z_max
  std::array<double, 3> body_force{0, 0, 0};   ///< uniform force density (e.g. a pressure drop)
  /// How the populations are stored (fluid/lattice/population_field.hpp); arithmetic is double.
  Precision precision = Precision::Double;
  Propagation propagation = Propagation::InPlace;  ///< the default: half the memory, faster, same bits
  /// The row y = 0 of this grid in the whole grid's rows: 0, or a block's first row (a grid
  /// cut along y over MPI ranks, DESIGN 8); the inlet profiles are functions of the whole
  /// grid's y.
  int y_origin = 0;
};

/// The paper's channel (DESIGN 3): a Blasius inlet of speed `inlet_speed` (c) and boundary
/// layer `boundary_layer` (cells) on x_min, outflow on x_max, the plate (a wall) on y_min,
/// free slip on y_max, periodic in z. The set-up the bench and the tests share.
inline FluidParams blasius_channel(GridShape shape, double tau, double inlet_speed,
                                   double boundary_layer) {
  FluidParams p;
  p.shape = shape;
  p.tau = tau;
  p.faces[XMin].kind = FaceKind::Inlet;
  p.faces[XMin].inlet_speed = inlet_speed;
  p.faces[XMin].profile = InletProfile::Blasius;
  p.faces[XMin].boundary_layer = boundary_layer;
  p.faces[XMax].kind = FaceKind::Outflow;
  p.faces[YMin].kind = FaceKind::Wall;
  p.faces[YMax].kind = FaceKind::FreeSlip;
  return p;
}

/// rho and the velocity u = (sum_a c_a f_a + F_body / 2) / rho of one cell (Eqs. 7-8 with
/// Guo's half-force shift): the velocity before the immersed-boundary force of the coming
/// step, which is what the IB coupling (DESIGN 2.1) needs.
struct CellState {
  double rho = 0, ux = 0, uy = 0, uz = 0;
};

/// Dense interior fields, x fastest: index x + nx (y + ny z).
struct MacroscopicFields {
  GridShape shape;
  std::vector<double> rho, ux, uy, uz;
  std::size_t index(int x, int y, int z) const {
    return std::size_t(x) + std::size_t(shape.nx) * (std::size_t(y) + std::size_t(shape.ny) * z);
  }
};

class FluidSolver {
 public:
  /// `halo`: for a block of a decomposed grid (DESIGN 8), the exchange that fills the ghost
  /// planes of its faces from the neighbour blocks (fluid/domain/halo_exchange.hpp); not owned, it
  /// outlives the solver. Every ghost fill (the constructor's, initialize(), each step,
  /// refresh_ghosts()) then calls it: collective among the blocks.
  explicit FluidSolver(const FluidParams& params, HaloExchange* halo = nullptr);

  /// Every interior cell to the equilibrium (Eq. 11) of rho and u given per cell. `state` is
  /// called from one thread, once per cell in x-fastest order (it may keep state).
  using InitialState = std::function<CellState(int x, int y, int z)>;
  void initialize(const InitialState& state);
  void initialize_uniform(double rho, const std::array<double, 3>& u);

  /// Adds a force density (impulse per LB step, lattice units) at an interior cell for the
  /// next step only. The IB spreading (Eqs. 21-24) lands here; the cell is then collided
  /// with body_force + this force (Guo forcing, Eq. 26).
  /// @pre 0 <= x < nx, 0 <= y < ny, 0 <= z < nz
  void add_force(int x, int y, int z, double fx, double fy, double fz);

  /// One LB step: stream, collide (with forces), boundaries. Clears the added forces.
  /// begin_step() then finish_step(); in a block with halo faces and at least 3 planes, the
  /// same bits with the halo exchange overlapped with the interior planes (step_overlapped).
  void step();
  /// A step in two parts. begin_step(): the bulk of the step (stream and collide every cell
  /// with the uniform body force into the second grid); the state is not changed yet. The
  /// cells that receive a force (add_force, before or after begin_step) are collided again
  /// with it by finish_step(), from the same state, which then makes the new state current:
  /// the same result as step(). A coupled step runs the bulk while the solid computes the
  /// impulses it spreads (fluid/schemes/serial_scheme.cpp), with two grids; in place the
  /// forced cells must be known first (FluidDomain::bulk_before_impulses).
  /// @throws std::logic_error out of order
  void begin_step();
  void finish_step();
  /// Between begin_step() and finish_step().
  bool mid_step() const { return mid_step_; }

  /// The in-place step split around its readers (the coupled step, DESIGN 7): step() for
  /// the rows (y, z) that the cells `read` pull from, the rows of the forced cells and the
  /// rows within kRestMargin of a y or z face (those the ghost fill reads), the others'
  /// kernel left for finish_rest(). The step count, the arrangement and the ghosts are those
  /// of the step after it: populations_at() of a cell of `read` (and of any cell whose
  /// pulls avoid the rows left) is that of step() at once; every reader of the whole state
  /// (state(), macroscopic(), last_step_extrema(), copy_state(), begin_step(), ...) runs
  /// finish_rest() first, so none ever sees a state part stepped. Each cell reads and writes
  /// only its own 19 slots in an in-place step (stream_collide_in_place), so the rows left
  /// still hold the state the step began from: the same bits as step(). step() itself where
  /// it cannot split: two grids, a block with halo faces, x faces whose ghosts the kernel
  /// does not write (InPlaceXFaces::all), or no row to leave.
  /// @throws std::logic_error mid-step
  void step_reading(std::span<const std::array<int, 3>> read);
  /// The rest of the step of step_reading() (nothing where none is left).
  void finish_rest() const;
  /// Rows are left for finish_rest().
  bool rest_pending() const { return !rest_.empty(); }
  /// The rows next to each y and z face that step_reading() steps first: the ghost fill
  /// reads at most this many layers of cells (BoundaryConditions).
  static constexpr int kRestMargin = 3;

  /// Scales the inlets' velocity by `s` (Turek and Hron's start-up ramp, inlet_ramp): the
  /// inlet ghosts are written again with it, the two-grid step's static ones at once (both
  /// grids), the in-place kernel's x inlets from its next step on (the ghosts a step pulls
  /// were written by the step before: one step late). @pre not mid_step()
  void set_inlet_scale(double s);

  /// Pre-collision populations of the current time at an interior cell.
  void populations_at(int x, int y, int z, double* f) const;
  CellState cell(int x, int y, int z) const;
  /// rho and u at every interior cell (OpenMP).
  void macroscopic(MacroscopicFields& out) const;
  /// The same into planes z_at .. z_at + nz - 1 of `out`, whose shape is this grid's with
  /// more planes (a block's fields with room for its neighbours' planes); the other planes
  /// are left as they are. @pre out.shape: nx and ny this grid's, nz >= z_at + this nz
  void macroscopic(MacroscopicFields& out, int z_at) const;
  /// The same into rows y_at .. y_at + ny - 1 of those planes (a block cut along y too).
  void macroscopic(MacroscopicFields& out, int y_at, int z_at) const;

  const GridShape& shape() const { return layout_.shape(); }
  const GridLayout& layout() const { return layout_; }
  const BoundaryConditions& boundaries() const { return bc_; }
  double tau() const { return params_.tau; }
  double viscosity() const { return (params_.tau - 0.5) / 3.0; }  ///< Eq. 13
  const std::array<double, 3>& body_force() const { return params_.body_force; }
  std::int64_t step_count() const { return steps_; }
  /// The whole grid's row of this grid's row 0 (FluidParams::y_origin).
  int y_origin() const { return params_.y_origin; }

  Precision precision() const { return params_.precision; }
  Propagation propagation() const { return params_.propagation; }
  /// Where the populations are now (always Canonical for Propagation::TwoGrid).
  PopulationLayout population_layout() const { return arrangement_; }
  /// Whether previous_state() is available (a two-grid step ran since the state was set).
  bool has_previous_state() const { return have_previous_; }
  /// Bytes of the population grids (19 values per cell, with ghosts and padding): two, one
  /// for Propagation::InPlace.
  std::size_t population_bytes() const;

  /// The current post-collision field (ghosts filled); for checkpoints and tests.
  /// @pre precision() == Precision::Double (else std::logic_error)
  const PopulationField& state() const;
  PopulationField& mutable_state();
  /// The same for the float store. @pre stores_floats(precision())
  const PopulationFieldSingle& state_single() const;
  PopulationFieldSingle& mutable_state_single();
  /// The same for the half store (codes of f_q - w_q, decode_population). @pre stores_halves(precision())
  const PopulationFieldHalf& state_half() const;
  PopulationFieldHalf& mutable_state_half();
  /// The state's first value (population 0's) in the precision's store, for checkpoints
  /// (Canonical, as state()).
  const void* state_data() const;
  void* mutable_state_data();
  /// How the kernel shares the rows among the threads (RowSchedule; default Static).
  void set_row_schedule(RowSchedule s) { schedule_ = s; }
  /// What the last kernel saw of the state it read: extrema of rho and u.u and whether all
  /// were finite (KernelExtrema). That state is the current one between begin_step() and
  /// finish_step(), else the one before the last step (step_count() - 1).
  const KernelExtrema& last_step_extrema() const {
    finish_rest();
    return extrema_;
  }
  /// That state itself, as long as no other step() ran (the second grid keeps it).
  /// @pre step_count() >= 1 and precision() == Precision::Double (Single:
  /// previous_state_single()), else std::logic_error
  const PopulationField& previous_state() const;
  const PopulationFieldSingle& previous_state_single() const;
  const PopulationFieldHalf& previous_state_half() const;
  /// Call after changing mutable_state() or mutable_state_single() by hand.
  void refresh_ghosts();
  /// A block's wall ghosts that the neighbour blocks' cells fill in the undivided grid
  /// (BoundaryConditions::fill_wall_ghosts_of_halo_cells: the halo layers `cells` marks),
  /// in the current state, which is otherwise unchanged (this block's steps never read
  /// them): before its share of a checkpoint is written.
  void fill_wall_ghosts_of_halo_cells(const std::array<bool, kFaces>& cells);
  /// A restart from a checkpoint (DESIGN 2.4): the step count the restored state is at.
  void set_step_count(std::int64_t steps) { steps_ = steps; }

  /// Keeps the state (populations with their ghosts) in `to`, for the implicit coupling
  /// scheme's sub-iterations; `to` gets this solver's layout. The field of the solver's
  /// precision (std::logic_error for the other).
  void copy_state(PopulationField& to) const;
  void copy_state(PopulationFieldSingle& to) const;
  void copy_state(PopulationFieldHalf& to) const;
  /// Back to a state kept by copy_state(), at step count `steps`.
  /// @throws std::invalid_argument for a field of another layout
  void restore_state(const PopulationField& from, std::int64_t steps);
  void restore_state(const PopulationFieldSingle& from, std::int64_t steps);
  void restore_state(const PopulationFieldHalf& from, std::int64_t steps);

 private:
  static GridLayout solver_layout(const FluidParams& p, const HaloExchange* halo);
  /// fn(f, g) with the current field and the second grid of the precision's store (the
  /// second grid empty in place): f_, g_ (double), fs_, gs_ (float) or fh_, gh_ (half).
  template <class Fn>
  void with_fields(Fn&& fn) const {
    switch (params_.precision) {
      case Precision::Double: fn(f_, g_); return;
      case Precision::Mixed:
      case Precision::Single: fn(fs_, gs_); return;
      case Precision::Half: fn(fh_, gh_); return;
    }
  }
  template <class Fn>
  void with_fields(Fn&& fn) {
    switch (params_.precision) {
      case Precision::Double: fn(f_, g_); return;
      case Precision::Mixed:
      case Precision::Single: fn(fs_, gs_); return;
      case Precision::Half: fn(fh_, gh_); return;
    }
  }
  template <class T>
  void copy_state_of(const BasicPopulationField<T>& f, BasicPopulationField<T>& to) const;
  template <class T>
  void restore_state_of(const BasicPopulationField<T>& from, BasicPopulationField<T>& f, std::int64_t steps);
  template <class T>
  void begin_fields(const BasicPopulationField<T>& f, BasicPopulationField<T>& g);
  template <class T>
  void finish_fields(BasicPopulationField<T>& f, BasicPopulationField<T>& g);
  template <class T>
  void apply_local_forces(const BasicPopulationField<T>& f, BasicPopulationField<T>& g);
  /// step() of a block with halo faces (fluid/solver/overlapped_step.cpp).
  template <class T>
  void step_overlapped(BasicPopulationField<T>& f, BasicPopulationField<T>& g);
  template <class T>
  void populations_of(const BasicPopulationField<T>& f, int x, int y, int z, double* out) const;
  // Propagation::InPlace (fluid_solver.cpp).
  template <class T>
  void begin_in_place(BasicPopulationField<T>& f, KernelRows rows = {});
  template <class T>
  void finish_in_place(BasicPopulationField<T>& f);
  template <class T>
  void fill_swapped_ghosts(BasicPopulationField<T>& f) const;
  /// Swapped -> Canonical (a pass over the field), after finish_rest();
  /// @throws std::logic_error mid-step.
  void make_canonical(const char* call) const;
  /// Throws std::logic_error if a pull of cell (y, z)'s row reads a row left for finish_rest().
  void check_not_left(int x, int y, int z) const;

  FluidParams params_;
  GridLayout layout_;
  HaloExchange* halo_ = nullptr;
  BoundaryConditions bc_;
  InPlaceXFaces x_faces_;  // what the in-place kernel fills itself (x faces)
  // Current (post-collision, ghosts valid) and scratch; only the pair of the precision is
  // allocated.
  // Propagation::InPlace: one grid (g_, gs_ stay empty); const readers turn a Swapped state
  // Canonical (make_canonical).
  mutable PopulationField f_;
  PopulationField g_;
  mutable PopulationFieldSingle fs_;
  PopulationFieldSingle gs_;
  mutable PopulationFieldHalf fh_;
  PopulationFieldHalf gh_;
  mutable PopulationLayout arrangement_ = PopulationLayout::Canonical;
  // InPlace: the pulled populations of the forced cells (forced_ order), kept by begin_step().
  std::vector<double> saved_inputs_;
  std::int64_t steps_ = 0;
  mutable KernelExtrema extrema_;  // of the state the last step read
  // step_reading(): the rows (y + ny z) left for finish_rest(), a flag per row while any
  // are (populations_at's check), and whether the step began from Canonical.
  mutable std::vector<std::int32_t> rest_;
  mutable std::vector<std::uint8_t> rest_row_;
  mutable bool rest_from_canonical_ = false;
  std::vector<std::int32_t> near_rows_;  // step_reading()'s scratch
  RowSchedule schedule_ = RowSchedule::Static;
  bool have_previous_ = false;  // the second grid holds the state before the last step
  bool mid_step_ = false;       // begin_step() ran, finish_step() not yet

  // Sparse forcing: allocated on first use, so a scene without IB pays nothing.
  std::vector<double> fx_, fy_, fz_;
  std::vector<std::ptrdiff_t> forced_;
};

}  // namespace cosim::fluid
