#include "fluid/ib/immersed_boundary.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <vector>
#include <string>

#include "fluid/boundary/boundary.hpp"
#include "fluid/lattice/d3q19.hpp"
#include "fluid/solver/fluid_solver.hpp"

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

ImmersedBoundary::ImmersedBoundary(const FluidParams& params)
    : ImmersedBoundary(params.shape,
                       {params.faces[XMin].kind == FaceKind::Periodic, params.faces[YMin].kind == FaceKind::Periodic,
                        params.faces[ZMin].kind == FaceKind::Periodic}) {}

NodeMoments node_moments(const FluidSolver& solver, int x, int y, int z) {
  const CellState c = solver.cell(x, y, z);
  return {c.rho, c.rho * c.ux, c.rho * c.uy, c.rho * c.uz};
}

MarkerSample ImmersedBoundary::sample(const FluidSolver& solver, const Vec3& X) const {
  const auto m = interpolate(X, [&](int x, int y, int z) { return node_moments(solver, x, y, z); });
  MarkerSample s;
  s.weight = kernel_weight(X);
  s.rho = m[0];
  if (s.rho > 0.0) s.u = {m[1] / s.rho, m[2] / s.rho, m[3] / s.rho};
  return s;
}

MarkerNodes ImmersedBoundary::marker_nodes(std::span<const Vec3> X) const {
  MarkerNodes out;
  std::vector<std::size_t> listed;
  marker_nodes(X, out, listed);
  return out;
}

void ImmersedBoundary::marker_nodes(std::span<const Vec3> X, MarkerNodes& out, std::vector<std::size_t>& listed) const {
  const std::size_t n = X.size();
  out.stencils.resize(n);
  out.first_visit.assign(n + 1, 0);
  out.cells.clear();
  out.visit.clear();
  if (n == 0) return;
  // The box of all stencils, in unwrapped node coordinates (a node wrapped across a
  // periodic face may sit in it twice: listed twice, the same value).
  std::array<int, 3> lo{}, hi{};
  for (std::size_t l = 0; l < n; ++l) {
    out.stencils[l] = delta_stencil(X[l]);
    for (int a = 0; a < 3; ++a) {
      const int first = out.stencils[l].first[a];
      lo[a] = l == 0 ? first : std::min(lo[a], first);
      hi[a] = l == 0 ? first + kDeltaNodes : std::max(hi[a], first + kDeltaNodes);
    }
  }
  const std::array<std::ptrdiff_t, 3> size{hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  const std::ptrdiff_t volume = size[0] * size[1] * size[2];
  // Markers far apart: the box would be mostly empty; every stencil node listed as visited.
  const bool box = volume <= 8 * kDeltaNodes * kDeltaNodes * kDeltaNodes * std::ptrdiff_t(n);
  constexpr std::size_t kUnlisted = ~std::size_t(0);
  listed.assign(box ? std::size_t(volume) : 0, kUnlisted);
  out.visit.reserve(n * kDeltaNodes * kDeltaNodes * kDeltaNodes);
  for (std::size_t l = 0; l < n; ++l) {
    const DeltaStencil& st = out.stencils[l];
    out.first_visit[l] = out.visit.size();
    for_each_stencil_node(st, [&](int i, int j, int k, int x, int y, int z, double) {
      std::size_t* at = nullptr;
      if (box)
        at = &listed[std::size_t(((std::ptrdiff_t(st.first[2] + k - lo[2]) * size[1]) + (st.first[1] + j - lo[1])) *
                                     size[0] +
                                 (st.first[0] + i - lo[0]))];
      if (at == nullptr || *at == kUnlisted) {
        if (at != nullptr) *at = out.cells.size();
        out.visit.push_back(out.cells.size());
        out.cells.push_back({x, y, z});
      } else {
        out.visit.push_back(*at);
      }
    });
  }
  out.first_visit[n] = out.visit.size();
}

void ImmersedBoundary::sum_samples(const MarkerNodes& nodes, std::span<const NodeMoments> values,
                                   std::span<MarkerSample> out) const {
  // Eq. 17 per marker, in for_each_node's order.
  const std::ptrdiff_t n = std::ptrdiff_t(nodes.stencils.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t l = 0; l < n; ++l) {
    std::size_t v = nodes.first_visit[std::size_t(l)];
    std::array<double, 4> sum{};
    double weight = 0.0;
    for_each_stencil_node(nodes.stencils[std::size_t(l)], [&](int, int, int, int, int, int, double D) {
      const NodeMoments& m = values[nodes.visit[v++]];
      for (std::size_t c = 0; c < sum.size(); ++c) sum[c] += D * m[c];
      weight += D;
    });
    MarkerSample& s = out[std::size_t(l)];
    s = MarkerSample{};
    s.weight = weight;
    s.rho = sum[0];
    if (s.rho > 0.0) s.u = {sum[1] / s.rho, sum[2] / s.rho, sum[3] / s.rho};
  }
}

void ImmersedBoundary::sample(const FluidSolver& solver, std::span<const Vec3> X,
                              std::span<MarkerSample> out) const {
  if (out.size() != X.size())
    throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(__LINE__) +
                                ": sample() needs one output per marker; resize the output "
                                "span to the number of marker positions");
  if (X.empty()) return;
  // The stencils of neighbouring markers overlap: the moments of each node once (OpenMP
  // over the nodes), then summed per marker.
  const MarkerNodes& nodes = scratch_.nodes;
  marker_nodes(X, scratch_.nodes, scratch_.listed);
  std::vector<NodeMoments>& value = scratch_.values;
  value.resize(nodes.cells.size());
  const std::ptrdiff_t m = std::ptrdiff_t(nodes.cells.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t t = 0; t < m; ++t) {
    const std::array<int, 3>& c = nodes.cells[std::size_t(t)];
    value[std::size_t(t)] = node_moments(solver, c[0], c[1], c[2]);
  }
  sum_samples(nodes, value, out);
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

void ImmersedBoundary::check_impulses(std::size_t markers, std::size_t impulses) {
  if (impulses != markers)
    throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(__LINE__) +
                                ": spread() needs one impulse per marker position; got " +
                                std::to_string(impulses) + " impulses for " +
                                std::to_string(markers) + " markers");
}

void ImmersedBoundary::spread(FluidSolver& solver, std::span<const Vec3> X,
                              std::span<const Vec3> J) const {
  spread(X, J, [&](int x, int y, int z, const Vec3& F) { solver.add_force(x, y, z, F[0], F[1], F[2]); });
}

}  // namespace cosim::fluid
