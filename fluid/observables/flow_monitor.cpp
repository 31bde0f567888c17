#include "fluid/observables/flow_monitor.hpp"

#include <algorithm>
#include <cmath>
#include <array>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <utility>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/equilibrium.hpp"

namespace cosim::fluid {

namespace {

using L = D3Q19;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Running extremum with its cell; ties to the smaller linear index.
struct Extremum {
  double value;
  std::int64_t index = std::numeric_limits<std::int64_t>::max();
  void take_min(double v, std::int64_t i) {
    if (v < value || (v == value && i < index)) set(v, i);
  }
  void take_max(double v, std::int64_t i) {
    if (v > value || (v == value && i < index)) set(v, i);
  }
  void set(double v, std::int64_t i) {
    value = v;
    index = i;
  }
};

/// What one thread gathers over its rows.
struct Partial {
  Extremum u2max{-1.0};
  Extremum rmin{kInf};
  Extremum rmax{-kInf};
  std::int64_t nan_index = std::numeric_limits<std::int64_t>::max();
  CellState nan_state;
};

/// rho (Eq. 7) and rho u = sum_a c_a f_a + F/2 (Eq. 8 with Guo's shift) of the cell x of a
/// row whose pulled populations f_q(x) = state_q(x - c_q) start at s[q].
template <class T>
inline Moments pulled_moments(const T* const* s, int x, const double* hF) {
  Moments m;
#pragma GCC unroll 19
  for (int q = 0; q < L::Q; ++q) {
    const double v = decode_population(s[q][x], q);
    m.rho += v;
    m.jx += L::cx[q] * v;
    m.jy += L::cy[q] * v;
    m.jz += L::cz[q] * v;
  }
  m.jx += hF[0];
  m.jy += hF[1];
  m.jz += hF[2];
  return m;
}

/// The reference: one row cell by cell into the thread's extrema and first non-finite cell
/// (the row's sums come from the vectorised pass alone, see summarize()).
template <class T>
void scan_row(Partial& p, const T* const* s, int nx, std::int64_t row0, const double* hF) {
  for (int x = 0; x < nx; ++x) {
    const Moments c = pulled_moments(s, x, hF);
    const double inv = 1.0 / c.rho;
    const double ux = c.jx * inv, uy = c.jy * inv, uz = c.jz * inv;
    const std::int64_t i = row0 + x;
    if (!(std::isfinite(c.rho) && std::isfinite(ux) && std::isfinite(uy) && std::isfinite(uz))) {
      if (i < p.nan_index) {
        p.nan_index = i;
        p.nan_state = {c.rho, ux, uy, uz};
      }
      continue;
    }
    p.u2max.take_max(ux * ux + uy * uy + uz * uz, i);
    p.rmin.take_min(c.rho, i);
    p.rmax.take_max(c.rho, i);
  }
}

CellIndex cell_of(std::int64_t i, const GridShape& s) {
  if (i == std::numeric_limits<std::int64_t>::max()) return {};
  const std::int64_t nx = s.nx, ny = s.ny;
  return {int(i % nx), int((i / nx) % ny), int(i / (nx * ny))};
}

std::string cell_prefix(const FlowSummary& s, const CellIndex& c) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "step %lld: cell (%d, %d, %d): ", static_cast<long long>(s.step),
                c.x, c.y, c.z);
  return buf;
}

const char* non_finite_name(double v) {
  if (std::isnan(v)) return "NaN";
  return v > 0 ? "+inf" : "-inf";
}

/// The partials of `f`, a state of `solver` (a block whose first cell is `first_cell` of the
/// whole grid).
template <class T>
FlowPartials partials_of_field(const FluidSolver& solver, const BasicPopulationField<T>& f,
                               std::int64_t first_cell, int whole_ny) {
  const GridLayout& lay = f.layout();
  const GridShape& shape = solver.shape();
  const int nx = shape.nx, ny = shape.ny;
  const std::ptrdiff_t rows = std::ptrdiff_t(ny) * shape.nz;
  // Velocity as FluidSolver::cell: u = (sum_a c_a f_a + F/2) / rho (Eqs. 7-8, Guo).
  const auto& F = solver.body_force();
  const double hF[3] = {0.5 * F[0], 0.5 * F[1], 0.5 * F[2]};

  // The sums are added per row, and the rows in row order after the parallel loop, so
  // that they do not depend on the number of threads or on the order in which the threads
  // finish: bit-identical runs (DESIGN 2.3). The extrema are order-independent (ties go to
  // the lower cell index).
  std::vector<std::array<double, 4>> row_sums(static_cast<std::size_t>(rows));
  Partial total;
#pragma omp parallel
  {
    Partial p;
#pragma omp for schedule(static) nowait
    for (std::ptrdiff_t r = 0; r < rows; ++r) {
      const int y = int(r % ny), z = int(r / ny);
      const std::ptrdiff_t base = lay.index(0, y, z);
      // Pull: f_q(x) = state_q(x - c_q), as in the stream-collide kernel.
      const T* s[L::Q];
#pragma GCC unroll 19
      for (int q = 0; q < L::Q; ++q) s[q] = f.q(q) + base - lay.offset(L::cx[q], L::cy[q], L::cz[q]);
      const std::int64_t row0 = first_cell + (std::int64_t(z) * whole_ny + y) * nx;
      // Fast path, vectorised along x: the row's sums and extrema, and a flag that is NaN
      // when any rho or u of the row is not finite (0 * inf and 0 * NaN are NaN).
      double mass = 0, mx = 0, my = 0, mz = 0, u2max = -1.0, rmin = kInf, rmax = -kInf, bad = 0;
#pragma omp simd reduction(+ : mass, mx, my, mz, bad) reduction(max : u2max, rmax) reduction(min : rmin)
      for (int x = 0; x < nx; ++x) {
        const Moments c = pulled_moments(s, x, hF);
        const double inv = 1.0 / c.rho;
        const double ux = c.jx * inv, uy = c.jy * inv, uz = c.jz * inv;
        mass += c.rho;
        mx += c.jx;
        my += c.jy;
        mz += c.jz;
        bad += 0.0 * (c.rho + ux + uy + uz);
        const double u2 = ux * ux + uy * uy + uz * uz;
        u2max = u2max > u2 ? u2max : u2;
        rmin = rmin < c.rho ? rmin : c.rho;
        rmax = rmax > c.rho ? rmax : c.rho;
      }
      // A row that holds a non-finite value or beats this thread's extrema is redone cell
      // by cell (std::isfinite, and the cell of each extremum); that is rare after the
      // first rows. Strict comparisons: on ties the earlier cell stays.
      if (bad != 0.0 || u2max > p.u2max.value || rmin < p.rmin.value || rmax > p.rmax.value)
        scan_row(p, s, nx, row0, hF);
      row_sums[static_cast<std::size_t>(r)] = {mass, mx, my, mz};
    }
#pragma omp critical(cosim_fluid_summarize)
    {
      total.u2max.take_max(p.u2max.value, p.u2max.index);
      total.rmin.take_min(p.rmin.value, p.rmin.index);
      total.rmax.take_max(p.rmax.value, p.rmax.index);
      if (p.nan_index < total.nan_index) {
        total.nan_index = p.nan_index;
        total.nan_state = p.nan_state;
      }
    }
  }

  FlowPartials out;
  out.row_sums = std::move(row_sums);
  out.u2_max = total.u2max.value;
  out.u2_max_cell = total.u2max.index;
  out.rho_min = total.rmin.value;
  out.rho_min_cell = total.rmin.index;
  out.rho_max = total.rmax.value;
  out.rho_max_cell = total.rmax.index;
  out.nan_cell = total.nan_index;
  out.nan_state = total.nan_state;
  return out;
}

FlowPartials partials_of(const FluidSolver& solver, bool previous, std::int64_t first_cell, int whole_ny) {
  if (solver.precision() == Precision::Double)
    return partials_of_field(solver, previous ? solver.previous_state() : solver.state(), first_cell, whole_ny);
  if (stores_halves(solver.precision()))
    return partials_of_field(solver, previous ? solver.previous_state_half() : solver.state_half(), first_cell,
                             whole_ny);
  return partials_of_field(solver, previous ? solver.previous_state_single() : solver.state_single(), first_cell,
                           whole_ny);
}

}  // namespace

void FlowPartials::merge_extrema(const FlowPartials& o) {
  Extremum u2{u2_max, u2_max_cell}, lo{rho_min, rho_min_cell}, hi{rho_max, rho_max_cell};
  u2.take_max(o.u2_max, o.u2_max_cell);
  lo.take_min(o.rho_min, o.rho_min_cell);
  hi.take_max(o.rho_max, o.rho_max_cell);
  u2_max = u2.value, u2_max_cell = u2.index;
  rho_min = lo.value, rho_min_cell = lo.index;
  rho_max = hi.value, rho_max_cell = hi.index;
  if (o.nan_cell < nan_cell) {
    nan_cell = o.nan_cell;
    nan_state = o.nan_state;
  }
}

FlowPartials flow_partials(const FluidSolver& block, bool previous, std::int64_t first_cell, int whole_ny) {
  return partials_of(block, previous, first_cell, whole_ny > 0 ? whole_ny : block.shape().ny);
}

FlowSummary flow_summary(const FlowPartials& p, const GridShape& shape, std::int64_t step) {
  double mass = 0, mx = 0, my = 0, mz = 0;
  // The rows in row order (DESIGN 2.3: bit-identical whatever the threads or the ranks).
  for (const auto& r : p.row_sums) {
    mass += r[0];
    mx += r[1];
    my += r[2];
    mz += r[3];
  }
  FlowSummary out;
  out.step = step;
  out.mass = mass;
  out.momentum = {mx, my, mz};
  const bool any_finite = p.rho_min_cell != FlowPartials::kNone;
  out.max_mach = any_finite ? std::sqrt(p.u2_max / L::cs2) : 0.0;
  out.max_mach_cell = cell_of(p.u2_max_cell, shape);
  out.rho_min = any_finite ? p.rho_min : 0.0;
  out.rho_min_cell = cell_of(p.rho_min_cell, shape);
  out.rho_max = any_finite ? p.rho_max : 0.0;
  out.rho_max_cell = cell_of(p.rho_max_cell, shape);
  out.has_nan = p.nan_cell != FlowPartials::kNone;
  out.nan_cell = cell_of(p.nan_cell, shape);
  out.nan_state = p.nan_state;
  return out;
}

FlowSummary summarize(const FluidSolver& solver) {
  return flow_summary(partials_of(solver, false, 0, solver.shape().ny), solver.shape(), solver.step_count());
}

bool kernel_extrema_suspect(const KernelExtrema& e, const HealthLimits& limits) {
  const auto near_or_past = [](double v, double bound, int side) {  // side: +1 above, -1 below
    const double slack = 1e-12 * std::max(1.0, std::abs(bound));
    return side > 0 ? v >= bound - slack : v <= bound + slack;
  };
  const double u2_limit = limits.mach_limit * limits.mach_limit * L::cs2;
  const bool suspect = !e.finite || near_or_past(e.rho_min, limits.rho_floor, -1) ||
                       near_or_past(e.rho_min, limits.rho_min, -1) ||
                       (std::isfinite(limits.rho_max) && near_or_past(e.rho_max, limits.rho_max, +1)) ||
                       near_or_past(e.u2_max, u2_limit, +1);
  return suspect;
}

std::string kernel_state_problem(const FluidSolver& solver, const HealthLimits& limits) {
  if (!kernel_extrema_suspect(solver.last_step_extrema(), limits)) return {};
  // Mid-step, or where no previous state is kept (the in-place propagation): the state now.
  if (solver.mid_step() || !solver.has_previous_state()) return health_problem(summarize(solver), limits);
  const std::int64_t before = solver.step_count() - 1;
  return health_problem(flow_summary(partials_of(solver, true, 0, solver.shape().ny), solver.shape(), before), limits);
}

std::string health_problem(const FlowSummary& s, const HealthLimits& limits) {
  char buf[128];
  if (s.has_nan) {
    const CellState& c = s.nan_state;
    const char* what = !std::isfinite(c.rho)  ? "rho"
                       : !std::isfinite(c.ux) ? "u_x"
                       : !std::isfinite(c.uy) ? "u_y"
                                              : "u_z";
    const double v = !std::isfinite(c.rho)  ? c.rho
                     : !std::isfinite(c.ux) ? c.ux
                     : !std::isfinite(c.uy) ? c.uy
                                            : c.uz;
    return cell_prefix(s, s.nan_cell) + what + " is " + non_finite_name(v);
  }
  if (s.rho_min_cell.x >= 0 && s.rho_min <= limits.rho_floor) {
    std::snprintf(buf, sizeof buf, "rho = %.4g <= %g", s.rho_min, limits.rho_floor);
    return cell_prefix(s, s.rho_min_cell) + buf;
  }
  if (s.rho_min_cell.x >= 0 && s.rho_min < limits.rho_min) {
    std::snprintf(buf, sizeof buf, "rho = %.4g below watchdog.rho_min = %g", s.rho_min, limits.rho_min);
    return cell_prefix(s, s.rho_min_cell) + buf;
  }
  if (s.rho_max_cell.x >= 0 && s.rho_max > limits.rho_max) {
    std::snprintf(buf, sizeof buf, "rho = %.4g above watchdog.rho_max = %g", s.rho_max, limits.rho_max);
    return cell_prefix(s, s.rho_max_cell) + buf;
  }
  if (s.max_mach_cell.x >= 0 && s.max_mach > limits.mach_limit) {
    std::snprintf(buf, sizeof buf, "Mach %.3g above the limit %g", s.max_mach, limits.mach_limit);
    return cell_prefix(s, s.max_mach_cell) + buf;
  }
  return {};
}

}  // namespace cosim::fluid
