// The kernel's body, compiled once per instruction-set level into namespace COSIM_ISA_NS
// (fluid/CMakeLists.txt, cosim_isa_objects); fluid/collision/kernel_dispatch.cpp picks one at run time
// and holds the public stream_collide().
#include "fluid/collision/stream_collide.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#include "fluid/boundary/boundary.hpp"
#include "fluid/lattice/d3q19.hpp"
#include "fluid/collision/kernel_dispatch.hpp"
#include "fluid/lattice/lanes.hpp"

namespace cosim::fluid::COSIM_ISA_NS {

namespace {

using L = D3Q19;

/// Direction pairs (q, q + 1) with c_{q+1} = -c_q: q = 1, 3, ..., 17 (D3Q19::opp).
constexpr int kPairs = (L::Q - 1) / 2;
constexpr int pair_q(int p) { return 2 * p + 1; }
static_assert([] {
  for (int p = 0; p < kPairs; ++p)
    if (L::opp[pair_q(p)] != pair_q(p) + 1) return false;
  return true;
}());

// The per-cell helpers below are forced inline ([[gnu::always_inline]]) so that the values
// of a cell group stay in registers. They compute on a group V of the level's vectors
// (fluid/lattice/lanes.hpp): Lanes (double arithmetic: the precision modes "double" and
// "mixed") or LanesFloat (float arithmetic: "single"), one template for both; S = Scalar<V>.
// Constants are written S(...): exact in either type but for the weights and the per-call
// constants, which are computed in double and rounded once to S (CollisionConstants).

/// a + c v for a lattice velocity component c in {-1, 0, 1}; no multiplication by zero.
template <int c, class V>
[[gnu::always_inline]] inline V add_c(V a, V v) {
  if constexpr (c == 1) return a + v;
  if constexpr (c == -1) return a - v;
  return a;
}

/// c v for c in {-1, 1}.
template <int c, class V>
[[gnu::always_inline]] inline V times_c(V v) {
  static_assert(c == 1 || c == -1);
  if constexpr (c == 1) return v;
  return -v;
}

/// c_q . a for a direction q (not the rest direction) known at compile time.
template <int q, class V>
[[gnu::always_inline]] inline V dot_c(V ax, V ay, V az) {
  if constexpr (L::cx[q] != 0)
    return add_c<L::cz[q]>(add_c<L::cy[q]>(times_c<L::cx[q]>(ax), ay), az);
  else if constexpr (L::cy[q] != 0)
    return add_c<L::cz[q]>(times_c<L::cy[q]>(ay), az);
  else
    return times_c<L::cz[q]>(az);
}

/// Per-call constants of the collision: relaxation rate, the body force and the
/// velocity-independent parts of Guo's source term; computed in double, then rounded once to
/// the arithmetic's type S.
template <class S>
struct CollisionConstants {
  S omega;                     ///< 1 / tau
  S Fx, Fy, Fz;                ///< uniform force density
  S src_pref;                  ///< 1 - omega / 2 (Eq. 26)
  S cF3[kPairs], cF9[kPairs];  ///< src_pref E_q 3 c_q.F and 9 c_q.F, q of each pair
  S shift[L::Q];               ///< w_q: the half store keeps f_q - w_q (load_pop, store_pop)

  CollisionConstants(double tau, const std::array<double, 3>& F) {
    const double om = 1.0 / tau, pref = 1.0 - 0.5 * om;
    omega = S(om);
    Fx = S(F[0]);
    Fy = S(F[1]);
    Fz = S(F[2]);
    src_pref = S(pref);
    for (int p = 0; p < kPairs; ++p) {
      const int q = pair_q(p);
      const double cF = L::cx[q] * F[0] + L::cy[q] * F[1] + L::cz[q] * F[2];
      cF3[p] = S(pref * L::w[q] * 3.0 * cF);
      cF9[p] = S(pref * L::w[q] * 9.0 * cF);
    }
    for (int q = 0; q < L::Q; ++q) shift[q] = S(L::w[q]);
  }
};

/// The three weights of Eq. 12 and the class of a direction: 0 rest, 1 axis, 2 diagonal.
constexpr double kWeights[3] = {L::w[0], L::w[1], L::w[7]};
constexpr int weight_class(int q) { return q == 0 ? 0 : q < 7 ? 1 : 2; }
static_assert([] {
  for (int q = 0; q < L::Q; ++q)
    if (L::w[q] != kWeights[weight_class(q)]) return false;
  return true;
}());

/// rho (Eq. 7) and j = rho v (Eq. 8) of a group of cells.
template <class V>
struct LaneMoments {
  V rho, jx, jy, jz;
};

/// Adds the pair (q, opp q) to the moments: both to rho (one by one, in the order of
/// moments() in fluid/lattice/equilibrium.hpp: same rounding as the one-cell reference), their
/// difference along c_q to j.
template <int q, class V>
[[gnu::always_inline]] inline void add_pair(LaneMoments<V>& m, V fq, V fo) {
  m.rho = (m.rho + fq) + fo;
  const V d = fq - fo;
  m.jx = add_c<L::cx[q]>(m.jx, d);
  m.jy = add_c<L::cy[q]>(m.jy, d);
  m.jz = add_c<L::cz[q]>(m.jz, d);
}

template <class V, std::size_t... P>
[[gnu::always_inline]] inline LaneMoments<V> moments(const V (&f)[L::Q], std::index_sequence<P...>) {
  LaneMoments<V> m{f[0], {}, {}, {}};
  (add_pair<pair_q(P)>(m, f[pair_q(P)], f[pair_q(P) + 1]), ...);
  return m;
}

/// What the relaxation of every direction needs from a cell: Guo's velocity and the parts
/// of f_eq (Eq. 11) and of the source that do not depend on the direction.
template <class V>
struct LaneFlow {
  V ux, uy, uz;
  V uu;       ///< u.u
  V even0;    ///< 1 - 3/2 u.u
  V wrho[3];  ///< E rho for E = 1/3, 1/18, 1/36 (weight_class)
  V src0[3];  ///< (1 - omega/2) E (-3 u.F), the part of S without c.F
};

template <bool kForce, class V, class S = Scalar<V>>
[[gnu::always_inline]] inline LaneFlow<V> flow(const LaneMoments<V>& m, const CollisionConstants<S>& k) {
  LaneFlow<V> v;
  const V inv_rho = S(1.0) / m.rho;
  // Guo's velocity u = (j + F/2) / rho
  v.ux = (kForce ? m.jx + S(0.5) * k.Fx : m.jx) * inv_rho;
  v.uy = (kForce ? m.jy + S(0.5) * k.Fy : m.jy) * inv_rho;
  v.uz = (kForce ? m.jz + S(0.5) * k.Fz : m.jz) * inv_rho;
  v.uu = v.ux * v.ux + v.uy * v.uy + v.uz * v.uz;
  v.even0 = S(1.0) - S(1.5) * v.uu;
  const V uF3 = kForce ? (S(-3.0) * k.src_pref) * (v.ux * k.Fx + v.uy * k.Fy + v.uz * k.Fz) : V{};
  for (int c = 0; c < 3; ++c) {
    v.wrho[c] = m.rho * S(kWeights[c]);
    v.src0[c] = kForce ? uF3 * S(kWeights[c]) : V{};
  }
  return v;
}

/// f_q += omega (f_eq_q - f_q) + (1 - omega/2) S_q for the pair (q, opp q) of pair P;
/// f_eq and S split into the parts even and odd in c (see collide).
template <bool kForce, int P, class V, class S = Scalar<V>>
[[gnu::always_inline]] inline void relax_pair(V& fq, V& fo, const LaneFlow<V>& v, const CollisionConstants<S>& k) {
  constexpr int q = pair_q(P), wi = weight_class(q);
  const V cu = dot_c<q>(v.ux, v.uy, v.uz);
  const V even = v.wrho[wi] * (v.even0 + S(4.5) * cu * cu);
  const V odd = v.wrho[wi] * (S(3.0) * cu);
  V src_even{}, src_odd{};
  if constexpr (kForce) {
    src_even = v.src0[wi] + k.cF9[P] * cu;
    src_odd = V{} + k.cF3[P];
  }
  fq += k.omega * ((even + odd) - fq) + (src_even + src_odd);
  fo += k.omega * ((even - odd) - fo) + (src_even - src_odd);
}

template <bool kForce, class V, class S, std::size_t... P>
[[gnu::always_inline]] inline void relax_pairs(V (&f)[L::Q], const LaneFlow<V>& v, const CollisionConstants<S>& k,
                                               std::index_sequence<P...>) {
  (relax_pair<kForce, int(P)>(f[pair_q(P)], f[pair_q(P) + 1], v, k), ...);
}

/// The extrema the kernel gathers of the cells it collides (KernelExtrema): a thread's
/// running values, lane by lane.
template <class V>
struct LaneExtrema {
  using S = Scalar<V>;
  static constexpr int N = lanes_of<V>;
  V rho_min = V{} + std::numeric_limits<S>::infinity();
  V rho_max = V{} - std::numeric_limits<S>::infinity();
  V uu_max = V{};
  V bad = V{};  ///< NaN once a rho or u.u was not finite (0 inf and 0 NaN are NaN)
  /// The first n lanes of a group (a row's partial group pads with cells of rho = 19).
  void take(V rho, V uu, int n = N) {
    if (n < N) {
      // Lanes past n repeat lane 0.
      for (int i = n; i < N; ++i) {
        rho[i] = rho[0];
        uu[i] = uu[0];
      }
    }
    rho_min = rho < rho_min ? rho : rho_min;
    rho_max = rho > rho_max ? rho : rho_max;
    uu_max = uu > uu_max ? uu : uu_max;
    bad += S(0.0) * (rho + uu);
  }
  /// Into the call's result (one thread at a time).
  void merge_into(KernelExtrema& e) const {
    for (int i = 0; i < N; ++i) {
      e.rho_min = std::min(e.rho_min, double(rho_min[i]));
      e.rho_max = std::max(e.rho_max, double(rho_max[i]));
      e.u2_max = std::max(e.u2_max, double(uu_max[i]));
      if (!(bad[i] == S(0.0))) e.finite = false;
    }
  }
};

/// BGK collision (Eq. 10) with Guo forcing (Eq. 26) of a group of cells at once, the same
/// arithmetic as BgkGuo::collide; `f` holds the pulled (streamed, Eq. 9) populations and
/// receives the post-collision ones. Each pair (q, opp q) shares the even part of the
/// equilibrium (Eq. 11) and of the source S = E (3 (c - u).F + 9 (c.u)(c.F)):
///   f_eq = E rho (1 - 3/2 u.u + 9/2 (c.u)^2) +- E rho 3 c.u,
///   S    = E (9 (c.u)(c.F) - 3 u.F) +- E 3 c.F.
/// The first n cells' rho (Eq. 7) and u.u go into `ex`.
template <bool kForce, class V, class S = Scalar<V>>
[[gnu::always_inline]] inline void collide(V (&f)[L::Q], const CollisionConstants<S>& k, LaneExtrema<V>& ex,
                                           int n = lanes_of<V>) {
  const auto pairs = std::make_index_sequence<kPairs>{};
  const LaneMoments<V> m = moments(f, pairs);
  const LaneFlow<V> v = flow<kForce>(m, k);
  ex.take(m.rho, v.uu, n);
  // Rest direction: c = 0.
  f[0] += k.omega * (v.wrho[0] * v.even0 - f[0]) + v.src0[0];
  relax_pairs<kForce>(f, v, k, pairs);
}

/// The outflow ghost (fluid/boundary/boundary.hpp, outflow_ghost) of the cell in lane `lane` of the
/// post-collision group f: populations entering through the face (c_x = inward) stored at
/// g + q stride, g the ghost cell in population 0 of dst. From the values as stored (T), as
/// the ghost fill reads them back: a float store's values computed in double go through the
/// vector conversion of the store itself (to_stored_pop), and outflow_ghost widens them out of line (see there:
/// a (double)(float)x here was miscompiled).
template <class T, class V, class S>
inline void store_outflow_ghost(const V (&f)[L::Q], int lane, T* g, std::ptrdiff_t stride,
                                int inward, double rho_out, const CollisionConstants<S>& k) {
  T stored[L::Q], ghost[L::Q];
  for (int q = 0; q < L::Q; ++q) {
    const Stored<T, V> s = to_stored_pop<T>(f[q], k.shift[q]);
    std::memcpy(&stored[q], reinterpret_cast<const char*>(&s) + std::size_t(lane) * sizeof(T), sizeof(T));
  }
  outflow_ghost(stored, 0, inward, rho_out, ghost);
  for (int q = 0; q < L::Q; ++q)
    if (L::cx[q] == inward) g[q * stride] = ghost[q];
}

/// How far ahead of its group, in bytes along x, a kernel prefetches each of the 19 slots it
/// reads (8 cache lines): the cache's own prefetchers leave it waiting on memory. Measured on
/// the AMD EPYC of docs/results/in-place-20261202.md (AVX-512), interleaved runs of `bench --grids paper box
/// --threads 2 --precision double single --no-ib --repeat 3 --propagation ...` with and
/// without: the in-place step with the double store from 66-84 % of the same-run roofline to
/// 86-94 % (256 and 128 bytes ahead: 64-104 %), with the single store from 27-48 % to
/// 36-65 %, and with --level x86-64-v3 the double store's box from 54-58 % to 80-89 %; the
/// two-grid step from 59-74 to 71-100 MLUPS (double) and from 70-83 to 95-126 (single).
/// Those runs asked on every group; asking once per line (prefetch_ahead) measured the same
/// within the noise, both levels, with fewer instructions where a group is half a line.
/// Prefetches change no value: the same bits.
constexpr int kPrefetchBytes = 512;

/// Asks for the lines kPrefetchBytes past the 19 read slots base + slot[q] + x of the group
/// of cells from x on, once per line of x: a group narrower than a line (floats, or doubles
/// below AVX-512) asks only where x starts a line (every row starts at x = 0), so no line is
/// asked for twice. The address is formed as an integer: near the field's end it lies past
/// the allocation, and a prefetch never faults.
template <int N, class T>
[[gnu::always_inline]] inline void prefetch_ahead(const T* base, const std::ptrdiff_t (&slot)[L::Q], int x) {
  constexpr int kLineCells = GridLayout::kLineBytes / int(sizeof(T));
  if constexpr (N < kLineCells)
    if (x % kLineCells != 0) return;
#pragma GCC unroll 19
  for (int q = 0; q < L::Q; ++q)
    __builtin_prefetch(reinterpret_cast<const void*>(reinterpret_cast<std::uintptr_t>(base + slot[q] + x) + kPrefetchBytes));
}

/// row(r) for the rows r = 0 .. rows - 1, shared among the threads of the enclosing parallel
/// region as `schedule` says (RowSchedule::Dynamic: 64 chunks, see stream_collide.hpp); no
/// barrier at the end.
template <class Row>
[[gnu::always_inline]] inline void for_rows(std::ptrdiff_t rows, RowSchedule schedule, const Row& row) {
  if (schedule == RowSchedule::Dynamic) {
    const std::ptrdiff_t chunk = std::max<std::ptrdiff_t>(1, (rows + 63) / 64);
#pragma omp for schedule(dynamic, chunk) nowait
    for (std::ptrdiff_t r = 0; r < rows; ++r) row(r);
  } else {
#pragma omp for schedule(static) nowait
    for (std::ptrdiff_t r = 0; r < rows; ++r) row(r);
  }
}

/// The interior of the block row by row (OpenMP), a group V of cells of x at a time; the last,
/// partial group of a row goes through a padded copy. Outflow ghosts on x faces as the row's
/// first and last cells are stored (KernelOutflow).
///
/// Non-temporal stores must fill whole 64-byte lines back to back, or the write-combining
/// buffers, shared by the 19 streams, flush partial lines (a first single store that wrote
/// half lines was slower than the double one; on an AVX2 CPU the double store's half-line
/// stores moved data at about half the rate of whole lines, issue 21). A stored group is one
/// line with AVX-512 for the double store (8 doubles) and for the float store in float
/// arithmetic (16 floats); where it is less than a line (the float store in double arithmetic
/// on any level, the others below AVX-512) the kernel collides the groups of a line first, keeps
/// all but the last in a small buffer (L1) and then streams each population's line in one go.
template <class T, class V, bool kForce, bool kStream>
void update_rows(const BasicPopulationField<T>& src, BasicPopulationField<T>& dst, double tau,
                 const std::array<double, 3>& F, const KernelOutflow& out, KernelExtrema* extrema,
                 RowSchedule schedule) {
  if (extrema != nullptr) *extrema = KernelExtrema{};
  constexpr int N = lanes_of<V>;
  constexpr int kGroupBytes = N * int(sizeof(T));
  constexpr int kLineGroups = kStream && kGroupBytes < GridLayout::kLineBytes
                                  ? GridLayout::kLineBytes / kGroupBytes
                                  : 1;
  constexpr int kLineCells = kLineGroups * N;
  const GridLayout& lay = src.layout();
  const int nx = lay.nx(), ny = lay.ny();
  const std::ptrdiff_t rows = std::ptrdiff_t(ny) * lay.nz();
  const std::ptrdiff_t stride = std::ptrdiff_t(lay.stride());
  const CollisionConstants<Scalar<V>> k(tau, F);
  // Pull (Eq. 9): population q of cell i comes from src(q) at i - c_q.
  std::ptrdiff_t pull[L::Q];
  for (int q = 0; q < L::Q; ++q) pull[q] = q * stride - lay.offset(L::cx[q], L::cy[q], L::cz[q]);
  const T* const s0 = src.q(0);
  T* const d0 = dst.q(0);

#pragma omp parallel
  {
    alignas(GridLayout::kLineBytes) T line[kLineGroups > 1 ? L::Q : 1][kLineCells];
    LaneExtrema<V> ex;
    // One row of x; inlined into both schedules below.
    const auto row = [&](std::ptrdiff_t r) __attribute__((always_inline)) {
      const std::ptrdiff_t base = lay.index(0, int(r % ny), int(r / ny));
      const T* const s = s0 + base;
      T* const d = d0 + base;
      V f[L::Q];
      // Outflow ghosts of the cells x0 .. x0 + n - 1 of f, where the row ends.
      const auto edges = [&](int x0, int n) {
        if (out.x_min && x0 == 0) store_outflow_ghost(f, 0, d - 1, stride, 1, out.rho_x_min, k);
        if (out.x_max && x0 + n == nx)
          store_outflow_ghost(f, n - 1, d + nx, stride, -1, out.rho_x_max, k);
      };
      int x = 0;
      if constexpr (kLineGroups > 1) {
        for (; x + kLineCells <= nx; x += kLineCells) {
          for (int g = 0; g < kLineGroups; ++g) {
            const int xg = x + g * N;
            prefetch_ahead<N>(s, pull, xg);
#pragma GCC unroll 19
            for (int q = 0; q < L::Q; ++q) f[q] = load_pop<V>(s + pull[q] + xg, k.shift[q]);
            collide<kForce>(f, k, ex);
            edges(xg, N);
            if (g + 1 < kLineGroups) {
#pragma GCC unroll 19
              for (int q = 0; q < L::Q; ++q) store_pop_aligned(line[q] + g * N, f[q], k.shift[q]);
            }
          }
          // The last group goes from registers: a 64-byte load of a line that was just
          // stored as two halves would wait for the stores (no store forwarding).
#if defined(__AVX512F__)
          // Two half lines of 32 bytes (8 floats, or 16 halves moved as 8 floats' bytes).
          static_assert((std::is_same_v<T, float> || std::is_same_v<T, Half16>) && kLineGroups == 2);
#pragma GCC unroll 19
          for (int q = 0; q < L::Q; ++q)
            store_stream_pair(reinterpret_cast<float*>(static_cast<void*>(d + q * stride + x)),
                              load_aligned_single(reinterpret_cast<const float*>(static_cast<const void*>(line[q]))),
                              __builtin_bit_cast(LanesSingle, to_stored_pop<T>(f[q], k.shift[q])));
#else
#pragma GCC unroll 19
          for (int q = 0; q < L::Q; ++q) {
            store_pop_aligned(line[q] + (kLineGroups - 1) * N, f[q], k.shift[q]);
            store_stream_line(d + q * stride + x, line[q]);
          }
#endif
        }
        if (x < nx) {
          // The row's last, partial line: its cells, and the x = nx outflow ghost where that
          // falls in it, assembled in `line` and streamed whole. An ordinary store of half a
          // line among the non-temporal streams (the first version) took the paper grid's
          // kernel from 175 MLUPS (plain stores) down to 113. The layout gives the row this
          // line to itself (GridLayout::row_values); its values past the ghost are padding.
          const int n = nx - x;
          for (int g = 0; g < kLineGroups; ++g) {
            const int xg = x + g * N, ng = n - g * N;
            if (ng <= 0) {
#pragma GCC unroll 19
              for (int q = 0; q < L::Q; ++q) store_pop_aligned(line[q] + g * N, V{}, k.shift[q]);
              continue;
            }
            if (ng >= N) {
#pragma GCC unroll 19
              for (int q = 0; q < L::Q; ++q) f[q] = load_pop<V>(s + pull[q] + xg, k.shift[q]);
            } else {
              for (int q = 0; q < L::Q; ++q) f[q] = load_pop_partial<V>(s + pull[q] + xg, ng, k.shift[q]);
            }
            collide<kForce>(f, k, ex, ng < N ? ng : N);
            if (out.x_min && xg == 0) store_outflow_ghost(f, 0, d - 1, stride, 1, out.rho_x_min, k);
#pragma GCC unroll 19
            for (int q = 0; q < L::Q; ++q) store_pop_aligned(line[q] + g * N, f[q], k.shift[q]);
          }
          // Past the row's last cell the line holds the x = nx ghost and padding. An inlet's
          // static ghost is kept (KernelOutflow::keep_x_max_ghosts; read back only then: a
          // read of each line about to be streamed costs traffic); other ghosts are filled
          // after the kernel, or by it (outflow, below). Ghost and padding get zeros, not the
          // padded lanes of the last group, so that the stored bytes (checkpoints hold the
          // whole field) do not depend on the group width.
          for (int q = 0; q < L::Q; ++q) {
            line[q][n] = out.keep_x_max_ghosts ? d[q * stride + nx] : T{};
            for (int i = n + 1; i < kLineCells; ++i) line[q][i] = T{};
          }
          // f holds the last group with cells; x = nx - 1 is its lane (n - 1) % N.
          if (out.x_max)
            store_outflow_ghost(f, (n - 1) % N, line[0] + n, kLineCells, -1, out.rho_x_max, k);
#pragma GCC unroll 19
          for (int q = 0; q < L::Q; ++q) store_stream_line(d + q * stride + x, line[q]);
          x = nx;
        }
      }
      for (; x + N <= nx; x += N) {
        prefetch_ahead<N>(s, pull, x);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) f[q] = load_pop<V>(s + pull[q] + x, k.shift[q]);
        collide<kForce>(f, k, ex);
        edges(x, N);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) {
          // (The single store's rows end in its line loop above.)
          if constexpr (kStream && kLineGroups == 1) store_group_stream(d + q * stride + x, f[q]);
          else store_pop_aligned(d + q * stride + x, f[q], k.shift[q]);
        }
      }
      if (x < nx) {
        const int n = nx - x;
        for (int q = 0; q < L::Q; ++q) f[q] = load_pop_partial<V>(s + pull[q] + x, n, k.shift[q]);
        collide<kForce>(f, k, ex, n);
        edges(x, n);
        for (int q = 0; q < L::Q; ++q) store_pop_partial(d + q * stride + x, f[q], n, k.shift[q]);
      }
    };
    for_rows(rows, schedule, row);
    if constexpr (kStream) store_fence();  // before the barrier: others read dst next
    if (extrema != nullptr) {
#pragma omp critical(cosim_fluid_kernel_extrema)
      ex.merge_into(*extrema);
    }
  }
}

/// One in-place step (stream_collide_in_place in stream_collide.hpp) over the interior,
/// row by row (OpenMP), a group V of cells of x at a time. Each cell x reads its 19 pulled
/// populations from the slots `rd` and stores the collided ones to the slots `wr`, the same
/// 19 slots: from Canonical, f_q(x) = A[q](x - c_q) in and f*_q(x) to A[opp q](x + c_q); from
/// Swapped, f_q(x) = A[opp q](x) in and f*_q(x) to A[q](x). No two cells share a slot, so
/// the groups of a row and the rows of the threads never touch each other's values. The
/// lines a group stores were just loaded: ordinary stores (no write-allocate read), unaligned
/// where the slot is shifted along x.
template <class T, class V, bool kForce>
void update_in_place(BasicPopulationField<T>& f, bool from_canonical, double tau,
                     const std::array<double, 3>& F, KernelExtrema* extrema, RowSchedule schedule,
                     const InPlaceXFaces* x_faces, KernelRows some) {
  if (extrema != nullptr) *extrema = KernelExtrema{};
  constexpr int N = lanes_of<V>;
  const GridLayout& lay = f.layout();
  const int nx = lay.nx(), ny = lay.ny();
  const std::ptrdiff_t rows = std::ptrdiff_t(ny) * lay.nz();
  const std::ptrdiff_t stride = std::ptrdiff_t(lay.stride());
  const CollisionConstants<Scalar<V>> k(tau, F);
  std::ptrdiff_t rd[L::Q], wr[L::Q];
  for (int q = 0; q < L::Q; ++q) {
    const std::ptrdiff_t c = lay.offset(L::cx[q], L::cy[q], L::cz[q]);
    if (from_canonical) {
      rd[q] = q * stride - c;
      wr[q] = L::opp[q] * stride + c;
    } else {
      rd[q] = L::opp[q] * stride;
      wr[q] = q * stride;
    }
  }
  T* const f0 = f.q(0);

#pragma omp parallel
  {
    LaneExtrema<V> ex;
    const auto row = [&](std::ptrdiff_t r) __attribute__((always_inline)) {
      const int y = int(r % ny);
      T* const c = f0 + lay.index(0, y, int(r / ny));
      V v[L::Q];
      int x = 0;
      for (; x + N <= nx; x += N) {
        prefetch_ahead<N>(c, rd, x);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) v[q] = load_pop<V>(c + rd[q] + x, k.shift[q]);
        collide<kForce>(v, k, ex);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) store_pop(c + wr[q] + x, v[q], k.shift[q]);
      }
      if (x < nx) {
        const int n = nx - x;
        for (int q = 0; q < L::Q; ++q) v[q] = load_pop_partial<V>(c + rd[q] + x, n, k.shift[q]);
        collide<kForce>(v, k, ex, n);
        for (int q = 0; q < L::Q; ++q) store_pop_partial(c + wr[q] + x, v[q], n, k.shift[q]);
      }
      if (x_faces != nullptr) in_place_x_ghosts(c, wr, nx, y, *x_faces);
    };
    if (some.rows == nullptr)
      for_rows(rows, schedule, row);
    else
      for_rows(some.count, schedule, [&](std::ptrdiff_t i) { row(some.rows[i]); });
    if (extrema != nullptr) {
#pragma omp critical(cosim_fluid_kernel_extrema)
      ex.merge_into(*extrema);
    }
  }
}

/// The kernel for a store T and a group V of the arithmetic (Lanes: double, LanesFloat: float).
template <class T, class V>
void run_in_place(BasicPopulationField<T>& f, bool from_canonical, double tau,
                  const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                  const InPlaceXFaces* x_faces, KernelRows rows) {
  if (force[0] == 0.0 && force[1] == 0.0 && force[2] == 0.0)
    update_in_place<T, V, false>(f, from_canonical, tau, force, extrema, schedule, x_faces, rows);
  else
    update_in_place<T, V, true>(f, from_canonical, tau, force, extrema, schedule, x_faces, rows);
}

template <class T, class V>
void run(const BasicPopulationField<T>& src, BasicPopulationField<T>& dst, double tau,
         const std::array<double, 3>& force, bool nt, const KernelOutflow& outflow,
         KernelExtrema* extrema, RowSchedule schedule) {
  if (force[0] == 0.0 && force[1] == 0.0 && force[2] == 0.0)
    nt ? update_rows<T, V, false, true>(src, dst, tau, force, outflow, extrema, schedule)
       : update_rows<T, V, false, false>(src, dst, tau, force, outflow, extrema, schedule);
  else
    nt ? update_rows<T, V, true, true>(src, dst, tau, force, outflow, extrema, schedule)
       : update_rows<T, V, true, false>(src, dst, tau, force, outflow, extrema, schedule);
}

}  // namespace

extern const KernelTable kernel_table;
const KernelTable kernel_table{kIsaLevel,
                               kIsaVectors,
                               kLanes,
                               kHasStreamingStores,
                               &run<double, Lanes>,
                               &run<float, Lanes>,
                               &run<float, LanesFloat>,
                               &run<Half16, LanesFloat>,
                               &run_in_place<double, Lanes>,
                               &run_in_place<float, Lanes>,
                               &run_in_place<float, LanesFloat>,
                               &run_in_place<Half16, LanesFloat>};

}  // namespace cosim::fluid::COSIM_ISA_NS
