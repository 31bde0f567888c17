// HDF5 cache of the RCGP construction, keyed by a hash of its inputs (DESIGN 4.3 item 9).
//
// One file per construction, <cache_dir>/rcgp-<rcgp_input_hash>.h5, holding every field of
// RcgpConstruction in SI units (float64 little endian, so a load is bit for bit the build):
//   /                        attributes format_version, input_hash, bond_length_m,
//                            atom_mass_kg, stage1_mass_identity_defect
//   /options                 attributes stages, flexural_scaling ("paper" | "physical"),
//                            truncation_range, moment_matching (0 | 1), bending_poisson,
//                            cache_dir
//   /force_constants         (4 shells, 3) N/m: radial, tangential_in, tangential_out
//   /atomistic               attributes c11_N_m, c12_N_m, c66_N_m, youngs_modulus_N_m,
//                            poisson_ratio, kappa_J
//   /stage1_consistent_mass_kg  ((2 range + 1)^2) kg, CgKernel indexing
//   /stages                  attribute count; groups 01, 02, ... (stage 1 first), each with
//                            attributes stage, lumped_mass_kg, atoms_per_cgp,
//                            translation_invariance_defect, stable_time_step_s and groups
//     projected, kernel      attributes ax_m, ay_m, range; in_plane ((2 range + 1)^2, 2, 2)
//                            [entry][row][column] N/m; flexural ((2 range + 1)^2) N/m
//     target                 in_plane_sum (2, 2), in_plane_second (4, 3), flexural_second
//                            (3), flexural_fourth (5) [row][column]; attribute flexural_sum
//     constants, spectrum    attributes named as the fields of SheetConstants and
//                            KernelSpectrum
#pragma once

#include <string>

#include "solid/rcgp/force_constant_model.hpp"
#include "solid/rcgp/rcgp_construction.hpp"
#include "solid/model/solid_config.hpp"

namespace cosim::solid {

/// <options.cache_dir>/rcgp-<rcgp_input_hash(options, atoms)>.h5 (empty when there is no
/// cache_dir).
std::string rcgp_cache_file(const RcgpOptions& options, const ForceConstantModel& atoms);

/// build_rcgp() through the cache. With an empty options.cache_dir it only builds.
/// Otherwise it loads rcgp_cache_file() when that file is readable and holds the same input
/// hash; else it builds and writes the file atomically (a temporary name in the same folder,
/// then a rename). A corrupt or mismatching file is rebuilt and overwritten. Creates
/// cache_dir if missing. `how` (if given) receives "loaded from PATH" or
/// "built in X s, cached in PATH" (plus what was wrong with a replaced file).
/// Throws std::runtime_error (one line naming the path and the OS or HDF5 reason) when the
/// cache folder cannot be created or the file cannot be written, and what build_rcgp()
/// throws.
RcgpConstruction load_or_build_rcgp(const RcgpOptions& options,
                                    const ForceConstantModel& atoms = ForceConstantModel{},
                                    std::string* how = nullptr);

/// Writes `construction` to the HDF5 file `path` (replacing it atomically: a temporary name
/// in the same folder, then a rename) with its input hash as the attribute input_hash.
/// Throws std::runtime_error naming the file and the reason.
void save_rcgp(const RcgpConstruction& construction, const std::string& path);

/// Reads a file written by save_rcgp(). Throws std::runtime_error naming the file and what
/// is wrong (missing, not HDF5, another format version, a missing or misshapen field).
RcgpConstruction load_rcgp(const std::string& path);

}  // namespace cosim::solid
