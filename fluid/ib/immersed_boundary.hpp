// Immersed boundary coupling of the fluid (DESIGN 2.1, 4.2): interpolation of rho and u at
// the markers (Eq. 17), the momentum-exchange force (Eqs. 14, 18-19) and the spreading of
// the marker impulses onto the lattice (Eqs. 21-24), all with the kernel of Eqs. 22-23.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "fluid/ib/delta_kernel.hpp"
#include "fluid/lattice/grid_layout.hpp"

namespace cosim::fluid {

class FluidSolver;
struct FluidParams;

using Vec3 = std::array<double, 3>;
/// What Eq. 17 interpolates at one node: rho and rho u (FluidSolver::cell).
using NodeMoments = std::array<double, 4>;

/// rho, rho u_x, rho u_y, rho u_z of the cell (x, y, z) of `solver` (FluidSolver::cell).
NodeMoments node_moments(const FluidSolver& solver, int x, int y, int z);

/// The nodes the kernels of a set of markers reach (Eq. 22) and, per marker, which of them
/// each stencil node is, in for_each_node's order: what a batched sample() gathers its node
/// values for and sums from. A grid over several blocks (fluid/mpi/) gets the values of
/// `cells` from the blocks that own them and sums on one process, in the same order.
struct MarkerNodes {
  std::vector<DeltaStencil> stencils;       ///< per marker
  std::vector<std::array<int, 3>> cells;    ///< the nodes whose moments the sums need (wrapped cells)
  std::vector<std::size_t> visit;           ///< per marker and stencil node in order: its index in cells
  std::vector<std::size_t> first_visit;     ///< marker l's entries are visit[first_visit[l] .. first_visit[l + 1])
};

/// rho and u interpolated at one marker (Eq. 17), lattice units. u is the velocity of
/// FluidSolver::cell(): (sum_a c_a f_a + F_body / 2) / rho, without the IB force of the
/// coming step.
struct MarkerSample {
  double rho = 0.0;
  Vec3 u{0.0, 0.0, 0.0};
  /// kernel_weight() of the marker, from the same pass: sum D over the nodes it reaches.
  double weight = 0.0;
};

/// Momentum-exchange force density on the fluid at a marker (DESIGN 2.1).
///
/// Derivation. Let f_a be the populations at the marker (Eq. 17) and beta the direction
/// with c_beta = -c_alpha. Eq. 14 (Ladd 1994) gives the post-collision population
///   f~_beta = f_alpha - 2 rho E_alpha (c_alpha . U_B) / c_s^2.
/// Eq. 18, read as the change of population beta (DESIGN 2.1: as printed it subtracts
/// f_alpha, which would leave only 2 rho U_B), is
///   delta f_beta = f~_beta - f_beta,
/// and Eq. 19 sums the momentum of these changes over all 19 directions:
///   g = sum_beta c_beta (f~_beta - f_beta)
///     = sum_beta c_beta f_alpha - sum_beta c_beta f_beta
///       - (2 rho / c_s^2) sum_beta c_beta E_alpha (c_alpha . U_B).
/// With c_beta = -c_alpha, E_beta = E_alpha and beta running over all directions:
///   sum_beta c_beta f_alpha = -sum_alpha c_alpha f_alpha = -rho u,
///   sum_beta c_beta f_beta  =  rho u,
///   -(2 rho / c_s^2) sum_alpha (-c_alpha) E_alpha c_alpha . U_B
///       = (2 rho / c_s^2) (sum_alpha E_alpha c_alpha c_alpha) . U_B = 2 rho U_B,
/// using sum_a c_a f_a = rho u (Eq. 8) and sum_a E_a c_a c_a = c_s^2 I (Eq. 12). Hence
///   g = 2 rho (U_B - u)                                          (Niu et al. 2006)
/// and the fluid needs to send only rho and u per marker, not 19 populations.
///
/// The marker's volume in lattice units is dA dx, so the impulse handed to the fluid for
/// one LB step (dt = 1) is J = g dA; it is spread with D (Eq. 21) and applied as a force
/// density through Guo's forcing (Eqs. 25-26). Guo's velocity u' = (sum c f + F/2) / rho
/// then reads, at a node that receives the whole force F = g = 2 rho (U_B - u),
///   u' = u + F / (2 rho) = U_B:
/// the force sets the velocity at the marker to U_B in one step. Spread through the kernel,
/// the velocity that a marker sees change is sum_x D(x - X_l) sum_m D(x - X_m) J_m / (2 rho),
/// which is a fraction of U_B - u (about 3/8 for a densely marked surface, the integral of
/// delta_h^2 across it); the condition is then met as a steady state of repeated steps, not
/// in one step. Wu and Shu (2009) iterate or solve for it; this project does not.
///
/// Both forms are below; the test ReducedForceEqualsPopulationSum checks
/// that they agree.
inline Vec3 momentum_exchange_force(double rho, const Vec3& u, const Vec3& U_B) {
  return {2.0 * rho * (U_B[0] - u[0]), 2.0 * rho * (U_B[1] - u[1]), 2.0 * rho * (U_B[2] - u[2])};
}

/// Eq. 19 as an explicit sum over the 19 populations f[0..18] at the marker, with Eq. 14
/// for f~_beta, Eq. 18 read as f~_beta - f_beta, and rho = sum_a f_a (Eq. 7).
Vec3 momentum_exchange_force_from_populations(const double* f, const Vec3& U_B);

/// The lattice geometry the kernel of a marker lands on: interior shape and which axes
/// are periodic. Nodes of a stencil wrap along periodic axes; along the others nodes outside
/// the interior are skipped. Interpolation and spreading both go through for_each_node, so
/// they are exactly adjoint:  sum_x v(x) . spread(J)(x) = sum_l J_l . interpolate(v)(X_l).
class ImmersedBoundary {
 public:
  ImmersedBoundary(const GridShape& shape, const std::array<bool, 3>& periodic);
  /// Shape and periodic axes (FaceKind::Periodic) of the solver's block.
  explicit ImmersedBoundary(const FluidSolver& solver);
  /// Shape and periodic axes of the whole grid of `params` (a grid over several blocks).
  explicit ImmersedBoundary(const FluidParams& params);

  const GridShape& shape() const { return shape_; }
  bool periodic(int axis) const { return periodic_[axis]; }

  /// Calls visit(x, y, z, D) for every interior node of the 4x4x4 stencil of X (Eq. 22),
  /// with (x, y, z) wrapped along periodic axes.
  template <class Visit>
  void for_each_node(const Vec3& X, Visit&& visit) const {
    for_each_stencil_node(delta_stencil(X), [&](int, int, int, int x, int y, int z, double D) { visit(x, y, z, D); });
  }

  /// Eq. 17 for any field: sum_x D(x - X) field(x), field returning std::array<double, N>.
  template <class Field>
  auto interpolate(const Vec3& X, Field&& field) const {
    using Value = decltype(field(0, 0, 0));
    Value sum{};
    for_each_node(X, [&](int x, int y, int z, double D) {
      const Value v = field(x, y, z);
      for (std::size_t c = 0; c < sum.size(); ++c) sum[c] += D * v[c];
    });
    return sum;
  }

  /// sum_x D(x - X) over the fluid nodes the kernel reaches: 1 in the bulk, less where the
  /// kernel crosses a wall, so that rho_l / weight is the mean density the kernel sees
  /// (rho_l of sample() is Eq. 17's partial sum there).
  double kernel_weight(const Vec3& X) const {
    double w = 0.0;
    for_each_node(X, [&](int, int, int, double D) { w += D; });
    return w;
  }

  /// Eq. 21: the impulse J of one marker onto the nodes, sink(x, y, z, D J).
  template <class Sink>
  void spread(const Vec3& X, const Vec3& J, Sink&& sink) const {
    for_each_node(X, [&](int x, int y, int z, double D) {
      sink(x, y, z, Vec3{D * J[0], D * J[1], D * J[2]});
    });
  }
  /// The same for every marker in order (each node's contributions in marker order: a grid
  /// over blocks keeps the nodes it owns and gets each node's sum in the same order).
  /// @pre J.size() == X.size()
  template <class Sink>
  void spread(std::span<const Vec3> X, std::span<const Vec3> J, Sink&& sink) const {
    check_impulses(X.size(), J.size());
    for (std::size_t l = 0; l < X.size(); ++l) spread(X[l], J[l], sink);
  }

  /// Eq. 17 applied to the populations: rho_l = sum D rho and rho_l u_l = sum D rho u, so
  /// that u_l = (sum D rho u) / (sum D rho) is the velocity of the interpolated populations.
  MarkerSample sample(const FluidSolver& solver, const Vec3& X) const;
  /// sample() for every marker, the same sums: the stencils of neighbouring markers overlap
  /// (markers about a cell apart, 4 x 4 x 4 nodes each), so the moments of each node are
  /// computed once (OpenMP over the nodes), then summed per marker (OpenMP over markers).
  /// @pre out.size() == X.size()
  void sample(const FluidSolver& solver, std::span<const Vec3> X,
              std::span<MarkerSample> out) const;
  /// The two halves of the batched sample(): the nodes the markers reach (each once when
  /// the markers are close together), and Eq. 17 per marker from the nodes' moments
  /// (values[i] those of nodes.cells[i]). @pre out.size() == X.size() of nodes
  MarkerNodes marker_nodes(std::span<const Vec3> X) const;
  /// marker_nodes() into `out`, reusing its storage and `listed` (a scratch of the stencils'
  /// box) from an earlier call: no heap traffic once they have grown to the markers' size.
  void marker_nodes(std::span<const Vec3> X, MarkerNodes& out, std::vector<std::size_t>& listed) const;
  void sum_samples(const MarkerNodes& nodes, std::span<const NodeMoments> values,
                   std::span<MarkerSample> out) const;
  /// Eq. 17 literally: the 19 populations interpolated at X, f[0..18].
  void interpolate_populations(const FluidSolver& solver, const Vec3& X, double* f) const;

  /// Eqs. 21-24: the impulses J_l (force density x dA_l, for one LB step) spread at X_l and
  /// added to the solver's force for its next step (FluidSolver::add_force).
  /// @pre J.size() == X.size()
  void spread(FluidSolver& solver, std::span<const Vec3> X, std::span<const Vec3> J) const;

 private:
  static void check_impulses(std::size_t markers, std::size_t impulses);
  /// for_each_node over a stencil: visit(i, j, k, x, y, z, D) with (i, j, k) the node's
  /// place in the stencil (unwrapped: s.first + (i, j, k)) and (x, y, z) the wrapped cell.
  template <class Visit>
  void for_each_stencil_node(const DeltaStencil& s, Visit&& visit) const {
    const int n[3] = {shape_.nx, shape_.ny, shape_.nz};
    int node[3][kDeltaNodes];
    bool inside[3][kDeltaNodes];
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < kDeltaNodes; ++i) {
        int c = s.first[a] + i;
        if (periodic_[a]) c = ((c % n[a]) + n[a]) % n[a];
        node[a][i] = c;
        inside[a][i] = c >= 0 && c < n[a];
      }
    for (int k = 0; k < kDeltaNodes; ++k) {
      if (!inside[2][k]) continue;
      for (int j = 0; j < kDeltaNodes; ++j) {
        if (!inside[1][j]) continue;
        for (int i = 0; i < kDeltaNodes; ++i) {
          if (!inside[0][i]) continue;
          const double D = s.weight(i, j, k);
          if (D != 0.0) visit(i, j, k, node[0][i], node[1][j], node[2][k], D);
        }
      }
    }
  }

  GridShape shape_;
  std::array<bool, 3> periodic_{};
  /// The batched sample()'s buffers, kept from one call to the next: allocated and freed
  /// each LB step they cost more than the sample itself (the heap grown and trimmed back,
  /// each trim a TLB flush). Not for concurrent sample() calls on one object.
  struct SampleScratch {
    MarkerNodes nodes;
    std::vector<std::size_t> listed;
    std::vector<NodeMoments> values;
  };
  mutable SampleScratch scratch_;
};

}  // namespace cosim::fluid
