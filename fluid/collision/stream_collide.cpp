// The kernel's body, compiled once per instruction-set level into namespace COSIM_ISA_NS
// (fluid/CMakeLists.txt, cosim_isa_objects); fluid/collision/kernel_dispatch.cpp picks one at run time
// and holds the public stream_collide().
#include "fluid/collision/stream_collide.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
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

// The per-cell helpers below are forced inline ([[gnu::always_inline]]) so that the
// kLanes-wide values of a cell group stay in registers.

/// a + c v for a lattice velocity component c in {-1, 0, 1}; no multiplication by zero.
template <int c>
[[gnu::always_inline]] inline Lanes add_c(Lanes a, Lanes v) {
  if constexpr (c == 1) return a + v;
  if constexpr (c == -1) return a - v;
  return a;
}

/// c v for c in {-1, 1}.
template <int c>
[[gnu::always_inline]] inline Lanes times_c(Lanes v) {
  static_assert(c == 1 || c == -1);
  if constexpr (c == 1) return v;
  return -v;
}

/// c_q . a for a direction q (not the rest direction) known at compile time.
template <int q>
[[gnu::always_inline]] inline Lanes dot_c(Lanes ax, Lanes ay, Lanes az) {
  if constexpr (L::cx[q] != 0)
    return add_c<L::cz[q]>(add_c<L::cy[q]>(times_c<L::cx[q]>(ax), ay), az);
  else if constexpr (L::cy[q] != 0)
    return add_c<L::cz[q]>(times_c<L::cy[q]>(ay), az);
  else
    return times_c<L::cz[q]>(az);
}

/// Per-call constants of the collision: relaxation rate, the body force and the
/// velocity-independent parts of Guo's source term.
struct CollisionConstants {
  double omega;                     ///< 1 / tau
  double Fx, Fy, Fz;                ///< uniform force density
  double src_pref;                  ///< 1 - omega / 2 (Eq. 26)
  double cF3[kPairs], cF9[kPairs];  ///< src_pref E_q 3 c_q.F and 9 c_q.F, q of each pair

  CollisionConstants(double tau, const std::array<double, 3>& F)
      : omega(1.0 / tau), Fx(F[0]), Fy(F[1]), Fz(F[2]), src_pref(1.0 - 0.5 * omega) {
    for (int p = 0; p < kPairs; ++p) {
      const int q = pair_q(p);
      const double cF = L::cx[q] * Fx + L::cy[q] * Fy + L::cz[q] * Fz;
      cF3[p] = src_pref * L::w[q] * 3.0 * cF;
      cF9[p] = src_pref * L::w[q] * 9.0 * cF;
    }
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

/// rho (Eq. 7) and j = rho v (Eq. 8) of kLanes cells.
struct LaneMoments {
  Lanes rho, jx, jy, jz;
};

/// Adds the pair (q, opp q) to the moments: both to rho (one by one, in the order of
/// moments() in fluid/lattice/equilibrium.hpp: same rounding as the one-cell reference), their
/// difference along c_q to j.
template <int q>
[[gnu::always_inline]] inline void add_pair(LaneMoments& m, Lanes fq, Lanes fo) {
  m.rho = (m.rho + fq) + fo;
  const Lanes d = fq - fo;
  m.jx = add_c<L::cx[q]>(m.jx, d);
  m.jy = add_c<L::cy[q]>(m.jy, d);
  m.jz = add_c<L::cz[q]>(m.jz, d);
}

template <std::size_t... P>
[[gnu::always_inline]] inline LaneMoments moments(const Lanes (&f)[L::Q],
                                                 std::index_sequence<P...>) {
  LaneMoments m{f[0], {}, {}, {}};
  (add_pair<pair_q(P)>(m, f[pair_q(P)], f[pair_q(P) + 1]), ...);
  return m;
}

/// What the relaxation of every direction needs from a cell: Guo's velocity and the parts
/// of f_eq (Eq. 11) and of the source that do not depend on the direction.
struct LaneFlow {
  Lanes ux, uy, uz;
  Lanes uu;       ///< u.u
  Lanes even0;    ///< 1 - 3/2 u.u
  Lanes wrho[3];  ///< E rho for E = 1/3, 1/18, 1/36 (weight_class)
  Lanes src0[3];  ///< (1 - omega/2) E (-3 u.F), the part of S without c.F
};

template <bool kForce>
[[gnu::always_inline]] inline LaneFlow flow(const LaneMoments& m, const CollisionConstants& k) {
  LaneFlow v;
  const Lanes inv_rho = 1.0 / m.rho;
  // Guo's velocity u = (j + F/2) / rho
  v.ux = (kForce ? m.jx + 0.5 * k.Fx : m.jx) * inv_rho;
  v.uy = (kForce ? m.jy + 0.5 * k.Fy : m.jy) * inv_rho;
  v.uz = (kForce ? m.jz + 0.5 * k.Fz : m.jz) * inv_rho;
  v.uu = v.ux * v.ux + v.uy * v.uy + v.uz * v.uz;
  v.even0 = 1.0 - 1.5 * v.uu;
  const Lanes uF3 = kForce ? (-3.0 * k.src_pref) * (v.ux * k.Fx + v.uy * k.Fy + v.uz * k.Fz)
                           : Lanes{};
  for (int c = 0; c < 3; ++c) {
    v.wrho[c] = m.rho * kWeights[c];
    v.src0[c] = kForce ? uF3 * kWeights[c] : Lanes{};
  }
  return v;
}

/// f_q += omega (f_eq_q - f_q) + (1 - omega/2) S_q for the pair (q, opp q) of pair P;
/// f_eq and S split into the parts even and odd in c (see collide).
template <bool kForce, int P>
[[gnu::always_inline]] inline void relax_pair(Lanes& fq, Lanes& fo, const LaneFlow& v,
                                              const CollisionConstants& k) {
  constexpr int q = pair_q(P), wi = weight_class(q);
  const Lanes cu = dot_c<q>(v.ux, v.uy, v.uz);
  const Lanes even = v.wrho[wi] * (v.even0 + 4.5 * cu * cu);
  const Lanes odd = v.wrho[wi] * (3.0 * cu);
  Lanes src_even{}, src_odd{};
  if constexpr (kForce) {
    src_even = v.src0[wi] + k.cF9[P] * cu;
    src_odd = Lanes{} + k.cF3[P];
  }
  fq += k.omega * ((even + odd) - fq) + (src_even + src_odd);
  fo += k.omega * ((even - odd) - fo) + (src_even - src_odd);
}

template <bool kForce, std::size_t... P>
[[gnu::always_inline]] inline void relax_pairs(Lanes (&f)[L::Q], const LaneFlow& v,
                                               const CollisionConstants& k,
                                               std::index_sequence<P...>) {
  (relax_pair<kForce, int(P)>(f[pair_q(P)], f[pair_q(P) + 1], v, k), ...);
}

/// The extrema the kernel gathers of the cells it collides (KernelExtrema): a thread's
/// running values, lane by lane.
struct LaneExtrema {
  Lanes rho_min = Lanes{} + std::numeric_limits<double>::infinity();
  Lanes rho_max = Lanes{} - std::numeric_limits<double>::infinity();
  Lanes uu_max = Lanes{};
  Lanes bad = Lanes{};  ///< NaN once a rho or u.u was not finite (0 inf and 0 NaN are NaN)
  /// The first n lanes of a group (a row's partial group pads with cells of rho = 19).
  void take(Lanes rho, Lanes uu, int n = kLanes) {
    if (n < kLanes) {
      // Lanes past n repeat lane 0.
      for (int i = n; i < kLanes; ++i) {
        rho[i] = rho[0];
        uu[i] = uu[0];
      }
    }
    rho_min = rho < rho_min ? rho : rho_min;
    rho_max = rho > rho_max ? rho : rho_max;
    uu_max = uu > uu_max ? uu : uu_max;
    bad += 0.0 * (rho + uu);
  }
  /// Into the call's result (one thread at a time).
  void merge_into(KernelExtrema& e) const {
    for (int i = 0; i < kLanes; ++i) {
      e.rho_min = std::min(e.rho_min, rho_min[i]);
      e.rho_max = std::max(e.rho_max, rho_max[i]);
      e.u2_max = std::max(e.u2_max, uu_max[i]);
      if (!(bad[i] == 0.0)) e.finite = false;
    }
  }
};

/// BGK collision (Eq. 10) with Guo forcing (Eq. 26) of kLanes cells at once, the same
/// arithmetic as BgkGuo::collide; `f` holds the pulled (streamed, Eq. 9) populations and
/// receives the post-collision ones. Each pair (q, opp q) shares the even part of the
/// equilibrium (Eq. 11) and of the source S = E (3 (c - u).F + 9 (c.u)(c.F)):
///   f_eq = E rho (1 - 3/2 u.u + 9/2 (c.u)^2) +- E rho 3 c.u,
///   S    = E (9 (c.u)(c.F) - 3 u.F) +- E 3 c.F.
/// The first n cells' rho (Eq. 7) and u.u go into `ex`.
template <bool kForce>
[[gnu::always_inline]] inline void collide(Lanes (&f)[L::Q], const CollisionConstants& k, LaneExtrema& ex,
                                           int n = kLanes) {
  const auto pairs = std::make_index_sequence<kPairs>{};
  const LaneMoments m = moments(f, pairs);
  const LaneFlow v = flow<kForce>(m, k);
  ex.take(m.rho, v.uu, n);
  // Rest direction: c = 0.
  f[0] += k.omega * (v.wrho[0] * v.even0 - f[0]) + v.src0[0];
  relax_pairs<kForce>(f, v, k, pairs);
}

/// The outflow ghost (fluid/boundary/boundary.hpp, outflow_ghost) of the cell in lane `lane` of the
/// post-collision group f: populations entering through the face (c_x = inward) stored at
/// g + q stride, g the ghost cell in population 0 of dst. From the values as stored (T), as
/// the ghost fill reads them back: a float store's values go through the vector conversion
/// of the store itself (to_single), and outflow_ghost widens them out of line (see there:
/// a (double)(float)x here was miscompiled).
template <class T>
inline void store_outflow_ghost(const Lanes (&f)[L::Q], int lane, T* g, std::ptrdiff_t stride,
                                int inward, double rho_out) {
  T stored[L::Q], ghost[L::Q];
  for (int q = 0; q < L::Q; ++q) {
    if constexpr (std::is_same_v<T, float>)
      stored[q] = to_single(f[q])[lane];
    else
      stored[q] = f[q][lane];
  }
  outflow_ghost(stored, 0, inward, rho_out, ghost);
  for (int q = 0; q < L::Q; ++q)
    if (L::cx[q] == inward) g[q * stride] = ghost[q];
}

/// How far ahead of its group, in bytes along x, a kernel prefetches each of the 19 slots it
/// reads (8 cache lines): the cache's own prefetchers leave it waiting on memory. Measured on
/// the AMD EPYC of docs/performance.md (AVX-512), interleaved runs of `bench --grids paper box
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
template <class T>
[[gnu::always_inline]] inline void prefetch_ahead(const T* base, const std::ptrdiff_t (&slot)[L::Q], int x) {
  constexpr int kLineCells = GridLayout::kLineBytes / int(sizeof(T));
  if constexpr (kLanes < kLineCells)
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

/// The interior of the block row by row (OpenMP), kLanes cells of x at a time; the last,
/// partial group of a row goes through a padded copy. Outflow ghosts on x faces as the row's
/// first and last cells are stored (KernelOutflow).
///
/// Non-temporal stores must fill whole 64-byte lines back to back, or the write-combining
/// buffers, shared by the 19 streams, flush partial lines (a first single store that wrote
/// half lines was slower than the double one; on an AVX2 CPU the double store's half-line
/// stores moved data at about half the rate of whole lines, issue 21). A group of kLanes
/// doubles is one line with AVX-512; where a stored group is less than a line (floats on
/// any level, doubles below AVX-512) the kernel collides the groups of a line first, keeps
/// all but the last in a small buffer (L1) and then streams each population's line in one go.
template <class T, bool kForce, bool kStream>
void update_rows(const BasicPopulationField<T>& src, BasicPopulationField<T>& dst, double tau,
                 const std::array<double, 3>& F, const KernelOutflow& out, KernelExtrema* extrema,
                 RowSchedule schedule) {
  if (extrema != nullptr) *extrema = KernelExtrema{};
  constexpr int kGroupBytes = kLanes * int(sizeof(T));
  constexpr int kLineGroups = kStream && kGroupBytes < GridLayout::kLineBytes
                                  ? GridLayout::kLineBytes / kGroupBytes
                                  : 1;
  constexpr int kLineCells = kLineGroups * kLanes;
  const GridLayout& lay = src.layout();
  const int nx = lay.nx(), ny = lay.ny();
  const std::ptrdiff_t rows = std::ptrdiff_t(ny) * lay.nz();
  const std::ptrdiff_t stride = std::ptrdiff_t(lay.stride());
  const CollisionConstants k(tau, F);
  // Pull (Eq. 9): population q of cell i comes from src(q) at i - c_q.
  std::ptrdiff_t pull[L::Q];
  for (int q = 0; q < L::Q; ++q) pull[q] = q * stride - lay.offset(L::cx[q], L::cy[q], L::cz[q]);
  const T* const s0 = src.q(0);
  T* const d0 = dst.q(0);

#pragma omp parallel
  {
    alignas(GridLayout::kLineBytes) T line[kLineGroups > 1 ? L::Q : 1][kLineCells];
    LaneExtrema ex;
    // One row of x; inlined into both schedules below.
    const auto row = [&](std::ptrdiff_t r) __attribute__((always_inline)) {
      const std::ptrdiff_t base = lay.index(0, int(r % ny), int(r / ny));
      const T* const s = s0 + base;
      T* const d = d0 + base;
      Lanes f[L::Q];
      // Outflow ghosts of the cells x0 .. x0 + n - 1 of f, where the row ends.
      const auto edges = [&](int x0, int n) {
        if (out.x_min && x0 == 0) store_outflow_ghost(f, 0, d - 1, stride, 1, out.rho_x_min);
        if (out.x_max && x0 + n == nx)
          store_outflow_ghost(f, n - 1, d + nx, stride, -1, out.rho_x_max);
      };
      int x = 0;
      if constexpr (kLineGroups > 1) {
        for (; x + kLineCells <= nx; x += kLineCells) {
          for (int g = 0; g < kLineGroups; ++g) {
            const int xg = x + g * kLanes;
            prefetch_ahead(s, pull, xg);
#pragma GCC unroll 19
            for (int q = 0; q < L::Q; ++q) f[q] = load(s + pull[q] + xg);
            collide<kForce>(f, k, ex);
            edges(xg, kLanes);
            if (g + 1 < kLineGroups) {
#pragma GCC unroll 19
              for (int q = 0; q < L::Q; ++q) store_aligned(line[q] + g * kLanes, f[q]);
            }
          }
          // The last group goes from registers: a 64-byte load of a line that was just
          // stored as two halves would wait for the stores (no store forwarding).
#if defined(__AVX512F__)
          static_assert(std::is_same_v<T, float> && kLineGroups == 2);
#pragma GCC unroll 19
          for (int q = 0; q < L::Q; ++q)
            store_stream_pair(d + q * stride + x, load_aligned_single(line[q]), to_single(f[q]));
#else
#pragma GCC unroll 19
          for (int q = 0; q < L::Q; ++q) {
            store_aligned(line[q] + (kLineGroups - 1) * kLanes, f[q]);
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
            const int xg = x + g * kLanes, ng = n - g * kLanes;
            if (ng <= 0) {
#pragma GCC unroll 19
              for (int q = 0; q < L::Q; ++q) store_aligned(line[q] + g * kLanes, Lanes{});
              continue;
            }
            if (ng >= kLanes) {
#pragma GCC unroll 19
              for (int q = 0; q < L::Q; ++q) f[q] = load(s + pull[q] + xg);
            } else {
              for (int q = 0; q < L::Q; ++q) f[q] = load_partial(s + pull[q] + xg, ng);
            }
            collide<kForce>(f, k, ex, ng < kLanes ? ng : kLanes);
            if (out.x_min && xg == 0) store_outflow_ghost(f, 0, d - 1, stride, 1, out.rho_x_min);
#pragma GCC unroll 19
            for (int q = 0; q < L::Q; ++q) store_aligned(line[q] + g * kLanes, f[q]);
          }
          // Past the row's last cell the line holds the x = nx ghost and padding. An inlet's
          // static ghost is kept (KernelOutflow::keep_x_max_ghosts; read back only then: a
          // read of each line about to be streamed costs traffic); other ghosts are filled
          // after the kernel, or by it (outflow, below). Ghost and padding get zeros, not the
          // padded lanes of the last group, so that the stored bytes (checkpoints hold the
          // whole field) do not depend on the group width.
          for (int q = 0; q < L::Q; ++q) {
            line[q][n] = out.keep_x_max_ghosts ? d[q * stride + nx] : T(0);
            for (int i = n + 1; i < kLineCells; ++i) line[q][i] = T(0);
          }
          // f holds the last group with cells; x = nx - 1 is its lane (n - 1) % kLanes.
          if (out.x_max)
            store_outflow_ghost(f, (n - 1) % kLanes, line[0] + n, kLineCells, -1, out.rho_x_max);
#pragma GCC unroll 19
          for (int q = 0; q < L::Q; ++q) store_stream_line(d + q * stride + x, line[q]);
          x = nx;
        }
      }
      for (; x + kLanes <= nx; x += kLanes) {
        prefetch_ahead(s, pull, x);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) f[q] = load(s + pull[q] + x);
        collide<kForce>(f, k, ex);
        edges(x, kLanes);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) {
          // (The single store's rows end in its line loop above.)
          if constexpr (kStream && kLineGroups == 1) store_stream(d + q * stride + x, f[q]);
          else store_aligned(d + q * stride + x, f[q]);
        }
      }
      if (x < nx) {
        const int n = nx - x;
        for (int q = 0; q < L::Q; ++q) f[q] = load_partial(s + pull[q] + x, n);
        collide<kForce>(f, k, ex, n);
        edges(x, n);
        for (int q = 0; q < L::Q; ++q) store_partial(d + q * stride + x, f[q], n);
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
/// row by row (OpenMP), kLanes cells of x at a time. Each cell x reads its 19 pulled
/// populations from the slots `rd` and stores the collided ones to the slots `wr`, the same
/// 19 slots: from Canonical, f_q(x) = A[q](x - c_q) in and f*_q(x) to A[opp q](x + c_q); from
/// Swapped, f_q(x) = A[opp q](x) in and f*_q(x) to A[q](x). No two cells share a slot, so
/// the groups of a row and the rows of the threads never touch each other's values. The
/// lines a group stores were just loaded: ordinary stores (no write-allocate read), unaligned
/// where the slot is shifted along x.
template <class T, bool kForce>
void update_in_place(BasicPopulationField<T>& f, bool from_canonical, double tau,
                     const std::array<double, 3>& F, KernelExtrema* extrema, RowSchedule schedule,
                     const InPlaceXFaces* x_faces) {
  if (extrema != nullptr) *extrema = KernelExtrema{};
  const GridLayout& lay = f.layout();
  const int nx = lay.nx(), ny = lay.ny();
  const std::ptrdiff_t rows = std::ptrdiff_t(ny) * lay.nz();
  const std::ptrdiff_t stride = std::ptrdiff_t(lay.stride());
  const CollisionConstants k(tau, F);
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
    LaneExtrema ex;
    const auto row = [&](std::ptrdiff_t r) __attribute__((always_inline)) {
      const int y = int(r % ny);
      T* const c = f0 + lay.index(0, y, int(r / ny));
      Lanes v[L::Q];
      int x = 0;
      for (; x + kLanes <= nx; x += kLanes) {
        prefetch_ahead(c, rd, x);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) v[q] = load(c + rd[q] + x);
        collide<kForce>(v, k, ex);
#pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) store_unaligned(c + wr[q] + x, v[q]);
      }
      if (x < nx) {
        const int n = nx - x;
        for (int q = 0; q < L::Q; ++q) v[q] = load_partial(c + rd[q] + x, n);
        collide<kForce>(v, k, ex, n);
        for (int q = 0; q < L::Q; ++q) store_partial(c + wr[q] + x, v[q], n);
      }
      if (x_faces != nullptr) in_place_x_ghosts(c, wr, nx, y, *x_faces);
    };
    for_rows(rows, schedule, row);
    if (extrema != nullptr) {
#pragma omp critical(cosim_fluid_kernel_extrema)
      ex.merge_into(*extrema);
    }
  }
}

template <class T>
void run_in_place(BasicPopulationField<T>& f, bool from_canonical, double tau,
                  const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                  const InPlaceXFaces* x_faces) {
  if (force[0] == 0.0 && force[1] == 0.0 && force[2] == 0.0)
    update_in_place<T, false>(f, from_canonical, tau, force, extrema, schedule, x_faces);
  else
    update_in_place<T, true>(f, from_canonical, tau, force, extrema, schedule, x_faces);
}

template <class T>
void run(const BasicPopulationField<T>& src, BasicPopulationField<T>& dst, double tau,
         const std::array<double, 3>& force, bool nt, const KernelOutflow& outflow,
         KernelExtrema* extrema, RowSchedule schedule) {
  if (force[0] == 0.0 && force[1] == 0.0 && force[2] == 0.0)
    nt ? update_rows<T, false, true>(src, dst, tau, force, outflow, extrema, schedule)
       : update_rows<T, false, false>(src, dst, tau, force, outflow, extrema, schedule);
  else
    nt ? update_rows<T, true, true>(src, dst, tau, force, outflow, extrema, schedule)
       : update_rows<T, true, false>(src, dst, tau, force, outflow, extrema, schedule);
}

}  // namespace

extern const KernelTable kernel_table;
const KernelTable kernel_table{kIsaLevel,        kIsaVectors,         kLanes,
                               kHasStreamingStores, &run<double>,       &run<float>,
                               &run_in_place<double>, &run_in_place<float>};

}  // namespace cosim::fluid::COSIM_ISA_NS
