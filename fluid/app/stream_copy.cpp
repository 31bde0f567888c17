// An independent check of the bench's roofline (docs/results/roofline-check-20261205.md):
// the STREAM benchmark's copy kernel b[i] = a[i] written as STREAM writes it, a plain loop
// under `omp parallel for` left to the compiler (no code of the project's kernels or of the
// bench's copies, no intrinsics), counted as STREAM counts it (16 bytes per element).
//
//   ./build/fluid/stream_copy [MIB] [ROUNDS]
//
// Two arrays of MIB MiB each (default 360: beyond any cache here, the paper grid's double field
// is 94 MiB), the best and the median of ROUNDS copies (default 20), OpenMP threads as
// OMP_NUM_THREADS says.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

int main(int argc, char** argv) {
  const long mib = argc > 1 ? std::atol(argv[1]) : 360;
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 20;
  if (mib < 1 || mib > 65536 || rounds < 1 || rounds > 10000) {
    std::fprintf(stderr, "stream_copy: MIB must be in [1, 65536] and ROUNDS in [1, 10000]\n");
    return 2;
  }
  const long n = mib * (1L << 20) / long(sizeof(double));
  // Not initialized here: the first touch is the threads' own, in the order they copy.
  const std::unique_ptr<double[]> a{new double[std::size_t(n)]}, b{new double[std::size_t(n)]};
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) a[std::size_t(i)] = 1.0, b[std::size_t(i)] = 0.0;
  std::vector<double> gbs;
  for (int r = 0; r < rounds; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for schedule(static)
    for (long i = 0; i < n; ++i) b[std::size_t(i)] = a[std::size_t(i)];
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    gbs.push_back(16.0 * double(n) / s * 1e-9);
  }
  std::sort(gbs.begin(), gbs.end());
  std::printf("stream_copy: %d threads, 2 arrays of %ld MiB, %d rounds: best %.1f GB/s, median %.1f GB/s "
              "(b[1] = %.0f)\n",
              omp_get_max_threads(), mib, rounds, gbs.back(), gbs[gbs.size() / 2], b[1]);
  return 0;
}
