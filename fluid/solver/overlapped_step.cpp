// The step of a block of a decomposed grid (DESIGN 8) with the halo exchange overlapped with
// the bulk of the step: the two edge planes first, their exchange posted, the interior
// planes while it travels, then the ghost fills as in FluidSolver::step. The same bits as
// begin_step() + finish_step() (MpiFluidMatchesSerialBitForBit, MpiCoupledMatchesSerialBitForBit
// with the implicit scheme).
#include <algorithm>
#include <stdexcept>
#include <utility>
#include <vector>

#include "fluid/solver/fluid_solver.hpp"
#include "fluid/domain/halo_exchange.hpp"
#include "fluid/collision/stream_collide.hpp"

namespace cosim::fluid {

namespace {

/// The halo faces of an exchange already made: a ghost fill that comes after it fills the
/// other faces in their order and leaves the halo planes as received.
class AlreadyExchanged final : public HaloExchange {
 public:
  explicit AlreadyExchanged(const HaloExchange& h) : faces_(h.faces()) {}
  void exchange_axis(PopulationField&, int) override {}
  void exchange_axis(PopulationFieldSingle&, int) override {}
  void exchange_axis(PopulationFieldHalf&, int) override {}
  std::array<bool, kHaloFaces> faces() const override { return faces_; }

 private:
  std::array<bool, kHaloFaces> faces_;
};

}  // namespace

template <class T>
void FluidSolver::step_overlapped(BasicPopulationField<T>& f, BasicPopulationField<T>& g) {
  if (mid_step_) throw std::logic_error("FluidSolver::step(): the step begun before is not finished");
  const int nz = layout_.nz();
  // The kernel over planes z0 .. z0 + n - 1 (views of the two grids), with the stores a
  // sweep of the whole block would use (they decide nothing but how the bits are written).
  const Stores stores = uses_streaming_stores(layout_, Stores::Auto, sizeof(T)) ? Stores::Streaming : Stores::Cached;
  const KernelOutflow outflow = bc_.kernel_outflow();
  KernelExtrema all;
  const auto sweep = [&](int z0, int n) {
    const BasicPopulationField<T> src = BasicPopulationField<T>::planes(f, z0, n);
    BasicPopulationField<T> dst = BasicPopulationField<T>::planes(g, z0, n);
    KernelExtrema part;
    stream_collide(src, dst, params_.tau, params_.body_force, stores, outflow, &part, schedule_,
                   arithmetic_of(params_.precision));
    all.merge(part);
  };
  // The forced cells of some planes (apply_local_forces clears what it applies).
  const std::vector<std::ptrdiff_t> forced = std::move(forced_);
  const std::ptrdiff_t plane = layout_.plane_stride();
  const auto forces = [&](bool edges) {
    forced_.clear();
    for (const std::ptrdiff_t i : forced) {
      const int z = int(i / plane) - 1;
      if ((z == 0 || z == nz - 1) == edges) forced_.push_back(i);
    }
    apply_local_forces(f, g);
  };
  have_previous_ = false;
  AlreadyExchanged exchanged(*halo_);
  // The edge planes, whole: collided, forced, their x and y ghosts filled (the neighbours
  // receive them with their ghosts, as from a fill before the exchange; the rest of this
  // fill is made again below).
  sweep(0, 1);
  sweep(nz - 1, 1);
  forces(true);
  bc_.fill_step_ghosts(g, &exchanged);
  halo_->post(g);
  // The interior planes read no halo plane and write no plane sent.
  sweep(1, nz - 2);
  forces(false);
  halo_->wait();
  std::swap(f, g);
  bc_.fill_step_ghosts(f, &exchanged);
  extrema_ = all;
  have_previous_ = true;
  ++steps_;
}

template void FluidSolver::step_overlapped(PopulationField&, PopulationField&);
template void FluidSolver::step_overlapped(PopulationFieldSingle&, PopulationFieldSingle&);
template void FluidSolver::step_overlapped(PopulationFieldHalf&, PopulationFieldHalf&);

}  // namespace cosim::fluid
