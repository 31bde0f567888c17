// The solid's own energy where it reports one: `step` and `total_energy_J` of the solid.h5
// that a solid writes into its --output folder (the solid library's, sdk/solid_series.hpp,
// when the model gives Solid::energy_lb; the solid server's, solid/io/coupled_series.hpp).
// The protocol carries no energy: the kit reads the file after the session. IO only.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cosim::conformance {

/// E after each step the solid recorded, in joules; `none` says why there is none.
struct SolidEnergies {
  std::vector<std::int64_t> step;
  std::vector<double> total_J;
  std::string none;  ///< empty when read

  bool reported() const { return none.empty(); }
};

/// Reads `path`: a missing file, or one without `total_energy_J`, is `none` (the solid
/// reports no energy), as is one that does not read (named, with HDF5's reason). Never throws.
SolidEnergies read_solid_energies(const std::string& path);

}  // namespace cosim::conformance
