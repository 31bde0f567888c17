#include "fluid/immersed_boundary.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <vector>
#include <string>

#include "fluid/boundary.hpp"
#include "fluid/d3q19.hpp"
#include "fluid/fluid_solver.hpp"

namespace cosim::fluid {

Vec3 momentum_exchange_force_from_populations(const double* f, const Vec3& U_B) {
  double rho = 0.0;
  for (int q = 0; q < D3Q19::Q; ++q) rho += f[q];  // Eq. 7
  Vec3 g{0.0, 0.0, 0.0};
  for (int beta = 0; beta < D3Q19::Q; ++beta) {
    const int alpha = D3Q19::opp[beta];  // c_beta = -c_alpha
    const double cU = D3Q19::cx[alpha] * U_B[0] + D3Q19::cy[alpha] * U_B[1] +
                      D3Q19::cz[alpha] * U_B[2];
    const double f_tilde = f[alpha] - 2.0 * rho * D3Q19::w[alpha] * cU / D3Q19::cs2;  // Eq. 14
    const double delta_f = f_tilde - f[beta];                                       // Eq. 18
    g[0] += D3Q19::cx[beta] * delta_f;                                              // Eq. 19
    g[1] += D3Q19::cy[beta] * delta_f;
    g[2] += D3Q19::cz[beta] * delta_f;
  }
  return g;
}

ImmersedBoundary::ImmersedBoundary(const GridShape& shape, const std::array<bool, 3>& periodic)
    : shape_(shape), periodic_(periodic) {
  if (shape.nx <= 0 || shape.ny <= 0 || shape.nz <= 0)
    throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(__LINE__) +
                                ": the immersed boundary needs a lattice with at least one "
                                "cell along every axis");
}

ImmersedBoundary::ImmersedBoundary(const FluidSolver& solver)
    : ImmersedBoundary(solver.shape(),
                       {solver.boundaries().face(XMin).kind == FaceKind::Periodic,
                        solver.boundaries().face(YMin).kind == FaceKind::Periodic,
                        solver.boundaries().face(ZMin).kind == FaceKind::Periodic}) {}

MarkerSample ImmersedBoundary::sample(const FluidSolver& solver, const Vec3& X) const {
  const auto m = interpolate(X, [&](int x, int y, int z) {
    const CellState c = solver.cell(x, y, z);
    return std::array<double, 4>{c.rho, c.rho * c.ux, c.rho * c.uy, c.rho * c.uz};
  });
  MarkerSample s;
  s.weight = kernel_weight(X);
  s.rho = m[0];
  if (s.rho > 0.0) s.u = {m[1] / s.rho, m[2] / s.rho, m[3] / s.rho};
  return s;
}

void ImmersedBoundary::sample(const FluidSolver& solver, std::span<const Vec3> X,
                              std::span<MarkerSample> out) const {
  if (out.size() != X.size())
    throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(__LINE__) +
                                ": sample() needs one output per marker; resize the output "
                                "span to the number of marker positions");
  const std::ptrdiff_t n = std::ptrdiff_t(X.size());
  if (n == 0) return;
  // The box of all stencils, in unwrapped node coordinates (a node wrapped across a
  // periodic face may sit in it twice: computed twice, the same value).
  std::vector<DeltaStencil> stencils(X.size());
  std::array<int, 3> lo{}, hi{};
  for (std::size_t l = 0; l < X.size(); ++l) {
    stencils[l] = delta_stencil(X[l]);
    for (int a = 0; a < 3; ++a) {
      const int first = stencils[l].first[a];
      lo[a] = l == 0 ? first : std::min(lo[a], first);
      hi[a] = l == 0 ? first + kDeltaNodes : std::max(hi[a], first + kDeltaNodes);
    }
  }
  const std::array<std::ptrdiff_t, 3> size{hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  const std::ptrdiff_t volume = size[0] * size[1] * size[2];
  if (volume > 8 * kDeltaNodes * kDeltaNodes * kDeltaNodes * n) {
    // Markers far apart: the box would be mostly empty; node by node per marker.
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t l = 0; l < n; ++l) out[std::size_t(l)] = sample(solver, X[std::size_t(l)]);
    return;
  }
  const auto box_index = [&](const DeltaStencil& st, int i, int j, int k) {
    return ((std::ptrdiff_t(st.first[2] + k - lo[2]) * size[1]) + (st.first[1] + j - lo[1])) * size[0] +
           (st.first[0] + i - lo[0]);
  };
  // The nodes some marker reaches, and the cell each stands for.
  std::vector<std::array<int, 3>> cell(std::size_t(volume), std::array<int, 3>{-1, -1, -1});
  std::vector<std::ptrdiff_t> needed;
  for (const DeltaStencil& st : stencils)
    for_each_stencil_node(st, [&](int i, int j, int k, int x, int y, int z, double) {
      const std::ptrdiff_t b = box_index(st, i, j, k);
      if (cell[std::size_t(b)][0] < 0) {
        cell[std::size_t(b)] = {x, y, z};
        needed.push_back(b);
      }
    });
  // rho and rho u of each node once (as sample(solver, X) takes them from solver.cell).
  std::vector<std::array<double, 4>> value(static_cast<std::size_t>(volume));
  const std::ptrdiff_t m = std::ptrdiff_t(needed.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t t = 0; t < m; ++t) {
    const std::size_t b = std::size_t(needed[std::size_t(t)]);
    const CellState c = solver.cell(cell[b][0], cell[b][1], cell[b][2]);
    value[b] = {c.rho, c.rho * c.ux, c.rho * c.uy, c.rho * c.uz};
  }
  // Eq. 17 per marker, in for_each_node's order.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t l = 0; l < n; ++l) {
    const DeltaStencil& st = stencils[std::size_t(l)];
    std::array<double, 4> sum{};
    double weight = 0.0;
    for_each_stencil_node(st, [&](int i, int j, int k, int, int, int, double D) {
      const std::array<double, 4>& v = value[std::size_t(box_index(st, i, j, k))];
      for (std::size_t c = 0; c < sum.size(); ++c) sum[c] += D * v[c];
      weight += D;
    });
    MarkerSample& s = out[std::size_t(l)];
    s = MarkerSample{};
    s.weight = weight;
    s.rho = sum[0];
    if (s.rho > 0.0) s.u = {sum[1] / s.rho, sum[2] / s.rho, sum[3] / s.rho};
  }
}

void ImmersedBoundary::interpolate_populations(const FluidSolver& solver, const Vec3& X,
                                               double* f) const {
  const auto fl = interpolate(X, [&](int x, int y, int z) {
    std::array<double, D3Q19::Q> p;
    solver.populations_at(x, y, z, p.data());
    return p;
  });
  for (int q = 0; q < D3Q19::Q; ++q) f[q] = fl[std::size_t(q)];
}

void ImmersedBoundary::spread(FluidSolver& solver, std::span<const Vec3> X,
                              std::span<const Vec3> J) const {
  if (J.size() != X.size())
    throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(__LINE__) +
                                ": spread() needs one impulse per marker position; got " +
                                std::to_string(J.size()) + " impulses for " +
                                std::to_string(X.size()) + " markers");
  for (std::size_t l = 0; l < X.size(); ++l)
    spread(X[l], J[l], [&](int x, int y, int z, const Vec3& F) {
      solver.add_force(x, y, z, F[0], F[1], F[2]);
    });
}

}  // namespace cosim::fluid
