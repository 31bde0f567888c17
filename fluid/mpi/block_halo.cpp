#include "fluid/mpi/block_halo.hpp"

#include <stdexcept>
#include <type_traits>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/mpi/mpi_world.hpp"

namespace cosim::fluid::mpi {

std::array<bool, kHaloFaces> BlockHalo::faces() const {
  std::array<bool, kHaloFaces> h{};
  h[YMin] = n_.y_min >= 0;
  h[YMax] = n_.y_max >= 0;
  h[ZMin] = n_.z_min >= 0;
  h[ZMax] = n_.z_max >= 0;
  return h;
}

template <class T>
void BlockHalo::start(BasicPopulationField<T>& f, int axis, bool posted) {
  if (!requests_.empty()) throw std::logic_error("BlockHalo::post: the exchange posted before is not waited for");
  if (posted && (n_.y_min >= 0 || n_.y_max >= 0))
    throw std::logic_error("BlockHalo::post: a block cut along y exchanges its rows before its planes (exchange_axis)");
  const double t0 = MPI_Wtime();
  const GridLayout& lay = f.layout();
  // The half store's codes travel as their bits.
  const MPI_Datatype value = std::is_same_v<T, double> ? MPI_DOUBLE : std::is_same_v<T, float> ? MPI_FLOAT : MPI_UINT16_T;
  std::vector<MPI_Request>& req = requests_;
  req.reserve(4 * 5);
  axis_ = axis;
  // One unit of the exchange: a whole plane (z; its x and y ghosts included), or the row y
  // of every plane with its x ghosts (y).
  MPI_Datatype unit = value;
  int count = 0;
  std::ptrdiff_t unit_values = 0;
  int lo = -1, hi = -1, n = 0, cq = 0;
  if (axis == 2) {
    count = int(lay.plane_stride());
    unit_values = lay.plane_stride();
    lo = n_.z_min, hi = n_.z_max, n = lay.nz();
  } else if (axis == 1) {
    check(MPI_Type_vector(lay.nz(), lay.nx() + 2, int(lay.plane_stride()), value, &unit), "MPI_Type_vector");
    check(MPI_Type_commit(&unit), "MPI_Type_commit");
    count = 1;
    unit_values = std::ptrdiff_t(lay.nz()) * (lay.nx() + 2);
    lo = n_.y_min, hi = n_.y_max, n = lay.ny();
  } else {
    throw std::logic_error("BlockHalo: no halo along x");
  }
  // Offset of the first value of plane z (axis 2), or of row y's x = -1 ghost in plane 0.
  const auto at = [&](int i) {
    return axis == 2 ? std::ptrdiff_t(i + 1) * lay.plane_stride() : lay.index(-1, i, 0);
  };
  const int kUp = axis == 2 ? 100 : 500, kDown = axis == 2 ? 200 : 600;  // tags: + q
  for (int q = 0; q < D3Q19::Q; ++q) {
    T* fq = f.q(q);
    cq = D3Q19::c(q, axis);
    if (cq == 1) {  // travels up: from the block below into -1, to the one above
      if (lo >= 0) {
        req.emplace_back();
        check(MPI_Irecv(fq + at(-1), count, unit, lo, kUp + q, comm_, &req.back()), "MPI_Irecv");
      }
      if (hi >= 0) {
        req.emplace_back();
        check(MPI_Isend(fq + at(n - 1), count, unit, hi, kUp + q, comm_, &req.back()), "MPI_Isend");
        bytes_sent_ += unit_values * std::int64_t(sizeof(T));
      }
    } else if (cq == -1) {  // travels down
      if (hi >= 0) {
        req.emplace_back();
        check(MPI_Irecv(fq + at(n), count, unit, hi, kDown + q, comm_, &req.back()), "MPI_Irecv");
      }
      if (lo >= 0) {
        req.emplace_back();
        check(MPI_Isend(fq + at(0), count, unit, lo, kDown + q, comm_, &req.back()), "MPI_Isend");
        bytes_sent_ += unit_values * std::int64_t(sizeof(T));
      }
    }
  }
  if (unit != value) MPI_Type_free(&unit);  // freed once the operations that use it end
  seconds_ += MPI_Wtime() - t0;
}

void BlockHalo::wait() {
  const double t0 = MPI_Wtime();
  check(MPI_Waitall(int(requests_.size()), requests_.data(), MPI_STATUSES_IGNORE), "MPI_Waitall (halo exchange)");
  requests_.clear();
  if (axis_ == 2 || (n_.z_min < 0 && n_.z_max < 0)) ++exchanges_;
  seconds_ += MPI_Wtime() - t0;
}

template void BlockHalo::start(PopulationField&, int, bool);
template void BlockHalo::start(PopulationFieldSingle&, int, bool);
template void BlockHalo::start(PopulationFieldHalf&, int, bool);

}  // namespace cosim::fluid::mpi
