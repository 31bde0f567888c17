// Contact between sheets (DESIGN 4.3 item 8): the repulsive Lennard-Jones force of section
// 3.2 of the paper, which keeps a pair of sheets from passing through each other when they
// collide. On CGP i
//   F_i = (4 eps / s) sum_j {12 (s/r_ij)^13 - 6 (s/r_ij)^7} r_ij / r_ij   for r_ij < s,
// and 0 for r_ij >= s, with r_ij = X_i - X_j, j running over the CGPs of the OTHER sheets
// only (a sheet's own CGPs interact through its elastic model), s = dx_CG and eps = 1000 eV
// in the paper. The force is minus the gradient of the pair energy
//   U(r) = 4 eps [(s/r)^12 - (s/r)^6]  for r < s,   0 for r >= s.
// The cut sits at sigma, where the Lennard-Jones energy crosses zero, not at its minimum
// 2^(1/6) s: U is continuous at r = s, but the force is not -- it jumps from 0 to
// 24 eps / s as a pair crosses into range. The integrator sees an impulse there, so the
// energy of a collision is conserved only to O(dt), not to O(dt^2).
//
// Units: Hartree atomic units as in the rest of cosim::solid (solid_model.hpp): energies
// in E_h, lengths in bohr, forces in E_h / bohr.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "protocol/units.hpp"

namespace cosim::solid {

/// An energy in electron volts in hartree (CODATA 2018: 1 E_h = 27.211386245988 eV).
inline constexpr double hartree_from_eV(double energy_eV) {
  return energy_eV / protocol::PhysicalConstants::hartree_eV;
}

/// The inter-sheet contact of section 3.2 of the paper over one array of CGPs (the
/// SolidConfig order, or any other: only the sheet labels matter).
///
/// Sheets usually stand several dx_CG apart and touch only in collisions, so add_forces()
/// keeps a Verlet neighbour list of the inter-sheet pairs closer than sigma + skin and
/// rebuilds it (by cell binning, O(N)) only when some CGP has moved more than skin / 2
/// since the last build; between rebuilds a call costs one pass over the CGPs plus one over
/// the list. Pairs are kept in ascending (i, j) order and everything runs on the calling
/// thread, so the result does not depend on the binning or on timing.
class LjContact {
 public:
  /// @param sheet_of_cgp     sheet label of each CGP; CGPs with equal labels never interact
  /// @param epsilon_hartree  eps, E_h (the paper's 1000 eV is hartree_from_eV(1000))
  /// @param sigma_bohr       s = the cut-off, bohr (the paper: dx_CG)
  /// @param skin_bohr        extra range of the neighbour list, bohr; 0 rebuilds the list
  ///                         on every call in which any CGP moved
  /// Throws std::invalid_argument (file:line and what is allowed) unless there is at least
  /// one CGP, eps and sigma are positive and finite, and the skin is finite and >= 0.
  LjContact(std::vector<int> sheet_of_cgp, double epsilon_hartree, double sigma_bohr,
            double skin_bohr);

  /// Adds the contact forces at positions x (3 x N, bohr) into f (3 x N, E_h / bohr) and
  /// returns the contact energy, E_h. Rebuilds the neighbour list when needed. Throws
  /// std::invalid_argument on a wrong shape or on non-finite positions at a rebuild.
  double add_forces(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f);

  /// The contact energy at x, E_h, exactly (every inter-sheet pair closer than sigma);
  /// uses the neighbour list when it is still valid for x, a fresh binned search otherwise.
  /// Leaves the list and the counters alone.
  double energy(const Eigen::Matrix3Xd& x) const;

  Eigen::Index num_cgps() const { return static_cast<Eigen::Index>(sheet_.size()); }
  double epsilon_hartree() const { return epsilon_; }
  double sigma_bohr() const { return sigma_; }
  double skin_bohr() const { return skin_; }

  /// Inter-sheet pairs closer than sigma at the last add_forces() call.
  std::size_t pairs_in_cutoff() const { return pairs_in_cutoff_; }
  /// Inter-sheet pairs in the neighbour list (closer than sigma + skin at its last build).
  std::size_t listed_pairs() const { return pairs_.size(); }
  /// Neighbour-list builds so far (the first add_forces() call builds it).
  std::size_t num_rebuilds() const { return rebuilds_; }
  /// Smallest inter-sheet distance met by add_forces() since construction or the last
  /// reset_min_distance(), bohr; +infinity while no pair came within sigma + skin.
  /// A collision that drives it far below sigma means eps or dt is too small.
  double min_distance_bohr() const;
  void reset_min_distance();

 private:
  struct Pair {
    Eigen::Index i;
    Eigen::Index j;
  };

  void check_shape(const Eigen::Matrix3Xd& m, const char* what, int line) const;
  /// Every inter-sheet pair of x closer than `range`, in ascending (i, j) order.
  std::vector<Pair> find_pairs(const Eigen::Matrix3Xd& x, double range) const;
  /// Whether every CGP of x lies within skin / 2 of its position at the last build.
  bool list_valid_for(const Eigen::Matrix3Xd& x) const;

  std::vector<int> sheet_;
  double epsilon_;
  double sigma_;
  double skin_;

  std::vector<Pair> pairs_;
  Eigen::Matrix3Xd x_built_;  ///< positions at the last build; empty before the first
  std::size_t rebuilds_ = 0;
  std::size_t pairs_in_cutoff_ = 0;
  double min_r2_;
};

}  // namespace cosim::solid
