// The ghost planes of a block that a neighbour block fills (DESIGN 8): the interface through
// which the boundary fills of a block hand over to the exchange between blocks. No MPI here;
// the MPI exchange is fluid/mpi/block_halo.hpp.
#pragma once

#include <array>

#include "fluid/lattice/population_field.hpp"

namespace cosim::fluid {

constexpr int kHaloFaces = 6;  ///< x_min, x_max, y_min, y_max, z_min, z_max (fluid/boundary/boundary.hpp)

/// Fills the ghost rows and planes of the faces it names (faces()) with the post-collision
/// populations of the neighbour blocks' edge rows and planes, ghosts of the axes before that
/// face's included: what a periodic copy of the whole grid would have put there. One axis at
/// a time (exchange_axis), in the place of that axis' copy-type faces among the ghost fills
/// (BoundaryConditions: x, y, z, then the reflecting faces): the y rows over the x ghosts,
/// then the z planes whole, with their y ghost rows just received, so that the ghosts of a
/// y-z edge get the diagonal neighbour's cells (the populations (0, +-1, +-1) of D3Q19) in
/// two exchanges with the face neighbours, none with the diagonal ones.
/// Collective: every block of the run calls it at the same point.
class HaloExchange {
 public:
  virtual ~HaloExchange() = default;
  /// The faces of `axis` (1: y, 2: z) that it fills, in place of their copy-type fills.
  virtual void exchange_axis(PopulationField& f, int axis) = 0;
  virtual void exchange_axis(PopulationFieldSingle& f, int axis) = 0;
  virtual void exchange_axis(PopulationFieldHalf& f, int axis) = 0;
  /// Every axis, in order (what the ghost fills do, without the copy-type faces between).
  template <class T>
  void exchange(BasicPopulationField<T>& f) {
    const std::array<bool, kHaloFaces> h = faces();
    for (int a = 0; a < 3; ++a)
      if (h[std::size_t(2 * a)] || h[std::size_t(2 * a + 1)]) exchange_axis(f, a);
  }
  /// The z exchange in two halves, so that work that neither reads the ghost planes nor
  /// writes the planes sent can run between them (FluidSolver's step of a block cut along
  /// z only): post() starts it, wait() ends it. By default post() is the whole exchange.
  virtual void post(PopulationField& f) { exchange_axis(f, 2); }
  virtual void post(PopulationFieldSingle& f) { exchange_axis(f, 2); }
  virtual void post(PopulationFieldHalf& f) { exchange_axis(f, 2); }
  virtual void wait() {}
  /// The faces it fills; the boundary fills leave them alone.
  virtual std::array<bool, kHaloFaces> faces() const = 0;
};

}  // namespace cosim::fluid
