// Snapshots of rho, u and vorticity as HDF5 files with an XDMF index for ParaView.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fluid/solver/fluid_solver.hpp"
#include "fluid/observables/vorticity.hpp"

namespace cosim::fluid {

/// Writes into directory `dir` (created if missing):
///  - fields_NNNNNN.h5 per snapshot (step number, at least six digits) with datasets
///      rho        [nz][ny][nx]     rho / rho_0 (lattice density, dimensionless)
///      u          [nz][ny][nx][3]  velocity in m/s (u_LB dx / dt)
///      vorticity  [nz][ny][nx][3]  curl u in 1/us (omega_LB / dt)
///    x fastest, so ParaView reads them as they are; each dataset carries a "units"
///    attribute, the file root the attributes step, time_us, dx_um and dt_us;
///  - fields.xmf: XDMF 3, a temporal collection of uniform 3DCoRectMesh grids (node
///    centred: cell (x, y, z) at (x, y, z) dx, Origin 0, DxDyDz in micrometres), Time in
///    microseconds. Rewritten after each snapshot through a temporary file and a rename, so
///    ParaView opens a valid file at any time; each .h5 likewise appears complete or not at
///    all. The collection lists the snapshots of this writer only (a new writer starts a new
///    collection; older .h5 files in `dir` are left alone).
///
/// With a y_plane >= 0 the writer keeps only that plane of cells (y = y_plane; vorticity
/// still from the whole field): files PREFIX_NNNNNN.h5 with [nz][1][nx] datasets and
/// PREFIX.xmf, the plane placed at y = y_plane dx (the paper's Figs. 9 and 12).
class FieldWriter {
 public:
  /// @pre dx_um > 0, dt_us > 0 (throws std::invalid_argument otherwise)
  FieldWriter(std::string dir, double dx_um, double dt_us, std::string prefix = "fields",
              int y_plane = -1);

  /// Snapshot at solver.step_count(); a second snapshot of the same step replaces the first.
  /// Throws std::runtime_error with a one-line message on I/O failure.
  void write(const FluidSolver& solver);

  /// Lists the snapshot of `step` that an earlier run wrote into this folder (a restart,
  /// DESIGN 2.4) in the XDMF file from the next write() on, if its file exists; returns
  /// whether it does.
  bool adopt(std::int64_t step);

  const std::filesystem::path& directory() const { return dir_; }
  std::filesystem::path xdmf_path() const { return dir_ / (prefix_ + ".xmf"); }
  std::filesystem::path snapshot_path(std::int64_t step) const { return dir_ / snapshot_name(step); }
  std::size_t snapshots() const { return snapshots_.size(); }

 private:
  struct Snapshot {
    std::int64_t step;
    GridShape shape;
  };
  std::string snapshot_name(std::int64_t step) const;
  /// The shape written: the grid, or one y plane of it.
  GridShape written_shape() const;
  void write_hdf5(const std::filesystem::path& file, std::int64_t step);
  void write_xdmf() const;

  std::filesystem::path dir_;
  double dx_um_, dt_us_;
  std::string prefix_;
  int y_plane_;
  std::vector<Snapshot> snapshots_;
  // Work arrays kept between snapshots.
  MacroscopicFields m_;
  std::vector<double> wx_, wy_, wz_, vec_;
};

}  // namespace cosim::fluid
