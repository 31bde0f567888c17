// A rigid body held at rest by the fluid itself (no solid process; in a coupled run beside
// the solid's sheets, fluid/coupled/fluid_run.hpp hold_body): a circular cylinder,
// optionally with a rectangular bar on its downstream side (Turek and Hron's CFD cases,
// issue 29), marked by immersed-boundary markers on its surface in every span layer of a
// span-periodic grid. Each step the markers' impulses are found by multi-direct forcing
// (Wang, Fan and Luo 2008; Breugem 2012): the momentum-exchange force of the project
// (DESIGN 2.1, g = 2 rho (U_B - u), U_B = 0) applied a few times over, each time on the
// velocity that the impulses found so far leave at the markers (Eq. 17 of Eq. 21's spread
// force, through Guo's half-force shift), so that the no-slip condition holds at the
// markers within the step instead of only as a steady state. The force on the body is
// minus the sum of the impulses.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "fluid/ib/immersed_boundary.hpp"

namespace cosim::fluid {

/// The body in lattice units (cells; cell (i, j, k) centred at (i, j, k)).
struct HeldBodyShape {
  double x_c = 0.0, y_c = 0.0;  ///< the cylinder's axis
  double radius = 0.0;          ///< > 0
  /// The bar: from the cylinder's axis downstream to x = bar_tip_x, centred on y_c, of
  /// thickness bar_thickness; none where bar_thickness = 0.
  double bar_tip_x = 0.0;
  double bar_thickness = 0.0;
  /// The markers lie on the surface moved inward by this much (cells): the kernel of Eq. 23
  /// spreads over +-2 dx and makes the body look larger (Breugem 2012; the fixed cylinder
  /// of tests/validation/test_cylinder_drag.cpp takes 0.3).
  double retraction = 0.3;
  double spacing = 1.0;  ///< target marker spacing along the surface (cells)
  int iterations = 5;    ///< multi-direct forcing passes per step (>= 1; 1: the plain force)
};

/// The markers of a shape: a ring on the retracted cylinder (without the part inside the
/// bar) and, for a bar, its retracted top, bottom and tip outside the cylinder; every layer
/// z = 0 .. nz - 1. `area`: each marker's surface element (length along the surface x one
/// cell of span).
void held_body_markers(const HeldBodyShape& shape, int nz, std::vector<Vec3>& X, std::vector<double>& area);

class HeldBody {
 public:
  /// `ib`: the geometry of the whole grid (ImmersedBoundary(const FluidParams&)).
  /// @throws std::invalid_argument for a shape with no markers, radius <= 0 or iterations < 1
  HeldBody(const HeldBodyShape& shape, const ImmersedBoundary& ib);

  const HeldBodyShape& shape() const { return shape_; }
  std::span<const Vec3> markers() const { return X_; }

  /// The impulses J (one LB step, lattice units) of the markers from rho and u sampled
  /// there (FluidDomain::sample; the velocity before this step's forces): multi-direct
  /// forcing as above. @pre samples.size() == markers().size()
  const std::vector<Vec3>& impulses(std::span<const MarkerSample> samples);
  /// The force on the body of the last impulses(): - sum J, lattice units, the whole span.
  const Vec3& force() const { return force_; }

  /// One step's hold on a grid (FluidDomain or alike: sample(X, out), spread(X, J)): rho and
  /// u sampled at the markers, the impulses spread for the coming step. Call before the
  /// step; returns force().
  template <class Domain>
  const Vec3& hold(Domain& domain) {
    samples_.resize(X_.size());
    domain.sample(markers(), samples_);
    domain.spread(markers(), impulses(samples_));
    return force_;
  }

 private:
  HeldBodyShape shape_;
  std::vector<Vec3> X_;
  std::vector<double> area_;
  // The kernel of every marker as a sparse row: the nodes it reaches (indices into a list of
  // distinct nodes) and D there (Eq. 22).
  std::vector<std::size_t> first_;  // marker l's entries: first_[l] .. first_[l + 1]
  std::vector<std::size_t> node_;
  std::vector<double> weight_;
  std::size_t nodes_ = 0;
  // Scratch of impulses().
  std::vector<Vec3> J_, u_, dJ_, node_force_;
  std::vector<double> rho_;
  std::vector<MarkerSample> samples_;
  Vec3 force_{0.0, 0.0, 0.0};
};

}  // namespace cosim::fluid
