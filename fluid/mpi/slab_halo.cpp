#include "fluid/mpi/slab_halo.hpp"

#include <stdexcept>
#include <type_traits>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/mpi/mpi_world.hpp"

namespace cosim::fluid::mpi {

std::array<bool, kHaloFaces> SlabHalo::faces() const {
  std::array<bool, kHaloFaces> h{};
  h[ZMin] = n_.below >= 0;
  h[ZMax] = n_.above >= 0;
  return h;
}

template <class T>
void SlabHalo::start(BasicPopulationField<T>& f) {
  if (!requests_.empty()) throw std::logic_error("SlabHalo::post: the exchange posted before is not waited for");
  const double t0 = MPI_Wtime();
  const GridLayout& lay = f.layout();
  const std::ptrdiff_t plane = lay.plane_stride();
  const int nz = lay.nz();
  // The half store's codes travel as their bits.
  const MPI_Datatype type = std::is_same_v<T, double> ? MPI_DOUBLE : std::is_same_v<T, float> ? MPI_FLOAT : MPI_UINT16_T;
  // Offset of the first value of plane z (its x and y ghosts included).
  const auto at = [&](int z) { return std::ptrdiff_t(z + 1) * plane; };
  constexpr int kUp = 100, kDown = 200;  // tags: + q
  std::vector<MPI_Request>& req = requests_;
  req.reserve(4 * 5);
  for (int q = 0; q < D3Q19::Q; ++q) {
    T* fq = f.q(q);
    if (D3Q19::cz[q] == 1) {  // travels up: from the slab below into z = -1, to the one above
      if (n_.below >= 0) {
        req.emplace_back();
        check(MPI_Irecv(fq + at(-1), int(plane), type, n_.below, kUp + q, comm_, &req.back()), "MPI_Irecv");
      }
      if (n_.above >= 0) {
        req.emplace_back();
        check(MPI_Isend(fq + at(nz - 1), int(plane), type, n_.above, kUp + q, comm_, &req.back()), "MPI_Isend");
        bytes_sent_ += plane * std::int64_t(sizeof(T));
      }
    } else if (D3Q19::cz[q] == -1) {  // travels down
      if (n_.above >= 0) {
        req.emplace_back();
        check(MPI_Irecv(fq + at(nz), int(plane), type, n_.above, kDown + q, comm_, &req.back()), "MPI_Irecv");
      }
      if (n_.below >= 0) {
        req.emplace_back();
        check(MPI_Isend(fq + at(0), int(plane), type, n_.below, kDown + q, comm_, &req.back()), "MPI_Isend");
        bytes_sent_ += plane * std::int64_t(sizeof(T));
      }
    }
  }
  seconds_ += MPI_Wtime() - t0;
}

void SlabHalo::wait() {
  const double t0 = MPI_Wtime();
  check(MPI_Waitall(int(requests_.size()), requests_.data(), MPI_STATUSES_IGNORE), "MPI_Waitall (halo exchange)");
  requests_.clear();
  ++exchanges_;
  seconds_ += MPI_Wtime() - t0;
}

template void SlabHalo::start(PopulationField&);
template void SlabHalo::start(PopulationFieldSingle&);
template void SlabHalo::start(PopulationFieldHalf&);

}  // namespace cosim::fluid::mpi
