#include "fluid/stream_collide.hpp"

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <utility>

#include "fluid/d3q19.hpp"
#include "fluid/lanes.hpp"

namespace cosim::fluid {

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

/// a + c v for a lattice velocity component c in {-1, 0, 1}; no multiplication by zero.
template <int c>
Lanes add_c(Lanes a, Lanes v) {
  if constexpr (c == 1) return a + v;
  if constexpr (c == -1) return a - v;
  return a;
}

/// c_q . a for direction q, a compile-time constant.
template <int q>
Lanes dot_c(Lanes ax, Lanes ay, Lanes az) {
  return add_c<L::cz[q]>(add_c<L::cy[q]>(add_c<L::cx[q]>(Lanes{}, ax), ay), az);
}

/// Per-call constants of the collision: relaxation rate, the body force and the
/// velocity-independent parts of Guo's source term.
struct CollisionConstants {
  double omega;                    ///< 1 / tau
  double keep;                     ///< 1 - omega
  double Fx, Fy, Fz;               ///< uniform force density
  double src_pref;                 ///< 1 - omega / 2 (Eq. 26)
  double cF3[kPairs], cF9[kPairs]; ///< src_pref E_q 3 c_q.F and 9 c_q.F for q of each pair

  CollisionConstants(double tau, const std::array<double, 3>& F)
      : omega(1.0 / tau), keep(1.0 - omega), Fx(F[0]), Fy(F[1]), Fz(F[2]),
        src_pref(1.0 - 0.5 * omega) {
    for (int p = 0; p < kPairs; ++p) {
      const int q = pair_q(p);
      const double cF = L::cx[q] * Fx + L::cy[q] * Fy + L::cz[q] * Fz;
      cF3[p] = src_pref * L::w[q] * 3.0 * cF;
      cF9[p] = src_pref * L::w[q] * 9.0 * cF;
    }
  }
};

/// BGK collision (Eq. 10) with Guo forcing (Eq. 26) of kLanes cells at once; `f` holds the
/// pulled (streamed, Eq. 9) populations and receives the post-collision ones.
///
/// Each pair (q, opp q) shares the even part of the equilibrium (Eq. 11),
///   f_eq = E rho (1 - 3/2 u.u + 9/2 (c.u)^2) +- E rho 3 c.u,
/// and of the source S = E (3 (c - u).F + 9 (c.u)(c.F)),
///   S = E (9 (c.u)(c.F) - 3 u.F) +- E 3 c.F.
template <bool kForce>
void collide(Lanes (&f)[L::Q], const CollisionConstants& k) {
  // Moments (Eqs. 7-8) from pair sums and differences.
  Lanes rho = f[0], jx{}, jy{}, jz{};
  Lanes diff[kPairs];
  [&]<std::size_t... P>(std::index_sequence<P...>) {
    ((rho += f[pair_q(P)] + f[pair_q(P) + 1], diff[P] = f[pair_q(P)] - f[pair_q(P) + 1],
      jx = add_c<L::cx[pair_q(P)]>(jx, diff[P]), jy = add_c<L::cy[pair_q(P)]>(jy, diff[P]),
      jz = add_c<L::cz[pair_q(P)]>(jz, diff[P])),
     ...);
  }(std::make_index_sequence<kPairs>{});

  const Lanes inv_rho = 1.0 / rho;
  Lanes ux = jx * inv_rho, uy = jy * inv_rho, uz = jz * inv_rho;
  if constexpr (kForce) {  // Guo's velocity: u = (j + F/2) / rho
    ux += (0.5 * k.Fx) * inv_rho;
    uy += (0.5 * k.Fy) * inv_rho;
    uz += (0.5 * k.Fz) * inv_rho;
  }
  const Lanes even0 = 1.0 - 1.5 * (ux * ux + uy * uy + uz * uz);
  // omega E rho for the two weights of the moving directions.
  const Lanes orho = k.omega * rho;
  const Lanes owr[2] = {orho * L::w[1], orho * L::w[7]};
  Lanes src0[2] = {};  // -src_pref E 3 u.F, the even part of the source without c.F
  Lanes rest = (orho * L::w[0]) * even0;
  if constexpr (kForce) {
    const Lanes uF3 = (-3.0 * k.src_pref) * (ux * k.Fx + uy * k.Fy + uz * k.Fz);
    src0[0] = uF3 * L::w[1];
    src0[1] = uF3 * L::w[7];
    rest += uF3 * L::w[0];
  }
  f[0] = k.keep * f[0] + rest;

  [&]<std::size_t... P>(std::index_sequence<P...>) {
    (
        [&] {
          constexpr int q = pair_q(P), o = q + 1, wi = L::w[q] == L::w[1] ? 0 : 1;
          const Lanes cu = dot_c<q>(ux, uy, uz);
          Lanes even = owr[wi] * (even0 + 4.5 * cu * cu);
          Lanes odd = owr[wi] * (3.0 * cu);
          if constexpr (kForce) {
            even += src0[wi] + k.cF9[P] * cu;
            odd += k.cF3[P];
          }
          f[q] = k.keep * f[q] + (even + odd);
          f[o] = k.keep * f[o] + (even - odd);
        }(),
        ...);
  }(std::make_index_sequence<kPairs>{});
}

/// The interior of the block row by row (OpenMP), kLanes cells of x at a time; the last,
/// partial group of a row goes through a padded copy.
template <bool kForce, bool kStream>
void update_rows(const PopulationField& src, PopulationField& dst, double tau,
                 const std::array<double, 3>& F) {
  const GridLayout& lay = src.layout();
  const int nx = lay.nx(), ny = lay.ny();
  const std::ptrdiff_t rows = std::ptrdiff_t(ny) * lay.nz();
  const std::ptrdiff_t stride = std::ptrdiff_t(lay.stride());
  const CollisionConstants k(tau, F);
  // Pull (Eq. 9): population q of cell i comes from src(q) at i - c_q.
  std::ptrdiff_t pull[L::Q];
  for (int q = 0; q < L::Q; ++q) pull[q] = q * stride - lay.offset(L::cx[q], L::cy[q], L::cz[q]);
  const double* const s0 = src.q(0);
  double* const d0 = dst.q(0);
  const int full = nx / kLanes * kLanes;
  static const int pf = std::getenv("PF") ? std::atoi(std::getenv("PF")) : 0;

#pragma omp parallel
  {
#pragma omp for schedule(static) nowait
    for (std::ptrdiff_t r = 0; r < rows; ++r) {
      const std::ptrdiff_t base = lay.index(0, int(r % ny), int(r / ny));
      const double* const s = s0 + base;
      double* const d = d0 + base;
      Lanes f[L::Q];
      for (int x = 0; x < full; x += kLanes) {
  #pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) f[q] = load(s + pull[q] + x);
        if (pf) {
  #pragma GCC unroll 19
          for (int q = 0; q < L::Q; ++q) __builtin_prefetch(s + pull[q] + x + pf);
        }
        collide<kForce>(f, k);
  #pragma GCC unroll 19
        for (int q = 0; q < L::Q; ++q) {
          if constexpr (kStream) store_stream(d + q * stride + x, f[q]);
          else store_aligned(d + q * stride + x, f[q]);
        }
      }
      if (full < nx) {
        const int n = nx - full;
        for (int q = 0; q < L::Q; ++q) f[q] = load_partial(s + pull[q] + full, n);
        collide<kForce>(f, k);
        for (int q = 0; q < L::Q; ++q) store_partial(d + q * stride + full, f[q], n);
      }
    }
    if constexpr (kStream) store_fence();  // before the barrier: others read dst next
  }
}

}  // namespace

void stream_collide(const PopulationField& src, PopulationField& dst, double tau,
                    const std::array<double, 3>& force) {
  static const bool nt = std::getenv("NT") != nullptr;
  if (force[0] == 0.0 && force[1] == 0.0 && force[2] == 0.0)
    nt ? update_rows<false, true>(src, dst, tau, force) : update_rows<false, false>(src, dst, tau, force);
  else
    nt ? update_rows<true, true>(src, dst, tau, force) : update_rows<true, false>(src, dst, tau, force);
}

}  // namespace cosim::fluid
