// Snapshots of the sheets for visualisation (the paper's Fig. 11: the CGPs coloured by their
// area strain, section 3.2): one HDF5 file per snapshot, OUTPUT/sheets_NNNNNN.h5, and one
// XDMF 3 file, OUTPUT/sheets.xmf, that ParaView opens as a temporal collection of quad
// surfaces (one quad per cell of each sheet's nx_cg x ny_cg grid of CGPs) with per-node
// attributes. Written by the `solid` executable when a scene sets [output] sheets_every
// (scenes/README.md): every sheets_every LB steps of a coupled run, substeps of a standalone
// one, and at the first and the last.
//
// Layout of sheets_NNNNNN.h5 (n CGPs of all sheets in the model's order, SolidConfig; q quads):
//   position_um      float64 n x 3   CGP positions in the solid's frame (plate surface y = 0)
//   displacement_um  float64 n x 3   position - the flat reference position
//   velocity_m_s     float64 n x 3
//   area_strain      float64 n       (|dA_l| - |dA_l0|) / |dA_l0|, section 3.2 and Fig. 11
//   sheet            int32   n       the sheet of each CGP (0, 1, ...)
//   quads            int64   q x 4   CGP indices of each quad, counter-clockwise in (i, j):
//                                    (i, j), (i+1, j), (i+1, j+1), (i, j+1); sheet by sheet
//   sheet_grid       int32   sheets x 2   nx_cg, ny_cg of each sheet
//   attributes: step (int64; LB step, or substep standalone), time_s, time_us, frame,
//               area_strain (its definition)
// HDF5 stays out of this header (the library's headers do not expose it).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "solid/model/solid_config.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::solid {

/// Whether `step` of a run whose last step is `last` gets a snapshot: never for every = 0;
/// else at step 0, every `every` steps and at `last`.
bool sheet_snapshot_due(std::int64_t step, std::int64_t last, std::int64_t every);

class SheetSnapshotWriter {
 public:
  /// Creates `dir` if needed. Throws std::runtime_error if it cannot, and
  /// std::invalid_argument for a config without sheets or with a sheet check_sheet_spec
  /// refuses.
  SheetSnapshotWriter(std::filesystem::path dir, const SolidConfig& config);

  /// Writes sheets_NNNNNN.h5 for `step` (time `time_s` seconds) from the model's current
  /// state, then rewrites sheets.xmf with every snapshot so far (a run that stops later
  /// still leaves a valid file). Each file is written under a .part name and renamed, so a
  /// file of the final name is complete. The area strain is the model's
  /// (SolidObservables::area_strain), or computed from the positions where a model leaves
  /// it empty. A step written again replaces its snapshot. Throws std::runtime_error
  /// naming the file on an output error, std::invalid_argument if the model's CGP count
  /// is not the config's.
  void write(std::int64_t step, double time_s, const SolidModel& model);

  /// Lists the snapshot of `step` (time `time_s`) that an earlier run wrote into this
  /// folder (a restart, DESIGN 2.4) in sheets.xmf from the next write() on, if its file
  /// exists; returns whether it does.
  bool adopt(std::int64_t step, double time_s);

  /// "sheets_000050.h5" for step 50.
  static std::string snapshot_name(std::int64_t step);
  std::filesystem::path snapshot_path(std::int64_t step) const { return dir_ / snapshot_name(step); }
  std::filesystem::path xdmf_path() const { return dir_ / "sheets.xmf"; }
  /// Snapshots written so far.
  std::size_t count() const { return snapshots_.size(); }

 private:
  struct Snapshot {
    std::int64_t step;
    double time_us;
  };
  void write_hdf5(const std::filesystem::path& file, std::int64_t step, double time_s,
                  const SolidModel& model);
  void write_xdmf() const;

  std::filesystem::path dir_;
  SolidConfig config_;
  Eigen::Index n_ = 0;
  Eigen::Matrix3Xd reference_bohr_;      ///< flat positions of all sheets
  std::vector<std::int32_t> sheet_of_;   ///< n
  std::vector<std::int64_t> quads_;      ///< q x 4, row-major
  std::vector<std::int32_t> grid_;       ///< sheets x 2
  std::vector<Snapshot> snapshots_;
};

}  // namespace cosim::solid
