#include "common/hdf5/dataset_units.hpp"

#include <array>
#include <string_view>
#include <utility>

namespace cosim::protocol {

namespace {

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

}  // namespace

std::optional<std::string> dataset_units(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  const std::string_view name = slash == std::string::npos ? std::string_view(path) : std::string_view(path).substr(slash + 1);
  // Names that are not self-describing (the lattice's own quantities, counters, flags).
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 19> kTable{{
      {"step", "LB steps"},
      {"substep", "solid substeps (dt_CG)"},
      {"mass", "lattice units: rho_0 dx^3 (sum of rho over the cells)"},
      {"momentum", "lattice units: rho_0 dx^3 c (sum of rho u over the cells, x y z)"},
      {"max_mach", "1 (|u| / c_s)"},
      {"rho_min", "1 (rho / rho_0)"},
      {"rho_max", "1 (rho / rho_0)"},
      {"rho", "1 (rho / rho_0)"},
      {"max_mach_cell", "cell index (x, y, z)"},
      {"rho_min_cell", "cell index (x, y, z)"},
      {"rho_max_cell", "cell index (x, y, z)"},
      {"nan_cell", "cell index (x, y, z); -1 when none"},
      {"has_nan", "1 (flag: 1 when a non-finite value was found)"},
      {"force_coefficients", "1 (C_D, C_L, C_S: Eq. 33 with U_b of Eq. 34)"},
      {"leading_edge_strain", "1 (engineering strain)"},
      {"area_strain", "1 (relative change of the CGP's area)"},
      {"sheet", "sheet index (0-based, the scene's [[sheet]] order)"},
      {"quads", "node index (0-based, 4 per quad)"},
      {"sheet_grid", "CGPs (nx_cg, ny_cg per sheet)"},
  }};
  for (const auto& [n, u] : kTable)
    if (n == name) return std::string(u);
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 7> kSuffix{{
      {"_um", "um"}, {"_m_s", "m/s"}, {"_N", "N"}, {"_J", "J"}, {"_us", "us"}, {"_s", "s"}, {"_deg", "deg"},
  }};
  for (const auto& [s, u] : kSuffix)
    if (ends_with(name, s)) return std::string(u);
  return std::nullopt;
}

}  // namespace cosim::protocol
