// The halo exchange between blocks along y and z over MPI (fluid/domain/halo_exchange.hpp): a
// block's edge rows to the blocks beside it along y, then its edge planes, with those rows'
// ghosts, to the blocks below and above along z, each step.
#pragma once

#include <mpi.h>

#include <array>
#include <cstdint>
#include <vector>

#include "fluid/domain/decomposition.hpp"
#include "fluid/domain/halo_exchange.hpp"

namespace cosim::fluid::mpi {

/// Along y: sends the rows y = ny - 1 of every plane (the populations with c_y = +1, the
/// ones the block beyond y_max pulls from its y = -1 ghosts) to y_max and the rows y = 0
/// (c_y = -1) to y_min, and receives the neighbours' rows into the ghost rows y = -1 and
/// y = ny, each row with its x ghosts (an MPI vector type over the planes, straight from and
/// into the field). Along z: the plane z = nz - 1 (c_z = +1) up and z = 0 (c_z = -1) down,
/// into the ghost planes z = -1 and z = nz, each a whole plane with its x and y ghosts
/// (GridLayout::plane_stride values): the y ghost rows just received go with it, so the
/// y-z edge ghosts get the diagonal block's cells (the populations (0, +-1, +-1)) without a
/// message to it. 5 of the 19 populations each way. Nonblocking sends and receives, all of
/// an axis posted before its first wait (post(), then wait(): a block cut along z only
/// runs its interior planes in between).
class BlockHalo final : public HaloExchange {
 public:
  BlockHalo(MPI_Comm comm, const BlockNeighbours& n) : comm_(comm), n_(n) {}
  void exchange_axis(PopulationField& f, int axis) override {
    start(f, axis);
    wait();
  }
  void exchange_axis(PopulationFieldSingle& f, int axis) override {
    start(f, axis);
    wait();
  }
  void exchange_axis(PopulationFieldHalf& f, int axis) override {
    start(f, axis);
    wait();
  }
  /// The z exchange; @pre the block has no halo faces along y (std::logic_error)
  void post(PopulationField& f) override { start(f, 2, true); }
  void post(PopulationFieldSingle& f) override { start(f, 2, true); }
  void post(PopulationFieldHalf& f) override { start(f, 2, true); }
  void wait() override;
  std::array<bool, kHaloFaces> faces() const override;
  /// Bytes this block sent in its exchanges so far.
  std::int64_t bytes_sent() const { return bytes_sent_; }
  /// Exchanges of every axis so far (one per step).
  std::int64_t exchanges() const { return exchanges_; }
  /// Wall-clock seconds spent in the exchanges so far (posting, waiting: what a step spends
  /// on its halo; not the work between post() and wait()).
  double seconds() const { return seconds_; }

 private:
  template <class T>
  void start(BasicPopulationField<T>& f, int axis, bool posted = false);
  MPI_Comm comm_;
  BlockNeighbours n_;
  std::vector<MPI_Request> requests_;  ///< of the exchange posted
  int axis_ = 0;                       ///< of the exchange posted
  std::int64_t bytes_sent_ = 0, exchanges_ = 0;
  double seconds_ = 0.0;
};

}  // namespace cosim::fluid::mpi
