// The bench's yardsticks (fluid/app/bench_kernels.hpp), compiled once per instruction-set level
// into namespace COSIM_ISA_NS (fluid/CMakeLists.txt, cosim_isa_objects).
#include "fluid/app/bench_kernels.hpp"

#include <cstddef>
#include <cstring>
#include <type_traits>
#include <utility>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/lanes.hpp"

namespace cosim::fluid::COSIM_ISA_NS {

namespace {

using L = D3Q19;

void copy(const double* a, double* b, std::ptrdiff_t n, bool streaming) {
#pragma omp parallel
  {
    if (streaming) {
#pragma omp for schedule(static) nowait
      for (std::ptrdiff_t i = 0; i < n; i += kLanes) store_stream(b + i, load(a + i));
      store_fence();
    } else {
#pragma omp for schedule(static) nowait
      for (std::ptrdiff_t i = 0; i < n; i += kLanes) store_aligned(b + i, load(a + i));
    }
  }
}

// The groups (Lanes, LanesFloat), their loads and stores: fluid/lattice/lanes.hpp, as the
// project's kernel uses them.

/// c v for a lattice velocity component c in {-1, 0, 1}, known at compile time.
template <int c, class V>
[[gnu::always_inline]] inline V times(V v) {
  if constexpr (c == 1) return v;
  if constexpr (c == -1) return -v;
  return V{};
}

template <int c, class V>
[[gnu::always_inline]] inline V add(V a, V v) {
  if constexpr (c == 0) return a;
  return a + times<c>(v);
}

/// Plain BGK (Eqs. 10-11 without forcing) of a group of cells in f, in the arithmetic of V.
template <class V, std::size_t... Q>
[[gnu::always_inline]] inline void bgk(V (&f)[L::Q], Scalar<V> omega, std::index_sequence<Q...>) {
  using S = Scalar<V>;
  V rho = f[0], jx{}, jy{}, jz{};
  ((rho += f[Q + 1], jx = add<L::cx[Q + 1]>(jx, f[Q + 1]), jy = add<L::cy[Q + 1]>(jy, f[Q + 1]),
    jz = add<L::cz[Q + 1]>(jz, f[Q + 1])),
   ...);
  const V inv = S(1) / rho;
  const V ux = jx * inv, uy = jy * inv, uz = jz * inv;
  const V base = S(1) - S(1.5) * (ux * ux + uy * uy + uz * uz);
  f[0] += omega * (S(L::w[0]) * rho * base - f[0]);
  const auto relax = [&](auto qc) __attribute__((always_inline)) {
    constexpr int q = decltype(qc)::value;
    const V cu = add<L::cz[q]>(add<L::cy[q]>(times<L::cx[q]>(ux), uy), uz);
    f[q] += omega * (S(L::w[q]) * rho * (base + cu * (S(3) + S(4.5) * cu)) - f[q]);
  };
  (relax(std::integral_constant<int, int(Q) + 1>{}), ...);
}

/// The peer pattern on populations stored as T, computed in groups V.
template <class T, class V>
void peer(BasicPopulationField<T>& field, double tau, int steps) {
  constexpr int kGroup = int(sizeof(V) / sizeof(Scalar<V>));
  const GridLayout& lay = field.layout();
  const int nx = lay.nx(), ny = lay.ny();
  const std::ptrdiff_t rows = std::ptrdiff_t(ny) * lay.nz();
  const std::ptrdiff_t stride = std::ptrdiff_t(lay.stride());
  const Scalar<V> omega = Scalar<V>(1.0 / tau);
  // Even step: population q of a cell at slot q, stored back at slot opp q of the same cell.
  // Odd step: population q read at slot opp q of the cell at -c_q (where the even step left
  // it), written to slot q of the cell at +c_q (where the next even step finds it).
  std::ptrdiff_t here[L::Q], there[L::Q], from[L::Q], to[L::Q];
  for (int q = 0; q < L::Q; ++q) {
    here[q] = q * stride;
    there[q] = L::opp[q] * stride;
    from[q] = L::opp[q] * stride - lay.offset(L::cx[q], L::cy[q], L::cz[q]);
    to[q] = q * stride + lay.offset(L::cx[q], L::cy[q], L::cz[q]);
  }
  T* const f0 = field.q(0);
  const auto pairs = std::make_index_sequence<L::Q - 1>{};
#pragma omp parallel
  for (int s = 0; s < steps; ++s) {
    const bool even = s % 2 == 0;
    const std::ptrdiff_t* const rd = even ? here : from;
    const std::ptrdiff_t* const wr = even ? there : to;
#pragma omp for schedule(static)
    for (std::ptrdiff_t r = 0; r < rows; ++r) {
      T* const c = f0 + lay.index(0, int(r % ny), int(r / ny));
      V f[L::Q];
      int x = 0;
      for (; x + kGroup <= nx; x += kGroup) {
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) f[q] = load_group<V>(c + rd[q] + x);
        bgk(f, omega, pairs);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) store_group(c + wr[q] + x, f[q]);
      }
      if (x < nx) {
        const int n = nx - x;
        for (int q = 0; q < L::Q; ++q) f[q] = load_group_partial<V>(c + rd[q] + x, n);
        bgk(f, omega, pairs);
        for (int q = 0; q < L::Q; ++q) store_group_partial(c + wr[q] + x, f[q], n);
      }
    }
  }
}

}  // namespace

extern const BenchKernels bench_kernel_table;
const BenchKernels bench_kernel_table{&copy, &peer<double, Lanes>, &peer<float, Lanes>, &peer<float, LanesFloat>};

}  // namespace cosim::fluid::COSIM_ISA_NS
