// The halo exchange between slabs along z over MPI (fluid/domain/halo_exchange.hpp): a slab's edge
// planes to the slabs below and above, each step.
#pragma once

#include <mpi.h>

#include <array>
#include <cstdint>
#include <vector>

#include "fluid/domain/decomposition.hpp"
#include "fluid/domain/halo_exchange.hpp"

namespace cosim::fluid::mpi {

/// Sends the plane z = nz - 1 (the populations with c_z = +1, the ones the slab above pulls
/// from its z = -1 ghosts) up and the plane z = 0 (c_z = -1) down, and receives the
/// neighbours' planes into the ghost planes z = -1 and z = nz: 5 of the 19 populations, each
/// a whole plane with its x and y ghosts (GridLayout::plane_stride values), straight from and
/// into the field (no packing). Nonblocking sends and receives, all posted before the first
/// wait (post(), then wait(): a block's step runs its interior planes in between).
class SlabHalo final : public HaloExchange {
 public:
  SlabHalo(MPI_Comm comm, const SlabNeighbours& n) : comm_(comm), n_(n) {}
  void exchange(PopulationField& f) override {
    post(f);
    wait();
  }
  void exchange(PopulationFieldSingle& f) override {
    post(f);
    wait();
  }
  void exchange(PopulationFieldHalf& f) override {
    post(f);
    wait();
  }
  void post(PopulationField& f) override { start(f); }
  void post(PopulationFieldSingle& f) override { start(f); }
  void post(PopulationFieldHalf& f) override { start(f); }
  void wait() override;
  std::array<bool, kHaloFaces> faces() const override;
  /// Bytes this slab sent in its exchanges so far.
  std::int64_t bytes_sent() const { return bytes_sent_; }
  std::int64_t exchanges() const { return exchanges_; }
  /// Wall-clock seconds spent in the exchanges so far (posting, waiting: what a step spends
  /// on its halo; not the work between post() and wait()).
  double seconds() const { return seconds_; }

 private:
  template <class T>
  void start(BasicPopulationField<T>& f);
  MPI_Comm comm_;
  SlabNeighbours n_;
  std::vector<MPI_Request> requests_;  ///< of the exchange posted
  std::int64_t bytes_sent_ = 0, exchanges_ = 0;
  double seconds_ = 0.0;
};

}  // namespace cosim::fluid::mpi
