// The ghost planes of a block that a neighbour block fills (DESIGN 8): the interface through
// which the boundary fills of a block hand over to the exchange between blocks. No MPI here;
// the MPI exchange is fluid/mpi/slab_halo.hpp.
#pragma once

#include <array>

#include "fluid/lattice/population_field.hpp"

namespace cosim::fluid {

constexpr int kHaloFaces = 6;  ///< x_min, x_max, y_min, y_max, z_min, z_max (fluid/boundary/boundary.hpp)

/// Fills the ghost planes of the faces it names (faces()) with the post-collision populations
/// of the neighbour blocks' edge planes, ghosts of the axes before that face's included: what
/// a periodic copy of the whole grid would have put there. BoundaryConditions calls it after
/// the copy-type faces and before the reflecting ones (the order of fill_ghosts), so that the
/// sent planes carry their own copy-type ghosts and the reflecting fills read valid halos.
/// Collective: every block of the run calls it at the same point.
class HaloExchange {
 public:
  virtual ~HaloExchange() = default;
  virtual void exchange(PopulationField& f) = 0;
  virtual void exchange(PopulationFieldSingle& f) = 0;
  virtual void exchange(PopulationFieldHalf& f) = 0;
  /// exchange() in two halves, so that work that neither reads the ghost planes nor writes
  /// the planes sent can run between them (FluidSolver's step of a block): post() starts
  /// it, wait() ends it. By default post() is the whole exchange.
  virtual void post(PopulationField& f) { exchange(f); }
  virtual void post(PopulationFieldSingle& f) { exchange(f); }
  virtual void post(PopulationFieldHalf& f) { exchange(f); }
  virtual void wait() {}
  /// The faces it fills; the boundary fills leave them alone.
  virtual std::array<bool, kHaloFaces> faces() const = 0;
};

}  // namespace cosim::fluid
