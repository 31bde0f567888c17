#include "fluid/stream_collide.hpp"

#include <cstddef>

#include "fluid/d3q19.hpp"

namespace cosim::fluid {

namespace {

using L = D3Q19;

/// The cell update written once for the vectoriser: every direction index is a
/// compile-time constant after unrolling, so c_q products fold to additions.
template <bool kForce>
void update_rows(const PopulationField& src, PopulationField& dst, double tau,
                 const std::array<double, 3>& F) {
  const GridLayout& lay = src.layout();
  const int nx = lay.nx(), ny = lay.ny();
  const std::ptrdiff_t rows = std::ptrdiff_t(ny) * lay.nz();
  const double omega = 1.0 / tau;
  const double src_pref = 1.0 - 0.5 * omega;
  const double Fx = F[0], Fy = F[1], Fz = F[2];

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t r = 0; r < rows; ++r) {
    const int y = int(r % ny), z = int(r / ny);
    const std::ptrdiff_t base = lay.index(0, y, z);
    const double* __restrict s[L::Q];
    double* __restrict d[L::Q];
#pragma GCC unroll 19
    for (int q = 0; q < L::Q; ++q) {
      s[q] = src.q(q) + base - lay.offset(L::cx[q], L::cy[q], L::cz[q]);
      d[q] = dst.q(q) + base;
    }
#pragma omp simd
    for (int x = 0; x < nx; ++x) {
      double f[L::Q];
      double rho = 0, jx = 0, jy = 0, jz = 0;
#pragma GCC unroll 19
      for (int q = 0; q < L::Q; ++q) {
        f[q] = s[q][x];
        rho += f[q];
        jx += L::cx[q] * f[q];
        jy += L::cy[q] * f[q];
        jz += L::cz[q] * f[q];
      }
      const double inv_rho = 1.0 / rho;
      double ux = jx * inv_rho, uy = jy * inv_rho, uz = jz * inv_rho;
      if constexpr (kForce) {
        ux += 0.5 * Fx * inv_rho;
        uy += 0.5 * Fy * inv_rho;
        uz += 0.5 * Fz * inv_rho;
      }
      const double usq = 1.5 * (ux * ux + uy * uy + uz * uz);
      const double uF = kForce ? ux * Fx + uy * Fy + uz * Fz : 0.0;
#pragma GCC unroll 19
      for (int q = 0; q < L::Q; ++q) {
        const double cu = L::cx[q] * ux + L::cy[q] * uy + L::cz[q] * uz;
        const double feq = L::w[q] * rho * (1.0 - usq + 3.0 * cu + 4.5 * cu * cu);
        double out = f[q] + omega * (feq - f[q]);
        if constexpr (kForce) {
          const double cF = L::cx[q] * Fx + L::cy[q] * Fy + L::cz[q] * Fz;
          out += src_pref * L::w[q] * (3.0 * (cF - uF) + 9.0 * cu * cF);
        }
        d[q][x] = out;
      }
    }
  }
}

}  // namespace

void stream_collide(const PopulationField& src, PopulationField& dst, double tau,
                    const std::array<double, 3>& force) {
  if (force[0] == 0.0 && force[1] == 0.0 && force[2] == 0.0)
    update_rows<false>(src, dst, tau, force);
  else
    update_rows<true>(src, dst, tau, force);
}

}  // namespace cosim::fluid
