// Fluid throughput benchmark (DESIGN 7): million lattice updates per second (MLUPS) of
// FluidSolver::step() on a periodic box and on the paper's channel grid, beside the STREAM
// copy bandwidth measured in the same run, and the fraction of the memory-bandwidth
// roofline reached. Prints a plain table of medians; see docs/performance.md.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "fluid/d3q19.hpp"
#include "fluid/fluid_solver.hpp"
#include "fluid/stream_collide.hpp"

namespace cosim::fluid {
namespace {

/// Bytes per lattice update counted the way STREAM counts copy traffic: 19 doubles read
/// and 19 doubles written (write-allocate not counted, as STREAM does not count it).
constexpr double kBytesPerUpdate = 2.0 * D3Q19::Q * sizeof(double);

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

/// A periodic cube of n^3 cells, at rest but for a small uniform drift.
Case periodic_box(int n) {
  Case c{"box " + std::to_string(n) + "^3 periodic", {}};
  c.params.shape = {n, n, n};
  c.params.tau = 0.6;
  return c;
}

/// The paper's grid: 120 x 60 x 90, Blasius inlet (U = 0.104, delta = 3.4 cells) on x_min,
/// outflow on x_max, a wall on y_min, free slip on y_max, periodic in z.
Case paper_channel() {
  Case c{"paper 120x60x90", {}};
  FluidParams& p = c.params;
  p.shape = {120, 60, 90};
  p.tau = 0.6;
  p.faces[XMin].kind = FaceKind::Inlet;
  p.faces[XMin].inlet_speed = 0.104;
  p.faces[XMin].profile = InletProfile::Blasius;
  p.faces[XMin].boundary_layer = 3.4;
  p.faces[XMax].kind = FaceKind::Outflow;
  p.faces[YMin].kind = FaceKind::Wall;
  p.faces[YMax].kind = FaceKind::FreeSlip;
  return c;
}

/// STREAM "copy" b[i] = a[i] with ordinary (write-allocating) stores, OpenMP static
/// schedule like the kernel. Returns bytes/s counted as STREAM does (16 B per element).
class CopyBench {
 public:
  explicit CopyBench(std::size_t n) : n_(n), a_(alloc(n)), b_(alloc(n)) {
    double* a = a_.get();
    double* b = b_.get();
    const std::ptrdiff_t m = std::ptrdiff_t(n_);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < m; ++i) a[i] = 1.0, b[i] = 0.0;
  }
  std::size_t bytes_per_array() const { return n_ * sizeof(double); }

  double run() {
    const auto t0 = Clock::now();
    copy(a_.get(), b_.get(), std::ptrdiff_t(n_));
    return 2.0 * double(bytes_per_array()) / seconds_since(t0);
  }

 private:
  struct Free {
    void operator()(double* p) const { std::free(p); }
  };
  using Array = std::unique_ptr<double, Free>;
  static Array alloc(std::size_t n) {
    const std::size_t bytes = (n * sizeof(double) + 63) / 64 * 64;
    return Array(static_cast<double*>(std::aligned_alloc(64, bytes)));
  }
  // Not turned into a memcpy call: the kind of store must be known (ordinary stores).
  __attribute__((optimize("no-tree-loop-distribute-patterns"))) static void copy(
      const double* __restrict a, double* __restrict b, std::ptrdiff_t n) {
#pragma omp parallel for simd schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i) b[i] = a[i];
  }

  std::size_t n_;
  Array a_, b_;
};

struct Row {
  std::string grid;
  int threads = 0;
  double step_mlups = 0, kernel_mlups = 0, copy_gbs = 0;
};

struct Options {
  int box = 128;
  int steps = 30;
  int repeat = 5;
  std::vector<int> threads{1, 2};
  std::vector<std::string> grids{"box", "paper"};
};

Row measure(const Case& c, int threads, const Options& opt) {
  omp_set_num_threads(threads);
  FluidSolver solver(c.params);
  const FaceSpec& in = c.params.faces[XMin];
  solver.initialize_uniform(1.0, {in.kind == FaceKind::Inlet ? in.inlet_speed : 0.01, 0, 0});
  PopulationField scratch(solver.layout());
  // Copy arrays of the size of one population field (19 populations with ghosts).
  CopyBench copy(std::size_t(D3Q19::Q) * solver.layout().stride());

  const double updates = double(solver.shape().cells()) * opt.steps;
  for (int s = 0; s < 2; ++s) solver.step();  // warm-up: page faults, caches
  copy.run();
  std::vector<double> step, kernel, bw;
  // Interleaved, so that noise from other processes touches all three alike.
  for (int r = 0; r < opt.repeat; ++r) {
    bw.push_back(std::max(copy.run(), copy.run()));
    auto t0 = Clock::now();
    for (int s = 0; s < opt.steps; ++s) solver.step();
    step.push_back(updates / seconds_since(t0) * 1e-6);
    t0 = Clock::now();
    for (int s = 0; s < opt.steps; ++s)
      stream_collide(solver.state(), scratch, solver.tau(), solver.body_force());
    kernel.push_back(updates / seconds_since(t0) * 1e-6);
  }
  return {c.name, threads, median(step), median(kernel), median(bw) * 1e-9};
}

void print_header(const Options& opt, std::size_t box_bytes) {
  std::printf("cosim fluid bench: D3Q19 BGK-Guo, double precision, two grids (SoA)\n");
  std::printf("medians of %d repeats of %d steps; OMP_PROC_BIND=%s\n", opt.repeat, opt.steps,
              std::getenv("OMP_PROC_BIND") ? std::getenv("OMP_PROC_BIND") : "(unset)");
  std::printf("bytes/update B = 2 x 19 x 8 = %.0f (read + write, STREAM counting)\n",
              kBytesPerUpdate);
  std::printf("copy: STREAM copy b[i] = a[i], ordinary stores, two arrays each the size of one\n"
              "      population field of the grid (%zu MB for the box), best of 2 per repeat\n",
              box_bytes >> 20);
  std::printf("roofline MLUPS = copy bandwidth / B; ratio = step MLUPS / roofline\n");
  std::printf("step = FluidSolver::step() (kernel + ghost fill); kernel = stream_collide only\n\n");
  std::printf("%-22s %7s %11s %13s %10s %14s %7s\n", "grid", "threads", "step MLUPS",
              "kernel MLUPS", "copy GB/s", "roofline MLUPS", "ratio");
}

void print_row(const Row& r) {
  const double roof = r.copy_gbs * 1e9 / kBytesPerUpdate * 1e-6;
  std::printf("%-22s %7d %11.1f %13.1f %10.1f %14.1f %6.0f%%\n", r.grid.c_str(), r.threads,
              r.step_mlups, r.kernel_mlups, r.copy_gbs, roof, 100.0 * r.step_mlups / roof);
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
  CLI11_PARSE(app, argc, argv);

  const GridLayout box_layout(GridShape{opt.box, opt.box, opt.box});
  print_header(opt, std::size_t(D3Q19::Q) * box_layout.stride() * sizeof(double));
  for (const std::string& g : opt.grids) {
    const Case c = g == "box" ? periodic_box(opt.box) : paper_channel();
    for (const int t : opt.threads) print_row(measure(c, t, opt));
  }
  return 0;
}
