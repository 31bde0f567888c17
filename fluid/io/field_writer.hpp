// Snapshots of rho, u and vorticity as HDF5 files with an XDMF index for ParaView.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fluid/solver/fluid_solver.hpp"
#include "fluid/observables/vorticity.hpp"

namespace cosim::protocol {
class WriteGroup;
}

namespace cosim::fluid {

/// What one process writes into a snapshot: planes z0 .. z0 + nz() - 1 of a grid of
/// nz_whole planes (all of them in one process), their macroscopic fields in `m` from its
/// plane `ghosts` on, with `ghosts` planes of the grid either side for the vorticity
/// (vorticity(m, periodic, ghosts, ...)), at step `step`.
struct FieldPart {
  MacroscopicFields m;
  std::array<bool, 3> periodic{};  ///< per axis x, y, z
  int ghosts = 0, z0 = 0, nz_whole = 0;
  /// The same along y for a block cut along y (rows y0 .. y0 + ny() - 1 of ny_whole, from
  /// m's row y_ghosts on); y_ghosts = 0 and ny_whole = m.shape.ny for whole planes.
  int y_ghosts = 0, y0 = 0, ny_whole = 0;
  std::int64_t step = 0;
  int nz() const { return m.shape.nz - 2 * ghosts; }
  int ny() const { return m.shape.ny - 2 * y_ghosts; }
  /// The whole grid of `solver`, in `into` (its arrays reused).
  static void whole(const FluidSolver& solver, FieldPart& into);
};

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
  /// The same, written by the processes of `group` together (nullptr: this one alone), each
  /// its own part (parallel HDF5, DESIGN 8): the leading process creates the file and its
  /// XDMF index, each writes its planes' rows. Collective; the same exception on every
  /// process.
  void write(const FieldPart& part, const protocol::WriteGroup* group);

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
  /// The leading process: the file with its attributes and datasets, no values yet.
  void create_hdf5(const std::filesystem::path& file, std::int64_t step) const;
  /// Every process: its part's rows of rho, u and vorticity.
  void write_rows(const std::filesystem::path& file, const FieldPart& part, const protocol::WriteGroup& group);
  void write_xdmf() const;

  std::filesystem::path dir_;
  double dx_um_, dt_us_;
  std::string prefix_;
  int y_plane_;
  std::vector<Snapshot> snapshots_;
  GridShape grid_{};  // the whole grid's shape, of the latest write
  // Work arrays kept between snapshots.
  FieldPart whole_;
  std::vector<double> wx_, wy_, wz_, vec_;
};

}  // namespace cosim::fluid
