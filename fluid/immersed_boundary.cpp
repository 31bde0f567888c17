#include "fluid/immersed_boundary.hpp"

#include <stdexcept>
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
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t l = 0; l < n; ++l) out[std::size_t(l)] = sample(solver, X[std::size_t(l)]);
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
