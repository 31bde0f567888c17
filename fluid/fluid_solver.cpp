#include "fluid/fluid_solver.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "fluid/bgk_guo.hpp"
#include "fluid/d3q19.hpp"
#include "fluid/equilibrium.hpp"
#include "fluid/stream_collide.hpp"

namespace cosim::fluid {

namespace {

[[noreturn]] void wrong_precision(const char* call, Precision stored) {
  throw std::logic_error(std::string(__FILE__) + ": FluidSolver::" + call +
                         ": the populations are stored in " + precision_name(stored) +
                         " precision; use the accessor of that precision, or populations_at()");
}

}  // namespace

FluidSolver::FluidSolver(const FluidParams& params, HaloExchange* halo)
    : params_(params),
      layout_(layout_of(params.shape, params.precision)),
      halo_(halo),
      bc_(layout_, params.faces, halo != nullptr ? halo->faces() : std::array<bool, kFaces>{}) {
  if (params.precision == Precision::Double) {
    f_ = PopulationField(layout_);
    g_ = PopulationField(layout_);
  } else {
    fs_ = PopulationFieldSingle(layout_);
    gs_ = PopulationFieldSingle(layout_);
  }
  initialize_uniform(1.0, {0.0, 0.0, 0.0});
}

std::size_t FluidSolver::population_bytes() const {
  return 2 * std::size_t(D3Q19::Q) * layout_.stride() * bytes_per_value(params_.precision);
}

const PopulationField& FluidSolver::state() const {
  if (params_.precision != Precision::Double) wrong_precision("state()", params_.precision);
  return f_;
}
PopulationField& FluidSolver::mutable_state() {
  if (params_.precision != Precision::Double) wrong_precision("mutable_state()", params_.precision);
  have_previous_ = mid_step_ = false;
  return f_;
}
const PopulationFieldSingle& FluidSolver::state_single() const {
  if (params_.precision != Precision::Single) wrong_precision("state_single()", params_.precision);
  return fs_;
}
PopulationFieldSingle& FluidSolver::mutable_state_single() {
  if (params_.precision != Precision::Single)
    wrong_precision("mutable_state_single()", params_.precision);
  have_previous_ = mid_step_ = false;
  return fs_;
}

const PopulationField& FluidSolver::previous_state() const {
  if (params_.precision != Precision::Double) wrong_precision("previous_state()", params_.precision);
  if (!have_previous_) throw std::logic_error("FluidSolver::previous_state(): no step() since the state was set");
  return g_;
}
const PopulationFieldSingle& FluidSolver::previous_state_single() const {
  if (params_.precision != Precision::Single) wrong_precision("previous_state_single()", params_.precision);
  if (!have_previous_) throw std::logic_error("FluidSolver::previous_state_single(): no step() since the state was set");
  return gs_;
}

void FluidSolver::refresh_ghosts() {
  if (params_.precision == Precision::Double)
    bc_.fill_ghosts(f_, halo_);
  else
    bc_.fill_ghosts(fs_, halo_);
}

void FluidSolver::initialize(const InitialState& state) {
  const GridShape& s = layout_.shape();
  const bool dbl = params_.precision == Precision::Double;
  have_previous_ = mid_step_ = false;
  // One thread, x fastest: the callback may keep state (e.g. a random generator). Once per
  // run; a few tens of milliseconds on the paper's grid.
  for (int z = 0; z < s.nz; ++z)
    for (int y = 0; y < s.ny; ++y)
      for (int x = 0; x < s.nx; ++x) {
        const CellState c = state(x, y, z);
        const std::ptrdiff_t i = layout_.index(x, y, z);
        for (int q = 0; q < D3Q19::Q; ++q) {
          const double feq = equilibrium(q, c.rho, c.ux, c.uy, c.uz);  // Eq. 11
          if (dbl)
            f_.q(q)[i] = feq;
          else
            fs_.q(q)[i] = static_cast<float>(feq);
        }
      }
  if (dbl) {
    bc_.fill_ghosts(f_, halo_);
    bc_.fill_static_ghosts(g_);
  } else {
    bc_.fill_ghosts(fs_, halo_);
    bc_.fill_static_ghosts(gs_);
  }
}

void FluidSolver::initialize_uniform(double rho, const std::array<double, 3>& u) {
  initialize([&](int, int, int) { return CellState{rho, u[0], u[1], u[2]}; });
}

void FluidSolver::add_force(int x, int y, int z, double fx, double fy, double fz) {
  if (fx_.empty()) {
    fx_.assign(layout_.stride(), 0.0);
    fy_.assign(layout_.stride(), 0.0);
    fz_.assign(layout_.stride(), 0.0);
  }
  const std::ptrdiff_t i = layout_.index(x, y, z);
  if (fx_[i] == 0.0 && fy_[i] == 0.0 && fz_[i] == 0.0) forced_.push_back(i);
  fx_[i] += fx;
  fy_[i] += fy;
  fz_[i] += fz;
}

void FluidSolver::step() {
  if (halo_ != nullptr && bc_.has_halo() && layout_.nz() >= 3) {
    if (params_.precision == Precision::Double)
      step_overlapped(f_, g_);
    else
      step_overlapped(fs_, gs_);
    return;
  }
  begin_step();
  finish_step();
}

void FluidSolver::begin_step() {
  if (mid_step_) throw std::logic_error("FluidSolver::begin_step(): the step begun before is not finished");
  if (params_.precision == Precision::Double)
    begin_fields(f_, g_);
  else
    begin_fields(fs_, gs_);
  mid_step_ = true;
  have_previous_ = false;  // the second grid now holds the bulk of the new state
}

void FluidSolver::finish_step() {
  if (!mid_step_) throw std::logic_error("FluidSolver::finish_step(): no step begun");
  if (params_.precision == Precision::Double)
    finish_fields(f_, g_);
  else
    finish_fields(fs_, gs_);
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

template <class T>
void FluidSolver::begin_fields(const BasicPopulationField<T>& f, BasicPopulationField<T>& g) {
  // Boundaries (BoundaryConditions): the kernel writes the x outflows, the inlets stay from
  // fill_static_ghosts, the rest is filled after the swap.
  stream_collide(f, g, params_.tau, params_.body_force, Stores::Auto, bc_.kernel_outflow(), &extrema_, schedule_);
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
      fc[q] = f.q(q)[i - layout_.offset(D3Q19::cx[q], D3Q19::cy[q], D3Q19::cz[q])];
    bgk.collide(fc, F[0] + fx_[i], F[1] + fy_[i], F[2] + fz_[i]);
    for (int q = 0; q < D3Q19::Q; ++q) g.q(q)[i] = static_cast<T>(fc[q]);
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

template <class T>
void FluidSolver::populations_of(const BasicPopulationField<T>& f, int x, int y, int z,
                                 double* out) const {
  const std::ptrdiff_t i = layout_.index(x, y, z);
  for (int q = 0; q < D3Q19::Q; ++q)
    out[q] = f.q(q)[i - layout_.offset(D3Q19::cx[q], D3Q19::cy[q], D3Q19::cz[q])];
}

void FluidSolver::populations_at(int x, int y, int z, double* f) const {
  if (params_.precision == Precision::Double)
    populations_of(f_, x, y, z, f);
  else
    populations_of(fs_, x, y, z, f);
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
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < s.nz; ++z)
    for (int y = 0; y < s.ny; ++y)
      for (int x = 0; x < s.nx; ++x) {
        const CellState c = cell(x, y, z);
        const std::size_t i = out.index(x, y, z);
        out.rho[i] = c.rho;
        out.ux[i] = c.ux;
        out.uy[i] = c.uy;
        out.uz[i] = c.uz;
      }
}

// For the overlapped step of a block (fluid/overlapped_step.cpp).
template void FluidSolver::apply_local_forces(const PopulationField&, PopulationField&);
template void FluidSolver::apply_local_forces(const PopulationFieldSingle&, PopulationFieldSingle&);

}  // namespace cosim::fluid
