#include "fluid/solver/fluid_solver.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "fluid/collision/bgk_guo.hpp"
#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/equilibrium.hpp"
#include "fluid/collision/stream_collide.hpp"

namespace cosim::fluid {

namespace {

[[noreturn]] void wrong_precision(const char* call, Precision stored) {
  throw std::logic_error(std::string(__FILE__) + ": FluidSolver::" + call +
                         ": the populations are stored in " + precision_name(stored) +
                         " precision; use the accessor of that precision, or populations_at()");
}

/// Offset of the lattice vector c_q.
std::ptrdiff_t shift(const GridLayout& lay, int q) {
  return lay.offset(D3Q19::cx[q], D3Q19::cy[q], D3Q19::cz[q]);
}

/// Swaps the pairs (q, x) <-> (opp q, x + c_q) of q (odd) whose q end lies in row (y, z),
/// every pair with both slots in the extended grid (ghosts included): those whose value is
/// an interior cell's or a pulled ghost's, and those of two ghosts, where the kernel keeps
/// the x faces' ghosts of the rows next to a y or z face (a corner's fill reads them).
template <class T>
void swap_row_pairs(BasicPopulationField<T>& f, int q, int y, int z) {
  const GridLayout& lay = f.layout();
  const GridShape s = lay.shape();
  const int cx = D3Q19::cx[q], y2 = y + D3Q19::cy[q], z2 = z + D3Q19::cz[q];
  if (y2 < -1 || y2 > s.ny || z2 < -1 || z2 > s.nz) return;
  const int lo = std::max(-1, -1 - cx), hi = std::min(s.nx, s.nx - cx);
  T* const a = f.q(q) + lay.index(0, y, z);
  T* const b = f.q(D3Q19::opp[q]) + lay.index(0, y, z) + shift(lay, q);
  for (int x = lo; x <= hi; ++x) std::swap(a[x], b[x]);
}

/// Canonical <-> Swapped (PopulationLayout): swaps the slots (q, x) and (opp q, x + c_q) of
/// every pair in the extended grid (swap_row_pairs), once per pair (q odd). Each slot
/// belongs to one pair only: the rows run in parallel.
/// A grid wrapped along z (GridLayout::wraps_z) has the rows of its one plane only: its z
/// ghost rows are those rows, and a pair's other end is in the plane.
template <class T>
void swap_layout(BasicPopulationField<T>& f) {
  const GridShape s = f.layout().shape();
  const bool wrap = f.layout().wraps_z();
  const std::ptrdiff_t rows = std::ptrdiff_t(s.ny + 2) * (wrap ? 1 : s.nz + 2);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t r = 0; r < rows; ++r)
    for (int q = 1; q < D3Q19::Q; q += 2)
      swap_row_pairs(f, q, int(r % (s.ny + 2)) - 1, wrap ? 0 : int(r / (s.ny + 2)) - 1);
}

/// swap_layout restricted to what fill_ghosts_but_x reads and writes, Canonical <-> Swapped:
/// in the rows next to a y or z face (ghost rows included) the populations that cross that
/// face (c_y or c_z not 0; all 19 where a face of the axis reads them all: all_y, all_z),
/// with the partners of their pairs; the rest of the field as it is. Each such pair once: by
/// its q end where that row is one of them, else by the other end's row. A grid wrapped
/// along z has no z face to fill and the rows of its one plane only (swap_layout).
template <class T>
void swap_yz_shell(BasicPopulationField<T>& f, bool all_y, bool all_z) {
  const GridShape s = f.layout().shape();
  const bool wrap = f.layout().wraps_z();
  const auto near_y = [&](int y) { return y <= 0 || y >= s.ny - 1; };
  const auto near_z = [&](int z) { return !wrap && (z <= 0 || z >= s.nz - 1); };
  // Whether the fill touches population q (or opp q) in row (y, z).
  const auto touched = [&](int q, int y, int z) {
    return (near_y(y) && (all_y || D3Q19::cy[q] != 0)) || (near_z(z) && (all_z || D3Q19::cz[q] != 0));
  };
  const std::ptrdiff_t rows = std::ptrdiff_t(s.ny + 2) * (wrap ? 1 : s.nz + 2);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t r = 0; r < rows; ++r) {
    const int y = int(r % (s.ny + 2)) - 1, z = wrap ? 0 : int(r / (s.ny + 2)) - 1;
    if (!near_y(y) && !near_z(z)) continue;
    for (int q = 1; q < D3Q19::Q; q += 2) {
      const int dz = wrap ? 0 : D3Q19::cz[q];
      const int y1 = y + D3Q19::cy[q], z1 = z + dz;  // the other end's row
      if (touched(q, y, z) || touched(q, y1, z1)) swap_row_pairs(f, q, y, z);
      const int y0 = y - D3Q19::cy[q], z0 = z - dz;  // the pairs ending here
      if (y0 >= -1 && y0 <= s.ny && z0 >= -1 && z0 <= s.nz && !near_y(y0) && !near_z(z0) && touched(q, y, z))
        swap_row_pairs(f, q, y0, z0);
    }
  }
}

}  // namespace

/// layout_of, wrapped along z (GridLayout::wrapped_z) where the grid is one cell thick and
/// periodic along z in this process.
GridLayout FluidSolver::solver_layout(const FluidParams& p, const HaloExchange* halo) {
  const GridLayout l = layout_of(p.shape, p.precision);
  const bool z_halo = halo != nullptr && (halo->faces()[ZMin] || halo->faces()[ZMax]);
  const bool thin_periodic = p.shape.nz == 1 && p.faces[ZMin].kind == FaceKind::Periodic &&
                             p.faces[ZMax].kind == FaceKind::Periodic && !z_halo;
  return thin_periodic ? l.wrapped_z() : l;
}

const char* propagation_name(Propagation p) { return p == Propagation::TwoGrid ? "two-grid" : "in-place"; }

FluidSolver::FluidSolver(const FluidParams& params, HaloExchange* halo)
    : params_(params),
      layout_(solver_layout(params, halo)),
      halo_(halo),
      bc_(layout_, params.faces, halo != nullptr ? halo->faces() : std::array<bool, kFaces>{}, params.y_origin),
      x_faces_(bc_.in_place_x_faces()) {
  // The in-place propagation needs one grid.
  const bool two = params.propagation == Propagation::TwoGrid;
  with_fields([&](auto& f, auto& g) {
    using Field = std::remove_reference_t<decltype(f)>;
    f = Field(layout_);
    if (two) g = Field(layout_);
  });
  initialize_uniform(1.0, {0.0, 0.0, 0.0});
}

std::size_t FluidSolver::population_bytes() const {
  const std::size_t grids = params_.propagation == Propagation::InPlace ? 1 : 2;
  return grids * std::size_t(D3Q19::Q) * layout_.stride() * bytes_per_value(params_.precision);
}

void FluidSolver::make_canonical(const char* call) const {
  finish_rest();
  if (params_.propagation != Propagation::InPlace) return;
  if (mid_step_)
    throw std::logic_error(std::string("FluidSolver::") + call +
                           ": between begin_step() and finish_step() the in-place propagation holds no whole state");
  if (arrangement_ == PopulationLayout::Canonical) return;
  with_fields([](auto& f, auto&) { swap_layout(f); });
  arrangement_ = PopulationLayout::Canonical;
}

const PopulationField& FluidSolver::state() const {
  if (params_.precision != Precision::Double) wrong_precision("state()", params_.precision);
  make_canonical("state()");
  return f_;
}
void FluidSolver::fill_wall_ghosts_of_halo_cells(const std::array<bool, kFaces>& cells) {
  make_canonical("fill_wall_ghosts_of_halo_cells()");
  with_fields([&](auto& f, auto&) { bc_.fill_wall_ghosts_of_halo_cells(f, cells); });
}

PopulationField& FluidSolver::mutable_state() {
  if (params_.precision != Precision::Double) wrong_precision("mutable_state()", params_.precision);
  make_canonical("mutable_state()");
  have_previous_ = mid_step_ = false;
  return f_;
}
const PopulationFieldSingle& FluidSolver::state_single() const {
  if (!stores_floats(params_.precision)) wrong_precision("state_single()", params_.precision);
  make_canonical("state_single()");
  return fs_;
}
PopulationFieldSingle& FluidSolver::mutable_state_single() {
  if (!stores_floats(params_.precision))
    wrong_precision("mutable_state_single()", params_.precision);
  make_canonical("mutable_state_single()");
  have_previous_ = mid_step_ = false;
  return fs_;
}
const PopulationFieldHalf& FluidSolver::state_half() const {
  if (!stores_halves(params_.precision)) wrong_precision("state_half()", params_.precision);
  make_canonical("state_half()");
  return fh_;
}
PopulationFieldHalf& FluidSolver::mutable_state_half() {
  if (!stores_halves(params_.precision)) wrong_precision("mutable_state_half()", params_.precision);
  make_canonical("mutable_state_half()");
  have_previous_ = mid_step_ = false;
  return fh_;
}

const PopulationField& FluidSolver::previous_state() const {
  if (params_.precision != Precision::Double) wrong_precision("previous_state()", params_.precision);
  if (params_.propagation == Propagation::InPlace)
    throw std::logic_error("FluidSolver::previous_state(): the in-place propagation keeps no previous state");
  if (!have_previous_) throw std::logic_error("FluidSolver::previous_state(): no step() since the state was set");
  return g_;
}
const PopulationFieldSingle& FluidSolver::previous_state_single() const {
  if (!stores_floats(params_.precision)) wrong_precision("previous_state_single()", params_.precision);
  if (params_.propagation == Propagation::InPlace)
    throw std::logic_error("FluidSolver::previous_state_single(): the in-place propagation keeps no previous state");
  if (!have_previous_) throw std::logic_error("FluidSolver::previous_state_single(): no step() since the state was set");
  return gs_;
}
const PopulationFieldHalf& FluidSolver::previous_state_half() const {
  if (!stores_halves(params_.precision)) wrong_precision("previous_state_half()", params_.precision);
  if (params_.propagation == Propagation::InPlace)
    throw std::logic_error("FluidSolver::previous_state_half(): the in-place propagation keeps no previous state");
  if (!have_previous_) throw std::logic_error("FluidSolver::previous_state_half(): no step() since the state was set");
  return gh_;
}

const void* FluidSolver::state_data() const {
  make_canonical("state_data()");
  const void* p = nullptr;
  with_fields([&](const auto& f, const auto&) { p = f.q(0); });
  return p;
}
void* FluidSolver::mutable_state_data() {
  make_canonical("mutable_state_data()");
  have_previous_ = mid_step_ = false;
  void* p = nullptr;
  with_fields([&](auto& f, auto&) { p = f.q(0); });
  return p;
}

void FluidSolver::refresh_ghosts() {
  make_canonical("refresh_ghosts()");
  with_fields([&](auto& f, auto&) { bc_.fill_ghosts(f, halo_); });
}

void FluidSolver::initialize(const InitialState& state) {
  const GridShape& s = layout_.shape();
  have_previous_ = mid_step_ = false;
  arrangement_ = PopulationLayout::Canonical;
  rest_.clear();  // a whole new state
  rest_row_.clear();
  // One thread, x fastest: the callback may keep state (e.g. a random generator). Once per
  // run; a few tens of milliseconds on the paper's grid.
  with_fields([&](auto& f, auto& g) {
    using T = typename std::remove_reference_t<decltype(f)>::value_type;
    for (int z = 0; z < s.nz; ++z)
      for (int y = 0; y < s.ny; ++y)
        for (int x = 0; x < s.nx; ++x) {
          const CellState c = state(x, y, z);
          const std::ptrdiff_t i = layout_.index(x, y, z);
          for (int q = 0; q < D3Q19::Q; ++q)
            f.q(q)[i] = encode_population<T>(equilibrium(q, c.rho, c.ux, c.uy, c.uz), q);  // Eq. 11
        }
    bc_.fill_ghosts(f, halo_);
    if (!g.empty()) bc_.fill_static_ghosts(g);
  });
}

void FluidSolver::initialize_uniform(double rho, const std::array<double, 3>& u) {
  initialize([&](int, int, int) { return CellState{rho, u[0], u[1], u[2]}; });
}

void FluidSolver::set_inlet_scale(double s) {
  if (mid_step_) throw std::logic_error("FluidSolver::set_inlet_scale(): between begin_step() and finish_step()");
  finish_rest();
  if (s == bc_.inlet_scale()) return;
  bc_.set_inlet_scale(s);
  if (params_.propagation == Propagation::InPlace) {
    // The kernel writes the x faces' ghosts from the table; otherwise every fill is a whole
    // one (Fill::All) and reads the scale itself. A Canonical state's pulled ghosts now.
    if (arrangement_ == PopulationLayout::Canonical) with_fields([&](auto& f, auto&) { bc_.fill_static_ghosts(f); });
    return;
  }
  with_fields([&](auto& f, auto& g) {
    bc_.fill_static_ghosts(f);
    bc_.fill_static_ghosts(g);
  });
}

void FluidSolver::add_force(int x, int y, int z, double fx, double fy, double fz) {
  if (fx_.empty()) {
    fx_.assign(layout_.stride(), 0.0);
    fy_.assign(layout_.stride(), 0.0);
    fz_.assign(layout_.stride(), 0.0);
  }
  const std::ptrdiff_t i = layout_.index(x, y, z);
  if (fx_[i] == 0.0 && fy_[i] == 0.0 && fz_[i] == 0.0) {
    if (mid_step_ && params_.propagation == Propagation::InPlace)
      throw std::logic_error("FluidSolver::add_force: cell (" + std::to_string(x) + ", " + std::to_string(y) + ", " +
                             std::to_string(z) +
                             ") gets a force between begin_step() and finish_step(), and was not forced before "
                             "begin_step(): the in-place propagation kept no pulled populations of it (use the "
                             "two-grid propagation, or add the forces before begin_step())");
    forced_.push_back(i);
  }
  fx_[i] += fx;
  fy_[i] += fy;
  fz_[i] += fz;
}

void FluidSolver::step() {
  // A block's two-grid step sends its edge planes while it collides its interior ones; the
  // in-place step has one grid, whose edge planes the interior's collision would overwrite.
  // A block cut along y too sends its edge rows of every plane first: no overlap (its y
  // exchange needs the whole sweep).
  const bool y_halo = bc_.is_halo(YMin) || bc_.is_halo(YMax);
  if (halo_ != nullptr && bc_.has_halo() && !y_halo && layout_.nz() >= 3 &&
      params_.propagation == Propagation::TwoGrid) {
    with_fields([&](auto& f, auto& g) { step_overlapped(f, g); });
    return;
  }
  begin_step();
  finish_step();
}

void FluidSolver::begin_step() {
  if (mid_step_) throw std::logic_error("FluidSolver::begin_step(): the step begun before is not finished");
  finish_rest();
  with_fields([&](auto& f, auto& g) {
    if (params_.propagation == Propagation::InPlace)
      begin_in_place(f);
    else
      begin_fields(f, g);
  });
  mid_step_ = true;
  have_previous_ = false;  // the second grid now holds the bulk of the new state
}

void FluidSolver::finish_step() {
  if (!mid_step_) throw std::logic_error("FluidSolver::finish_step(): no step begun");
  with_fields([&](auto& f, auto& g) {
    if (params_.propagation == Propagation::InPlace)
      finish_in_place(f);
    else
      finish_fields(f, g);
  });
  mid_step_ = false;
  ++steps_;
}

template <class T>
void FluidSolver::copy_state_of(const BasicPopulationField<T>& f, BasicPopulationField<T>& to) const {
  if (to.layout().stride() != layout_.stride()) to = BasicPopulationField<T>(layout_);
  const std::size_t size = std::size_t(D3Q19::Q) * layout_.stride();
  std::copy(f.q(0), f.q(0) + size, to.q(0));
}

template <class T>
void FluidSolver::restore_state_of(const BasicPopulationField<T>& from, BasicPopulationField<T>& f,
                                   std::int64_t steps) {
  if (from.layout().stride() != layout_.stride())
    throw std::invalid_argument("FluidSolver::restore_state: a population field of another layout");
  const std::size_t size = std::size_t(D3Q19::Q) * layout_.stride();
  std::copy(from.q(0), from.q(0) + size, f.q(0));
  steps_ = steps;
  have_previous_ = mid_step_ = false;
  arrangement_ = PopulationLayout::Canonical;
}

// state() and the others throw std::logic_error for the other precision's field.
void FluidSolver::copy_state(PopulationField& to) const { copy_state_of(state(), to); }
void FluidSolver::copy_state(PopulationFieldSingle& to) const { copy_state_of(state_single(), to); }
void FluidSolver::restore_state(const PopulationField& from, std::int64_t steps) {
  restore_state_of(from, mutable_state(), steps);
}
void FluidSolver::restore_state(const PopulationFieldSingle& from, std::int64_t steps) {
  restore_state_of(from, mutable_state_single(), steps);
}
void FluidSolver::copy_state(PopulationFieldHalf& to) const { copy_state_of(state_half(), to); }
void FluidSolver::restore_state(const PopulationFieldHalf& from, std::int64_t steps) {
  restore_state_of(from, mutable_state_half(), steps);
}

template <class T>
void FluidSolver::begin_fields(const BasicPopulationField<T>& f, BasicPopulationField<T>& g) {
  // Boundaries (BoundaryConditions): the kernel writes the x outflows, the inlets stay from
  // fill_static_ghosts, the rest is filled after the swap.
  stream_collide(f, g, params_.tau, params_.body_force, Stores::Auto, bc_.kernel_outflow(), &extrema_, schedule_,
                 arithmetic_of(params_.precision));
}

template <class T>
void FluidSolver::finish_fields(BasicPopulationField<T>& f, BasicPopulationField<T>& g) {
  apply_local_forces(f, g);
  std::swap(f, g);
  bc_.fill_step_ghosts(f, halo_);
  have_previous_ = true;
}

template <class T>
void FluidSolver::apply_local_forces(const BasicPopulationField<T>& f,
                                     BasicPopulationField<T>& g) {
  // Cells that received an IB force are collided again from the same pulled populations
  // with the total force (Eq. 26); the bulk kernel stays free of a per-cell force array.
  if (forced_.empty()) return;
  const BgkGuo bgk(params_.tau);
  const auto& F = params_.body_force;
  const std::ptrdiff_t n = std::ptrdiff_t(forced_.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < n; ++k) {
    const std::ptrdiff_t i = forced_[k];
    double fc[D3Q19::Q];
    for (int q = 0; q < D3Q19::Q; ++q)
      fc[q] = decode_population(f.q(q)[i - layout_.offset(D3Q19::cx[q], D3Q19::cy[q], D3Q19::cz[q])], q);
    bgk.collide(fc, F[0] + fx_[i], F[1] + fy_[i], F[2] + fz_[i]);
    for (int q = 0; q < D3Q19::Q; ++q) g.q(q)[i] = encode_population<T>(fc[q], q);
  }
  // The kernel wrote the x-outflow ghosts from the cells as it collided them.
  const std::ptrdiff_t sx = layout_.row_stride(), plane = layout_.plane_stride();
  for (const std::ptrdiff_t i : forced_) {
    const int x = int(i % sx) - layout_.front_pad();
    if (x == 0 || x == layout_.nx() - 1)
      bc_.fill_outflow_ghost(g, x, int(i % plane / sx) - 1, int(i / plane) - 1);
  }
  for (const std::ptrdiff_t i : forced_) fx_[i] = fy_[i] = fz_[i] = 0.0;
  forced_.clear();
}

// Propagation::InPlace. A step from Canonical ends Swapped and the other way round; the
// collision is the two-grid kernel's (stream_collide.cpp), the forced cells' the same BgkGuo
// as apply_local_forces, the ghosts the same BoundaryConditions fills: the same bits as the
// two-grid step (test_lbm_invariants: InPlaceStepMatchesTwoGridStep).
template <class T>
void FluidSolver::begin_in_place(BasicPopulationField<T>& f, KernelRows rows) {
  // The forced cells' pulled populations, before the bulk overwrites them.
  const std::size_t cells = forced_.size();
  saved_inputs_.resize(cells * D3Q19::Q);
  const bool canonical = arrangement_ == PopulationLayout::Canonical;
  for (std::size_t k = 0; k < cells; ++k) {
    const std::ptrdiff_t i = forced_[k];
    for (int q = 0; q < D3Q19::Q; ++q)
      saved_inputs_[k * D3Q19::Q + q] =
          decode_population(canonical ? f.q(q)[i - shift(layout_, q)] : f.q(D3Q19::opp[q])[i], q);
  }
  stream_collide_in_place(f, arrangement_, params_.tau, params_.body_force, &extrema_, schedule_, &x_faces_,
                          arithmetic_of(params_.precision), rows);
  arrangement_ = canonical ? PopulationLayout::Swapped : PopulationLayout::Canonical;
}

template <class T>
void FluidSolver::finish_in_place(BasicPopulationField<T>& f) {
  if (!forced_.empty()) {
    const BgkGuo bgk(params_.tau);
    const auto& F = params_.body_force;
    const bool swapped = arrangement_ == PopulationLayout::Swapped;
    const std::ptrdiff_t n = std::ptrdiff_t(forced_.size());
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t k = 0; k < n; ++k) {
      const std::ptrdiff_t i = forced_[k];
      double fc[D3Q19::Q];
      std::copy_n(saved_inputs_.data() + k * D3Q19::Q, D3Q19::Q, fc);
      bgk.collide(fc, F[0] + fx_[i], F[1] + fy_[i], F[2] + fz_[i]);
      for (int q = 0; q < D3Q19::Q; ++q) {
        if (swapped)
          f.q(D3Q19::opp[q])[i + shift(layout_, q)] = encode_population<T>(fc[q], q);
        else
          f.q(q)[i] = encode_population<T>(fc[q], q);
      }
    }
    if (x_faces_.all()) {
      // The kernel wrote the x ghosts of the bulk's populations: those of a forced
      // boundary cell's row again.
      std::ptrdiff_t slot[D3Q19::Q];
      for (int q = 0; q < D3Q19::Q; ++q)
        slot[q] = swapped ? D3Q19::opp[q] * std::ptrdiff_t(layout_.stride()) + shift(layout_, q)
                          : q * std::ptrdiff_t(layout_.stride());
      const std::ptrdiff_t sx = layout_.row_stride(), plane = layout_.plane_stride();
      for (const std::ptrdiff_t i : forced_) {
        const int x = int(i % sx) - layout_.front_pad();
        if (x == 0 || x == layout_.nx() - 1)
          in_place_x_ghosts(f.q(0) + (i - x), slot, layout_.nx(), int(i % plane / sx) - 1, x_faces_);
      }
    }
    for (const std::ptrdiff_t i : forced_) fx_[i] = fy_[i] = fz_[i] = 0.0;
    forced_.clear();
  }
  if (arrangement_ == PopulationLayout::Swapped)
    fill_swapped_ghosts(f);
  else if (x_faces_.all())
    bc_.fill_ghosts_but_x(f, halo_);
  else
    bc_.fill_ghosts(f, halo_);
}

// The split step (step_reading). Why it gives the bits of step(): in an in-place step cell
// x reads its 19 pulled populations from its own slots and writes its collided ones back to
// them (stream_collide_in_place), and no two cells share a slot; the slots of the ghosts
// are no cell's. So the rows the first kernel call leaves still hold the state the step
// began from, whatever the first call, the forced cells' second collision (their rows are
// stepped first) and the ghost fill wrote, and finish_rest() collides them as the one
// call would have: a cell's bits do not depend on which rows share its call (KernelRows).
// The ghost fill of the faces y and z reads the post-collision values of the cells next to
// those faces (kRestMargin layers, all stepped first) and writes ghost slots only; the x
// faces' ghosts are the kernel's, row by row (InPlaceXFaces), so the rows left write
// theirs themselves. The kernel's extrema are merged from both calls (KernelExtrema::merge:
// min, max and "and" do not depend on the order).
void FluidSolver::step_reading(std::span<const std::array<int, 3>> read) {
  if (mid_step_) throw std::logic_error("FluidSolver::step_reading(): the step begun before is not finished");
  finish_rest();
  const int ny = layout_.ny(), nz = layout_.nz(), m = kRestMargin;
  if (params_.propagation != Propagation::InPlace || halo_ != nullptr || !x_faces_.all() || ny <= 2 * m ||
      nz <= 2 * m) {
    step();
    return;
  }
  // Which rows run first: the faces' margins, the rows the reads pull from, the forced cells'.
  const std::size_t rows = std::size_t(ny) * std::size_t(nz);
  std::vector<std::uint8_t>& first = rest_row_;
  first.assign(rows, 0);
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      if (y < m || y >= ny - m || z < m || z >= nz - m) first[std::size_t(y) + std::size_t(ny) * z] = 1;
  for (const std::array<int, 3>& c : read)
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy) {
        const int y = c[1] + dy, z = c[2] + dz;  // out of range: a face's row, stepped first
        if (y >= 0 && y < ny && z >= 0 && z < nz) first[std::size_t(y) + std::size_t(ny) * z] = 1;
      }
  const std::ptrdiff_t sx = layout_.row_stride(), plane = layout_.plane_stride();
  for (const std::ptrdiff_t i : forced_)
    first[std::size_t(i % plane / sx - 1) + std::size_t(ny) * std::size_t(i / plane - 1)] = 1;
  near_rows_.clear();
  std::vector<std::int32_t> rest;
  rest.reserve(rows);
  for (std::size_t r = 0; r < rows; ++r) (first[r] ? near_rows_ : rest).push_back(std::int32_t(r));
  if (rest.empty()) {
    step();
    return;
  }
  const bool from_canonical = arrangement_ == PopulationLayout::Canonical;
  const KernelRows near{near_rows_.data(), std::ptrdiff_t(near_rows_.size())};
  with_fields([&](auto& f, auto&) { begin_in_place(f, near); });
  mid_step_ = true;
  have_previous_ = false;
  finish_step();  // the forced cells, the ghosts (they read the rows stepped)
  rest_ = std::move(rest);
  rest_from_canonical_ = from_canonical;
  for (std::size_t r = 0; r < rows; ++r) first[r] = !first[r];  // now: the rows left
}

void FluidSolver::finish_rest() const {
  if (rest_.empty()) return;
  KernelExtrema part;
  const KernelRows rows{rest_.data(), std::ptrdiff_t(rest_.size())};
  const PopulationLayout from = rest_from_canonical_ ? PopulationLayout::Canonical : PopulationLayout::Swapped;
  with_fields([&](auto& f, const auto&) {
    stream_collide_in_place(f, from, params_.tau, params_.body_force, &part, schedule_, &x_faces_,
                            arithmetic_of(params_.precision), rows);
  });
  extrema_.merge(part);
  rest_.clear();
  rest_row_.clear();
}

void FluidSolver::check_not_left(int x, int y, int z) const {
  const int ny = layout_.ny(), nz = layout_.nz();
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy) {
      const int yy = y + dy, zz = z + dz;
      if (yy >= 0 && yy < ny && zz >= 0 && zz < nz && rest_row_[std::size_t(yy) + std::size_t(ny) * zz])
        throw std::logic_error("FluidSolver::populations_at(" + std::to_string(x) + ", " + std::to_string(y) +
                               ", " + std::to_string(z) +
                               "): the cell pulls from a row left for finish_rest() (not among step_reading()'s "
                               "cells)");
    }
}

/// The ghosts of a Swapped state: every slot A[opp q](y) of an interior y whose y - c_q is a
/// ghost gets the value that fill_ghosts puts at ghost (q, y - c_q) of the Canonical state.
/// The one fill does it, on the field itself. In one process it addresses the Swapped
/// slots as the Canonical ones (BoundaryConditions::fill_swapped_ghosts): each value's slot
/// is the other end of its pair. A block with halo faces (MPI) turns the part of the field
/// the fill reads and writes Canonical instead (swap_layout is its own inverse), fills, and
/// turns it back, since its exchange sends planes of the field as it is: where the kernel
/// wrote the x faces' ghosts (InPlaceXFaces::all), that part is the rows next to a y or z
/// face (swap_yz_shell) and fill_ghosts_but_x fills their ghosts; else (reflecting x faces)
/// the whole field, twice a pass.
template <class T>
void FluidSolver::fill_swapped_ghosts(BasicPopulationField<T>& f) const {
  if (!bc_.has_halo()) {
    // Without a halo the fill runs on the Swapped slots directly (PopulationSlots): the
    // same bits, without the two turns of the shell (2.4 % of the paper grid's in-place
    // step in perf; docs/performance.md).
    bc_.fill_swapped_ghosts(f, !x_faces_.all());
    return;
  }
  if (!x_faces_.all()) {
    swap_layout(f);
    bc_.fill_ghosts(f, halo_);
    swap_layout(f);
    return;
  }
  const bool all_y = bc_.reads_every_population(YMin) || bc_.reads_every_population(YMax);
  const bool all_z = bc_.reads_every_population(ZMin) || bc_.reads_every_population(ZMax);
  swap_yz_shell(f, all_y, all_z);
  bc_.fill_ghosts_but_x(f, halo_);
  swap_yz_shell(f, all_y, all_z);
}

template <class T>
void FluidSolver::populations_of(const BasicPopulationField<T>& f, int x, int y, int z,
                                 double* out) const {
  const std::ptrdiff_t i = layout_.index(x, y, z);
  if (arrangement_ == PopulationLayout::Swapped) {
    // f_q(x) = f*_q(x - c_q), kept at A[opp q](x) (ghosts included: fill_swapped_ghosts).
    for (int q = 0; q < D3Q19::Q; ++q) out[q] = decode_population(f.q(D3Q19::opp[q])[i], q);
    return;
  }
  for (int q = 0; q < D3Q19::Q; ++q)
    out[q] = decode_population(f.q(q)[i - layout_.offset(D3Q19::cx[q], D3Q19::cy[q], D3Q19::cz[q])], q);
}

void FluidSolver::populations_at(int x, int y, int z, double* f) const {
  if (mid_step_ && params_.propagation == Propagation::InPlace) make_canonical("populations_at()");  // throws
  if (!rest_.empty()) check_not_left(x, y, z);
  with_fields([&](const auto& field, const auto&) { populations_of(field, x, y, z, f); });
}

CellState FluidSolver::cell(int x, int y, int z) const {
  double f[D3Q19::Q];
  populations_at(x, y, z, f);
  const Moments m = moments(f);
  const auto& F = params_.body_force;
  const double inv = 1.0 / m.rho;
  return {m.rho, (m.jx + 0.5 * F[0]) * inv, (m.jy + 0.5 * F[1]) * inv, (m.jz + 0.5 * F[2]) * inv};
}

void FluidSolver::macroscopic(MacroscopicFields& out) const {
  const GridShape& s = layout_.shape();
  out.shape = s;
  const std::size_t n = std::size_t(s.cells());
  out.rho.resize(n);
  out.ux.resize(n);
  out.uy.resize(n);
  out.uz.resize(n);
  macroscopic(out, 0);
}

void FluidSolver::macroscopic(MacroscopicFields& out, int z_at) const {
  if (out.shape.ny != layout_.ny()) throw std::invalid_argument("FluidSolver::macroscopic: fields of another shape");
  macroscopic(out, 0, z_at);
}

void FluidSolver::macroscopic(MacroscopicFields& out, int y_at, int z_at) const {
  finish_rest();  // before the threads read
  const GridShape& s = layout_.shape();
  const std::size_t n = std::size_t(out.shape.cells());
  if (out.shape.nx != s.nx || y_at < 0 || out.shape.ny < y_at + s.ny || z_at < 0 || out.shape.nz < z_at + s.nz ||
      out.rho.size() != n ||
      out.ux.size() != n || out.uy.size() != n || out.uz.size() != n)
    throw std::invalid_argument("FluidSolver::macroscopic: fields of another shape");
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < s.nz; ++z)
    for (int y = 0; y < s.ny; ++y)
      for (int x = 0; x < s.nx; ++x) {
        const CellState c = cell(x, y, z);
        const std::size_t i = out.index(x, y + y_at, z + z_at);
        out.rho[i] = c.rho;
        out.ux[i] = c.ux;
        out.uy[i] = c.uy;
        out.uz[i] = c.uz;
      }
}

// For the overlapped step of a block (fluid/solver/overlapped_step.cpp).
template void FluidSolver::apply_local_forces(const PopulationField&, PopulationField&);
template void FluidSolver::apply_local_forces(const PopulationFieldSingle&, PopulationFieldSingle&);
template void FluidSolver::apply_local_forces(const PopulationFieldHalf&, PopulationFieldHalf&);

}  // namespace cosim::fluid
