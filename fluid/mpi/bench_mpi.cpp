// Strong scaling of the fluid over MPI ranks (DESIGN 8, docs/scaling.md): a fluid-only
// scene's steps on the ranks of this mpirun against the single-process solver on rank 0 in
// the same run, the bytes each step exchanges, and the message latency and bandwidth between
// two ranks (ping-pong), from which docs/scaling.md projects larger runs.
//
//   bash launch/mpirun-local.sh 2 build/fluid/bench_mpi [SCENE.toml] [--steps N] [--repeat R]
//
// Prints plain tables (medians of R repeats). One OpenMP thread per rank unless
// OMP_NUM_THREADS says otherwise (launch/mpirun-local.sh divides the cores); the serial
// reference uses as many threads as one rank.
#include <mpi.h>
#include <omp.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "fluid/domain/fluid_domain.hpp"
#include "fluid/mpi/distributed_fluid.hpp"
#include "fluid/mpi/mpi_world.hpp"
#include "fluid/config/scene_config.hpp"
#include "common/text/cli_parse.hpp"

namespace cosim::fluid::mpi {
namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// The other ranks wait for rank 0 without spinning (their cores stay free for its run).
void wait_for_rank0(MPI_Comm comm, int rank) {
  int token = 0;
  if (rank == 0) {
    int ranks = 1;
    MPI_Comm_size(comm, &ranks);
    for (int r = 1; r < ranks; ++r) MPI_Send(&token, 1, MPI_INT, r, 7, comm);
    return;
  }
  MPI_Request req;
  MPI_Irecv(&token, 1, MPI_INT, 0, 7, comm, &req);
  for (int done = 0; !done; usleep(1000)) MPI_Test(&req, &done, MPI_STATUS_IGNORE);
}

/// Seconds per step of the whole grid in this process (rank 0 alone).
double serial_step_s(const FluidScene& scene, int steps) {
  SerialDomain d(scene.params);
  d.initialize(scene);
  d.step();  // first touch, caches
  const double t0 = MPI_Wtime();
  for (int i = 0; i < steps; ++i) d.step();
  return (MPI_Wtime() - t0) / steps;
}

struct Decomposed {
  double step_s = 0, halo_s = 0;  // per step, the slowest rank
  double bytes = 0;               // per step, all ranks
};

Decomposed decomposed_step(const FluidScene& scene, int steps, MPI_Comm comm) {
  DistributedFluid d(scene, comm);
  d.initialize(scene);
  d.step();
  const double halo0 = d.halo().seconds();
  const double bytes0 = double(d.halo().bytes_sent());
  MPI_Barrier(comm);
  const double t0 = MPI_Wtime();
  for (int i = 0; i < steps; ++i) d.step();
  MPI_Barrier(comm);
  Decomposed r;
  r.step_s = (MPI_Wtime() - t0) / steps;
  double halo = (d.halo().seconds() - halo0) / steps, bytes = (double(d.halo().bytes_sent()) - bytes0) / steps;
  MPI_Allreduce(MPI_IN_PLACE, &halo, 1, MPI_DOUBLE, MPI_MAX, comm);
  MPI_Allreduce(MPI_IN_PLACE, &bytes, 1, MPI_DOUBLE, MPI_SUM, comm);
  r.halo_s = halo;
  r.bytes = bytes;
  return r;
}

/// Half the round trip of a message of `bytes` between ranks 0 and 1 (median of `reps`).
double one_way_s(std::size_t bytes, int reps, MPI_Comm comm, int rank) {
  std::vector<char> buf(std::max<std::size_t>(bytes, 1));
  std::vector<double> t;
  for (int i = 0; i < reps; ++i) {
    MPI_Barrier(comm);
    const double t0 = MPI_Wtime();
    if (rank == 0) {
      MPI_Send(buf.data(), int(bytes), MPI_CHAR, 1, 1, comm);
      MPI_Recv(buf.data(), int(bytes), MPI_CHAR, 1, 2, comm, MPI_STATUS_IGNORE);
    } else if (rank == 1) {
      MPI_Recv(buf.data(), int(bytes), MPI_CHAR, 0, 1, comm, MPI_STATUS_IGNORE);
      MPI_Send(buf.data(), int(bytes), MPI_CHAR, 0, 2, comm);
    }
    t.push_back(0.5 * (MPI_Wtime() - t0));
  }
  return median(t);
}

int main_impl(int argc, char** argv, const World& world) {
  CLI::App app{"Strong scaling of the fluid over the ranks of this mpirun (docs/scaling.md).", "bench_mpi"};
  std::string scene_path = "scenes/channel.toml";
  int steps = 20, repeat = 3;
  app.add_option("scene", scene_path, "a fluid-only scene (default: the paper's channel, scenes/channel.toml)");
  app.add_option("--steps", steps, "timed steps per repeat")->check(CLI::Range(1, 1000000));
  app.add_option("--repeat", repeat, "repeats (medians are printed)")->check(CLI::Range(1, 1000));
  if (const auto code = protocol::parse_command_line(app, argc, argv, "bench_mpi")) return *code;
  FluidScene scene;
  try {
    scene = load_scene(scene_path);
  } catch (const SceneError& e) {
    if (world.rank() == 0) std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  if (scene.threads > 0) omp_set_num_threads(scene.threads);
  const MPI_Comm comm = world.comm();
  const int rank = world.rank(), ranks = world.size();
  const GridShape& g = scene.params.shape;
  if (rank == 0) {
    // The machine's load: on shared cores the timings below say as much about it as about
    // the code.
    double load[3] = {0, 0, 0};
    if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
      if (std::fscanf(f, "%lf %lf %lf", &load[0], &load[1], &load[2]) != 3) load[0] = -1;
      std::fclose(f);
    }
    std::printf("bench_mpi: load average %.2f %.2f %.2f on %ld cores\n", load[0], load[1], load[2],
                sysconf(_SC_NPROCESSORS_ONLN));
    std::printf("bench_mpi: %s, %d x %d x %d = %lld cells, %s store; %d ranks x %d OpenMP threads; "
                "%d steps x %d repeats (medians)\n",
                scene.name.c_str(), g.nx, g.ny, g.nz, static_cast<long long>(g.cells()),
                precision_name(scene.params.precision), ranks, omp_get_max_threads(), steps, repeat);
    std::fflush(stdout);
  }
  std::vector<double> serial, step, halo;
  double bytes = 0;
  for (int r = 0; r < repeat; ++r) {
    if (rank == 0) serial.push_back(serial_step_s(scene, steps));
    wait_for_rank0(comm, rank);
    const Decomposed d = decomposed_step(scene, steps, comm);
    step.push_back(d.step_s);
    halo.push_back(d.halo_s);
    bytes = d.bytes;
  }
  const double cells = double(g.cells());
  if (rank == 0) {
    const double t1 = median(serial), tn = median(step), th = median(halo);
    std::printf("%-28s %12s %10s %12s %14s %10s\n", "run", "ms/step", "MLUPS", "efficiency", "bytes/step", "halo ms");
    std::printf("%-28s %12.3f %10.1f %12s %14s %10s\n", "1 process (serial solver)", t1 * 1e3, cells / t1 * 1e-6,
                "1", "0", "-");
    char name[64];
    std::snprintf(name, sizeof name, "%d ranks (slabs along z)", ranks);
    std::printf("%-28s %12.3f %10.1f %12.3f %14.0f %10.3f\n", name, tn * 1e3, cells / tn * 1e-6,
                t1 / (ranks * tn), bytes, th * 1e3);
    std::fflush(stdout);
  }
  if (ranks >= 2) {
    if (rank == 0) std::printf("\nping-pong rank 0 <-> 1 (one way, median of 200)\n%12s %12s %12s\n", "bytes", "us", "MB/s");
    for (const std::size_t b : {std::size_t(8), std::size_t(1) << 10, std::size_t(1) << 14, std::size_t(1) << 17,
                                std::size_t(1) << 20, std::size_t(1) << 22}) {
      const double t = one_way_s(b, 200, comm, rank);
      if (rank == 0) std::printf("%12zu %12.2f %12.0f\n", b, t * 1e6, double(b) / t * 1e-6);
    }
  }
  return 0;
}

}  // namespace
}  // namespace cosim::fluid::mpi

int main(int argc, char** argv) {
  cosim::fluid::mpi::World world(argc, argv);
  try {
    return cosim::fluid::mpi::main_impl(argc, argv, world);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_mpi: %s\n", e.what());
    cosim::fluid::mpi::World::abort(1);
  }
}
