// Fluid throughput benchmark (DESIGN 7): million lattice updates per second (MLUPS) of
// FluidSolver::step() on a periodic box and on the paper's channel grid, against one
// memory-bandwidth roofline per run (the best STREAM copy of every kernel level this CPU runs,
// measured once before the rows, the same for every row: Roofline), and the fraction of it
// reached; the immersed boundary of the paper's sheet (200 markers: interpolation,
// spreading and a step with the spread forces) timed on its own; the precision modes double,
// mixed, single, half; optionally the peer pattern (--peer-pattern: a minimal in-place AA-pattern D3Q19 BGK
// kernel, fluid/app/bench_kernels.hpp; with a float store also in float arithmetic) on the same
// grid in the same run. Prints the CPU model and
// the kernel level it ran (fluid/collision/kernel_dispatch.hpp), then a plain table of medians; see
// docs/performance.md.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "common/text/cli_parse.hpp"
#include "common/run/exit_codes.hpp"
#include "fluid/app/bench_kernels.hpp"
#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/equilibrium.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/ib/immersed_boundary.hpp"
#include "fluid/collision/kernel_dispatch.hpp"
#include "fluid/collision/stream_collide.hpp"

#define COSIM_DECLARE_BENCH_TABLE(ns, name) \
  namespace cosim::fluid::isa_##ns {        \
  extern const BenchKernels bench_kernel_table; \
  }
COSIM_FOR_EACH_ISA_LEVEL(COSIM_DECLARE_BENCH_TABLE)
#undef COSIM_DECLARE_BENCH_TABLE

namespace cosim::fluid {

/// The yardsticks of level `level` (an index into kernel_levels()).
const BenchKernels& bench_kernels_of(int level) {
#define COSIM_BENCH_TABLE_ADDRESS(ns, name) &isa_##ns::bench_kernel_table,
  static const BenchKernels* const tables[] = {COSIM_FOR_EACH_ISA_LEVEL(COSIM_BENCH_TABLE_ADDRESS)};
#undef COSIM_BENCH_TABLE_ADDRESS
  return *tables[level];
}

const BenchKernels& bench_kernels() { return bench_kernels_of(active_kernel_index()); }

namespace {

/// Bytes per lattice update counted the way STREAM counts copy traffic: 19 values read and
/// 19 written (write-allocate not counted, as STREAM does not count it): 304 for the double
/// store, 152 for the single one.
double bytes_per_update(Precision p) { return 2.0 * D3Q19::Q * double(bytes_per_value(p)); }

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Case {
  std::string name;
  FluidParams params;
};

/// A periodic cube of n^3 cells (started with a small uniform drift, see measure).
Case periodic_box(int n) {
  Case c{"box " + std::to_string(n) + "^3 periodic", {}};
  c.params.shape = {n, n, n};
  c.params.tau = 0.6;
  return c;
}

/// The paper's grid: 120 x 60 x 90, Blasius inlet (U = 0.104, delta = 3.4 cells) on x_min,
/// outflow on x_max, a wall on y_min, free slip on y_max, periodic in z.
Case paper_channel() {
  return Case{"paper 120x60x90", blasius_channel({120, 60, 90}, 0.6, 0.104, 3.4)};
}

/// Bytes of one population field (19 populations with ghosts) of a grid.
std::size_t field_bytes(const Case& c, Precision p) {
  return std::size_t(D3Q19::Q) * layout_of(c.params.shape, p).stride() * bytes_per_value(p);
}

/// The paper's single sheet at 90 deg as immersed-boundary markers (lattice units): 5 x 40
/// CGPs, spacing 0.24 um across (z) and 0.22 um up (y) at dx = 0.2561 um, the bottom row on
/// the plate (y = -1/2), a quarter of the way down the channel, centred in z
/// (scenes/paper/single_theta90_re40.toml).
std::vector<Vec3> paper_sheet_markers(const GridShape& g) {
  constexpr double dx_um = 0.2561, across = 0.24 / dx_um, up = 0.22 / dx_um;
  std::vector<Vec3> X;
  for (int j = 0; j < 40; ++j)
    for (int i = 0; i < 5; ++i)
      X.push_back({0.25 * g.nx, -0.5 + up * (j + 0.5), 0.5 * g.nz + across * (i - 2)});
  return X;
}

/// STREAM "copy" b[i] = a[i] with the loads and stores of a level (fluid/app/bench_kernels.hpp),
/// OpenMP static schedule like the kernel. Returns bytes/s counted as STREAM does (16 B per
/// element, write-allocate traffic not counted).
class CopyBench {
 public:
  explicit CopyBench(std::size_t n) : n_((n + 7) / 8 * 8), a_(alloc(n_)), b_(alloc(n_)) {
    double* a = a_.get();
    double* b = b_.get();
    const std::ptrdiff_t m = std::ptrdiff_t(n_);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < m; ++i) a[i] = 1.0, b[i] = 0.0;
  }
  std::size_t bytes_per_array() const { return n_ * sizeof(double); }

  double run(bool streaming, const BenchKernels& level) {
    const auto t0 = Clock::now();
    level.copy(a_.get(), b_.get(), std::ptrdiff_t(n_), streaming);
    return 2.0 * double(bytes_per_array()) / seconds_since(t0);
  }

 private:
  struct Free {
    void operator()(double* p) const { std::free(p); }
  };
  using Array = std::unique_ptr<double, Free>;
  static Array alloc(std::size_t n) {
    void* p = std::aligned_alloc(64, n * sizeof(double));
    if (p == nullptr) throw std::bad_alloc();
    return Array(static_cast<double*>(p));
  }
  std::size_t n_;
  Array a_, b_;
};

/// The bench run's one roofline (issue 35): the best STREAM copy this machine does, measured
/// once before the rows, the same for every row whatever its kernel level, store or
/// propagation. Every level this CPU runs copies with ordinary and with non-temporal stores
/// (each level's widest loads and stores), `rounds` rounds interleaved over them, on two
/// arrays the size of the largest population field of the run, with the most threads of the run.
struct Roofline {
  struct Copy {
    std::string level;
    double plain_gbs = 0, nt_gbs = 0;  ///< best of the rounds
  };
  std::vector<Copy> copies;
  double gbs = 0;    ///< the best of them all: the roofline's bandwidth
  std::string best;  ///< which: "x86-64-v4 NT"
  int threads = 0;
  double array_mib = 0;
  /// Roofline MLUPS of a store: bandwidth / bytes per update.
  double mlups(Precision p) const { return gbs * 1e3 / bytes_per_update(p); }
};

Roofline measure_roofline(std::size_t doubles, int threads, int rounds) {
  omp_set_num_threads(threads);
  Roofline r;
  r.threads = threads;
  CopyBench copy(doubles);
  r.array_mib = double(copy.bytes_per_array()) / double(1 << 20);
  std::vector<int> levels;
  const std::vector<std::string> names = kernel_levels();
  for (int i = 0; i < int(names.size()); ++i)
    if (cpu_runs_level(names[std::size_t(i)])) {
      levels.push_back(i);
      r.copies.push_back({names[std::size_t(i)]});
    }
  for (const int l : levels) copy.run(false, bench_kernels_of(l)), copy.run(true, bench_kernels_of(l));  // warm-up
  for (int k = 0; k < rounds; ++k)
    for (std::size_t i = 0; i < levels.size(); ++i) {
      Roofline::Copy& c = r.copies[i];
      c.plain_gbs = std::max(c.plain_gbs, copy.run(false, bench_kernels_of(levels[i])) * 1e-9);
      c.nt_gbs = std::max(c.nt_gbs, copy.run(true, bench_kernels_of(levels[i])) * 1e-9);
    }
  for (const Roofline::Copy& c : r.copies)
    for (const auto& [gbs, kind] : {std::pair{c.plain_gbs, "plain"}, std::pair{c.nt_gbs, "NT"}})
      if (gbs > r.gbs) r.gbs = gbs, r.best = c.level + " " + kind;
  return r;
}

struct Options {
  int box = 128;
  int steps = 30;
  int repeat = 5;
  std::vector<int> threads{1, 2};
  std::vector<std::string> grids{"box", "paper"};
  std::vector<Precision> precisions{Precision::Double};
  std::vector<Propagation> propagations{Propagation::TwoGrid};
  Stores stores = Stores::Auto;
  RowSchedule schedule = RowSchedule::Static;
  bool ib = true;
  bool peer = false;
};

struct Row {
  std::string grid;
  int threads = 0;
  Precision precision = Precision::Double;
  Propagation propagation = Propagation::TwoGrid;
  bool streaming = false;  ///< the kernel's stores
  double step_mlups = 0, kernel_mlups = 0;
  double ib_interp_us = 0, ib_spread_us = 0, step_ib_mlups = 0;  ///< 0: not measured
  double peer_mlups = 0;                                          ///< 0: not measured
  double peer_f32_mlups = 0;  ///< a float store's peer in float arithmetic; 0: not measured
};

/// The peer pattern's field (fluid/app/bench_kernels.hpp) on the solver's layout, every value
/// (ghosts and padding too) the equilibrium of rho = 1 and a small drift.
template <class T>
BasicPopulationField<T> peer_field(const GridLayout& layout) {
  BasicPopulationField<T> f(layout);
  for (int q = 0; q < D3Q19::Q; ++q)
    std::fill(f.q(q), f.q(q) + layout.stride(), static_cast<T>(equilibrium(q, 1.0, 0.01, 0.0, 0.0)));
  return f;
}

template <class T>
void run_peer(BasicPopulationField<T>& f, double tau, int steps) {
  if constexpr (std::is_same_v<T, double>)
    bench_kernels().peer_double(f, tau, steps);
  else
    bench_kernels().peer_single(f, tau, steps);
}

template <class T>
BasicPopulationField<T>& state_of(FluidSolver& s) {
  if constexpr (std::is_same_v<T, double>)
    return s.mutable_state();
  else if constexpr (std::is_same_v<T, Half16>)
    return s.mutable_state_half();
  else
    return s.mutable_state_single();
}

template <class T>
Row measure(const Case& base, int threads, Precision precision, Propagation propagation, const Options& opt) {
  omp_set_num_threads(threads);
  Case c = base;
  c.params.precision = precision;
  c.params.propagation = propagation;
  const bool in_place = propagation == Propagation::InPlace;
  FluidSolver solver(c.params);
  solver.set_row_schedule(opt.schedule);
  const FaceSpec& in = c.params.faces[XMin];
  solver.initialize_uniform(1.0, {in.kind == FaceKind::Inlet ? in.inlet_speed : 0.01, 0, 0});
  BasicPopulationField<T> scratch(solver.layout());
  solver.boundaries().fill_static_ghosts(scratch);
  // The immersed boundary of the paper's sheet: markers, their samples and impulses.
  const ImmersedBoundary ib(solver);
  const std::vector<Vec3> X = paper_sheet_markers(solver.shape());
  std::vector<MarkerSample> samples(X.size());
  std::vector<Vec3> J(X.size());

  const double updates = double(solver.shape().cells()) * opt.steps;
  for (int s = 0; s < 2; ++s) solver.step();  // warm-up: page faults, caches
  BasicPopulationField<T> peer, peer_f32;
  const int peer_steps = (opt.steps + 1) / 2 * 2;  // whole AA pairs
  constexpr bool single = std::is_same_v<T, float>;  // a float store
  // The peer pattern has no half store: its columns stay empty on half rows.
  constexpr bool has_peer = !std::is_same_v<T, Half16>;
  const Arithmetic arithmetic = arithmetic_of(precision);
  if constexpr (has_peer) if (opt.peer) {
    peer = peer_field<T>(solver.layout());
    run_peer(peer, solver.tau(), 2);
    if constexpr (single) {
      peer_f32 = peer_field<T>(solver.layout());
      bench_kernels().peer_single_float(peer_f32, solver.tau(), 2);
    }
  }
  std::vector<double> step, kernel, interp, spread, step_ib, peer_rate, peer_f32_rate;
  // Interleaved, so that noise from other processes touches all of them alike.
  for (int r = 0; r < opt.repeat; ++r) {
    auto t0 = Clock::now();
    if (opt.stores == Stores::Auto) {
      for (int s = 0; s < opt.steps; ++s) solver.step();
      step.push_back(updates / seconds_since(t0) * 1e-6);
    }
    // The kernel alone, ping-ponging two fields as step() does (a field just written
    // with non-temporal stores is not in cache); the ghost fill in between is not timed.
    // The kernel includes the x-outflow ghosts it writes in a step (KernelOutflow).
    // In place: the in-place kernel on the scratch field, Canonical and Swapped in turn,
    // without the ghost fills.
    BasicPopulationField<T>* from = &state_of<T>(solver);
    BasicPopulationField<T>* to = &scratch;
    const KernelOutflow outflow = solver.boundaries().kernel_outflow();
    double seconds = 0;
    if (in_place) {
      if (r == 0) solver.copy_state(scratch);
      for (int s = 0; s < opt.steps; ++s) {
        t0 = Clock::now();
        stream_collide_in_place(scratch, s % 2 == 0 ? PopulationLayout::Canonical : PopulationLayout::Swapped,
                                solver.tau(), solver.body_force(), nullptr, opt.schedule, nullptr, arithmetic);
        seconds += seconds_since(t0);
      }
      if (opt.steps % 2 == 1)  // back to Canonical for the next repeat
        stream_collide_in_place(scratch, PopulationLayout::Swapped, solver.tau(), solver.body_force(), nullptr,
                                opt.schedule, nullptr, arithmetic);
    }
    for (int s = 0; s < (in_place ? 0 : opt.steps); ++s) {
      t0 = Clock::now();
      stream_collide(*from, *to, solver.tau(), solver.body_force(), opt.stores, outflow, nullptr, opt.schedule,
                     arithmetic);
      seconds += seconds_since(t0);
      solver.boundaries().fill_ghosts(*to);
      std::swap(from, to);
    }
    kernel.push_back(updates / seconds * 1e-6);
    if constexpr (has_peer) if (opt.peer) {
      t0 = Clock::now();
      run_peer(peer, solver.tau(), peer_steps);
      peer_rate.push_back(double(solver.shape().cells()) * peer_steps / seconds_since(t0) * 1e-6);
      if constexpr (single) {
        t0 = Clock::now();
        bench_kernels().peer_single_float(peer_f32, solver.tau(), peer_steps);
        peer_f32_rate.push_back(double(solver.shape().cells()) * peer_steps / seconds_since(t0) * 1e-6);
      }
    }
    if (!opt.ib || opt.stores != Stores::Auto) continue;
    // A coupled step's fluid side (DESIGN 2.1): interpolate rho and u at the markers
    // (Eq. 17), spread the momentum-exchange impulses of a sheet at rest (g = 2 rho (U_B - u),
    // dA = 1; Eqs. 19, 21-24), step with the spread forces (the forced cells are collided
    // again, Eq. 26). Each timed apart.
    double t_interp = 0, t_spread = 0, t_step = 0;
    for (int s = 0; s < opt.steps; ++s) {
      t0 = Clock::now();
      ib.sample(solver, X, samples);
      t_interp += seconds_since(t0);
      for (std::size_t l = 0; l < X.size(); ++l)
        J[l] = momentum_exchange_force(samples[l].rho, samples[l].u, {0.0, 0.0, 0.0});
      t0 = Clock::now();
      ib.spread(solver, X, J);
      t_spread += seconds_since(t0);
      t0 = Clock::now();
      solver.step();
      t_step += seconds_since(t0);
    }
    interp.push_back(t_interp / opt.steps * 1e6);
    spread.push_back(t_spread / opt.steps * 1e6);
    step_ib.push_back(updates / t_step * 1e-6);
  }
  Row row;
  row.grid = c.name;
  row.threads = threads;
  row.precision = precision;
  row.propagation = propagation;
  row.streaming = !in_place && uses_streaming_stores(solver.layout(), opt.stores, sizeof(T));
  row.step_mlups = step.empty() ? 0.0 : median(step);
  row.kernel_mlups = median(kernel);
  if (!peer_rate.empty()) row.peer_mlups = median(peer_rate);
  if (!peer_f32_rate.empty()) row.peer_f32_mlups = median(peer_f32_rate);
  if (!interp.empty()) {
    row.ib_interp_us = median(interp);
    row.ib_spread_us = median(spread);
    row.step_ib_mlups = median(step_ib);
  }
  return row;
}

/// Whether the table has the peer f32 columns (--peer-pattern with a float store).
bool peer_f32_columns(const Options& opt) {
  return opt.peer && std::any_of(opt.precisions.begin(), opt.precisions.end(), stores_floats);
}

void print_header(const Options& opt, const std::vector<Case>& cases, const Roofline& roof) {
  const KernelTable& k = active_kernel();
  std::printf("CPU: %s; kernel level %s (%s), chosen by %s\n", cpu_model().c_str(), k.level, k.vectors,
              kernel_level_source());
  std::printf("two-grid fields of %.1f MiB and more written with non-temporal stores (the L3 size of CPU 0, else 32)\n",
              double(streaming_stores_from()) / double(1 << 20));
  std::printf("cosim fluid bench: D3Q19 BGK-Guo, structure of arrays, precision modes");
  for (const Precision p : opt.precisions) std::printf(" %s", precision_name(p));
  std::printf(" (double: double store and arithmetic; mixed: float store, double arithmetic;\n"
              "    single: float store and arithmetic; half: 16-bit store of f - w (FP16S), float arithmetic)\n");
  std::printf("medians of %d repeats of %d steps; OMP_PROC_BIND=%s; rows %s\n", opt.repeat, opt.steps,
              std::getenv("OMP_PROC_BIND") ? std::getenv("OMP_PROC_BIND") : "(unset)",
              opt.schedule == RowSchedule::Static ? "static" : "dynamic (64 chunks)");
  std::printf("B = bytes/update = 2 x 19 x 8 = %.0f for the double store, 2 x 19 x 4 = %.0f for\n"
              "    the float one, 2 x 19 x 2 = %.0f for the half one (19 values read + 19 written,\n"
              "    counted as STREAM counts copy; ordinary stores also move 19 write-allocate reads)\n",
              bytes_per_update(Precision::Double), bytes_per_update(Precision::Mixed),
              bytes_per_update(Precision::Half));
  std::printf("prop = propagation (FluidParams::propagation): 2grid = pull from one grid into the\n"
              "    other, stores plain or NT; AA = in place, one grid (the AA pattern), ordinary stores\n"
              "    of lines just loaded (no write-allocate)\n");
  std::printf("copy = STREAM copy b[i] = a[i], measured once before the rows: every level this CPU runs,\n"
              "    ordinary ('plain') and non-temporal ('NT') stores, best of %d rounds, %d threads, two\n"
              "    arrays of %.0f MiB (the largest population field of the run:",
              roof.copies.empty() ? 0 : 2 * opt.repeat, roof.threads, roof.array_mib);
  for (std::size_t i = 0; i < cases.size(); ++i)
    for (const Precision p : opt.precisions)
      std::printf("%s%s %s %.0f MiB", i || p != opt.precisions[0] ? ", " : " ", cases[i].name.c_str(),
                  precision_name(p), double(field_bytes(cases[i], p)) / (1 << 20));
  std::printf(")\n");
  for (const Roofline::Copy& c : roof.copies)
    std::printf("    %-10s plain %6.1f GB/s   NT %6.1f GB/s\n", c.level.c_str(), c.plain_gbs, c.nt_gbs);
  std::printf("roofline = the best copy, %.1f GB/s (%s), the same for every row: %.1f MLUPS for the\n"
              "    double store, %.1f for the float one, %.1f for the half one (bandwidth / B)\n",
              roof.gbs, roof.best.c_str(), roof.mlups(Precision::Double), roof.mlups(Precision::Mixed),
              roof.mlups(Precision::Half));
  std::printf("step = FluidSolver::step() (kernel + ghost fill); kernel = stream_collide only\n"
              "    (with the x-outflow ghosts it writes); AA rows: stream_collide_in_place only, no ghosts\n");
  if (opt.ib && opt.stores == Stores::Auto)
    std::printf("IB = the paper's sheet, 5 x 40 = 200 markers: interp = Eq. 17 at every marker\n"
                "    (ImmersedBoundary::sample), spread = Eqs. 21-24 (ImmersedBoundary::spread),\n"
                "    us per LB step; step+IB = step() with the spread forces (forced cells\n"
                "    collided again), MLUPS\n");
  if (opt.peer)
    std::printf("peer = the peer pattern: a minimal D3Q19 BGK kernel, in place (AA pattern), no\n"
                "    forcing or boundaries (fluid/app/bench_kernels.hpp), on the same grid and layout,\n"
                "    MLUPS; peer/roof against the roofline;\n"
                "    step/peer = step MLUPS / peer MLUPS\n");
  if (peer_f32_columns(opt))
    std::printf("peer f32 = the peer pattern on the float store computed in float arithmetic, float\n"
                "    groups twice as wide (the peer column computes in double), MLUPS and against the\n"
                "    roofline; float-store rows only\n");
  std::printf("note: a shared machine; other processes add noise\n\n");
  const char* const f32[3][2] = {{"peer f32", "peer f32"}, {"MLUPS", "/roof"}, {"", ""}};
  const char* const rows[3][15] = {
      {"grid", "thr", "store", "prop", "step", "kernel", "roofline",
       "step", "kernel", "IB", "IB", "step", "peer", "peer", "step"},
      {"", "", "", "", "MLUPS", "MLUPS", "MLUPS", "/roof", "/roof", "interp",
       "spread", "+IB", "MLUPS", "/roof", "/peer"},
      {"", "", "", "", "", "", "", "", "", "us", "us", "MLUPS", "", "", ""}};
  for (int i = 0; i < 3; ++i) {
    const auto& c = rows[i];
    std::printf("%-20s %3s %6s %6s %6s %7s %9s %6s %6s %8s %8s %7s", c[0], c[1], c[2], c[3],
                c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11]);
    if (opt.peer) std::printf(" %7s %6s %6s", c[12], c[13], c[14]);
    if (peer_f32_columns(opt)) std::printf(" %8s %8s", f32[i][0], f32[i][1]);
    std::printf("\n");
  }
}

void print_row(const Row& r, const Options& opt, const Roofline& roofline) {
  const bool in_place = r.propagation == Propagation::InPlace;
  const double roof = roofline.mlups(r.precision);
  char step[16] = "-", step_ratio[16] = "-", interp[16] = "-", spread[16] = "-", ib[16] = "-";
  if (r.step_mlups > 0) {
    std::snprintf(step, sizeof step, "%.1f", r.step_mlups);
    std::snprintf(step_ratio, sizeof step_ratio, "%.0f%%", 100.0 * r.step_mlups / roof);
  }
  if (r.step_ib_mlups > 0) {
    std::snprintf(interp, sizeof interp, "%.0f", r.ib_interp_us);
    std::snprintf(spread, sizeof spread, "%.0f", r.ib_spread_us);
    std::snprintf(ib, sizeof ib, "%.1f", r.step_ib_mlups);
  }
  std::printf("%-20s %3d %6s %6s %6s %7.1f %9.1f %6s %5.0f%% %8s %8s %7s",
              r.grid.c_str(), r.threads, precision_name(r.precision),
              in_place ? "AA" : r.streaming ? "2gr NT" : "2grid",
              step, r.kernel_mlups, roof, step_ratio,
              100.0 * r.kernel_mlups / roof, interp, spread, ib);
  if (r.peer_mlups > 0) {
    char per_peer[16] = "-";
    if (r.step_mlups > 0) std::snprintf(per_peer, sizeof per_peer, "%.0f%%", 100.0 * r.step_mlups / r.peer_mlups);
    std::printf(" %7.1f %5.0f%% %6s", r.peer_mlups, 100.0 * r.peer_mlups / roof, per_peer);
  }
  if (peer_f32_columns(opt)) {
    if (r.peer_f32_mlups > 0)
      std::printf(" %8.1f %7.0f%%", r.peer_f32_mlups, 100.0 * r.peer_f32_mlups / roof);
    else
      std::printf(" %8s %8s", "-", "-");
  }
  std::printf("\n");
  std::fflush(stdout);
}

}  // namespace
}  // namespace cosim::fluid

int main(int argc, char** argv) {
  using namespace cosim::fluid;
  Options opt;
  CLI::App app{"MLUPS of the D3Q19 fluid against the STREAM copy roofline"};
  app.add_option("--box", opt.box, "edge of the periodic box in cells")->check(CLI::Range(8, 1024));
  app.add_option("--steps", opt.steps, "steps per timed repeat")->check(CLI::Range(1, 100000));
  app.add_option("--repeat", opt.repeat, "timed repeats (median reported)")
      ->check(CLI::Range(1, 1000));
  app.add_option("--threads", opt.threads, "OpenMP thread counts to run, e.g. 1 2")
      ->check(CLI::Range(1, 1024));
  app.add_option("--grids", opt.grids, "grids to run: box (periodic cube), paper (120x60x90)")
      ->check(CLI::IsMember({"box", "paper"}));
  const std::map<std::string, Stores> stores{
      {"auto", Stores::Auto}, {"plain", Stores::Cached}, {"nt", Stores::Streaming}};
  app.add_option("--stores", opt.stores,
                 "kernel stores: auto (as the solver), plain or nt; not auto: kernel only")
      ->transform(CLI::CheckedTransformer(stores, CLI::ignore_case));
  const std::map<std::string, Precision> precisions{{"double", Precision::Double},
                                                    {"mixed", Precision::Mixed},
                                                    {"single", Precision::Single},
                                                    {"half", Precision::Half}};
  app.add_option("--precision", opt.precisions,
                 "precision modes to run ([run] precision): double, mixed (float store, double arithmetic), "
                 "single (float store and arithmetic), half (16-bit store of f - w, float arithmetic; no peer "
                 "pattern)")
      ->transform(CLI::CheckedTransformer(precisions, CLI::ignore_case));
  const std::map<std::string, RowSchedule> schedules{{"static", RowSchedule::Static},
                                                     {"dynamic", RowSchedule::Dynamic}};
  app.add_option("--schedule", opt.schedule,
                 "how the kernel shares rows among threads: static (default) or dynamic (as the parallel "
                 "coupling scheme's free steps)")
      ->transform(CLI::CheckedTransformer(schedules, CLI::ignore_case));
  const std::map<std::string, Propagation> propagations{{"two-grid", Propagation::TwoGrid},
                                                        {"in-place", Propagation::InPlace}};
  app.add_option("--propagation", opt.propagations,
                 "propagations to run: two-grid (default), in-place (the AA pattern, FluidParams::propagation)")
      ->transform(CLI::CheckedTransformer(propagations, CLI::ignore_case));
  bool no_ib = false;
  app.add_flag("--no-ib", no_ib, "skip the immersed-boundary columns");
  app.add_flag("--peer-pattern", opt.peer,
               "also run the peer pattern, a minimal in-place (AA) D3Q19 BGK kernel, on the same grid\n"
               "(float stores: also in float arithmetic, peer f32)");
  std::string level;
  app.add_option("--level", level,
                 "kernel instruction-set level to run (default: the highest this CPU runs, or "
                 "COSIM_KERNEL_LEVEL); one of the levels built in: " +
                     [] {
                       std::string s;
                       for (const std::string& l : kernel_levels()) s += (s.empty() ? "" : ", ") + l;
                       return s;
                     }());
  if (const auto code = cosim::protocol::parse_command_line(app, argc, argv, "bench")) return *code;
  opt.ib = !no_ib;
  try {
    if (!level.empty())
      set_kernel_level(level, "--level");
    else
      active_kernel();
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "bench: %s\n", e.what());
    return cosim::protocol::exit_code::bad_input;
  }

  std::vector<Case> cases;
  for (const std::string& g : opt.grids)
    cases.push_back(g == "box" ? periodic_box(opt.box) : paper_channel());
  std::size_t largest = 0;
  for (const Case& c : cases)
    for (const Precision p : opt.precisions) largest = std::max(largest, field_bytes(c, p));
  const Roofline roof =
      measure_roofline(largest / sizeof(double), *std::max_element(opt.threads.begin(), opt.threads.end()), 2 * opt.repeat);
  print_header(opt, cases, roof);
  for (const Case& c : cases)
    for (const Precision p : opt.precisions)
      for (const Propagation g : opt.propagations)
        for (const int t : opt.threads)
          print_row(p == Precision::Double ? measure<double>(c, t, p, g, opt)
                    : stores_halves(p)   ? measure<Half16>(c, t, p, g, opt)
                                         : measure<float>(c, t, p, g, opt),
                    opt, roof);
  return 0;
}
