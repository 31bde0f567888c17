// The recursive coarse-grained particle (RCGP) construction of graphene (the paper's
// section 2.1, Eqs. 1-6, Fig. 1; DESIGN 4.3 items 2-5).
//
// Stage 1 projects the atomistic harmonic model (force_constant_model.hpp) of a periodic
// super cell of 2n x 2n rectangular 8-atom unit cells (n = 2 range + 1; 10 x 10 cells,
// 800 atoms for range 2) on n x n CGPs with the weights phi = (N^T N)^-1 N^T of bilinear
// shape functions N (so phi N = I):
//   K_CG = (phi D^+ phi^T)^+        (Eq. 4, K = [(phi D^-1 phi^t)^-1])
// where ^+ is the pseudo-inverse with exactly the rigid translations removed (D is
// singular: two in-plane and one out-of-plane translation). Stage j + 1 expands the
// n x n periodic cell of stage j 2 x 2 and projects it back on n x n CGPs (lambda = 2).
//
// Each stage's stiffness is translation invariant on the CG lattice, so it is kept as a
// kernel K(R) of range (n - 1) / 2 (cg_kernel.hpp). The exact kernel is long-ranged; the
// periodic cell folds its tail back onto the range, which changes its long-wave moments.
// Moment-matched truncation restores the sum rules and the moments that carry the
// elasticity (Eq. 6: the elastic constants are second moments of K; bending is the fourth
// moment of the flexural block), so that the moduli stay the same from stage to stage.
//
// Scaling (DESIGN 4.3 item 4): the projection itself keeps the in-plane kernel (lambda^0,
// d = 2) and scales the flexural kernel by lambda^-2 (kappa fixed, the CG spring is
// kappa / h^2). FlexuralScaling::Paper multiplies the flexural kernel back by lambda^2
// per stage (and by (h_1 / a)^2 = 16 at stage 1, a = sqrt(3) d the atomic spacing), as the
// paper's K^(j+1) ~ lambda^(d-2) K^(j) does for every block: bending then is Lambda^2
// times graphene's. The lumped CGP mass grows by lambda^2 per stage (M^(j+1) =
// lambda^d M^(j)); for one atomic species (phi m^-1 phi^T)^-1 = m N^T N exactly.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "solid/rcgp/cg_kernel.hpp"
#include "solid/rcgp/force_constant_model.hpp"
#include "solid/model/solid_config.hpp"

namespace cosim::solid {

struct RcgpStage {
  int stage = 0;              ///< 1..N_r
  CgKernel projected;         ///< straight from the projection (the periodic cell's kernel)
  CgKernel kernel;            ///< truncated and moment matched: what the next stage uses
  KernelMoments target;       ///< the moments that matching restored
  double lumped_mass_kg = 0.0;  ///< mass of the atoms of one CG cell
  double atoms_per_cgp = 0.0;
  /// The translation invariance of the projected stiffness matrix: largest deviation of a
  /// block from the kernel, relative to the largest entry (round-off).
  double translation_invariance_defect = 0.0;
  SheetConstants constants;     ///< of `kernel` (Eq. 6), intensive
  KernelSpectrum spectrum;      ///< of `kernel`
  /// 2 / omega_max of the periodic CG lattice with the lumped mass, s.
  double stable_time_step_s = 0.0;
};

struct RcgpConstruction {
  RcgpOptions options;
  ForceConstants force_constants;
  double bond_length_m = 0.0;
  double atom_mass_kg = 0.0;
  ElasticConstants2D atomistic;       ///< from the long-wave sound velocities
  double atomistic_kappa_J = 0.0;     ///< from the ZA branch (shell sums)
  std::vector<RcgpStage> stages;      ///< stage 1 first
  /// Stage 1's consistent mass kernel m (N^T N)(R), kg, same indexing as CgKernel.
  std::vector<double> stage1_consistent_mass_kg;
  /// Largest deviation of (phi m^-1 phi^T)^-1 from m N^T N at stage 1, relative.
  double stage1_mass_identity_defect = 0.0;

  const RcgpStage& final_stage() const { return stages.back(); }
  /// Lambda = final CG spacing along x over the atomic lattice constant sqrt(3) d.
  double coarse_graining_ratio() const;
};

/// Runs the construction. Throws std::invalid_argument for options out of range (stages
/// 1..16 -- resolve 0 with rcgp_stages_for_spacing first -- truncation_range 2..4) and std::runtime_error when a stage's stiffness is not
/// positive (an unstable force-constant model, or a truncation that breaks K(q) >= 0).
RcgpConstruction build_rcgp(const RcgpOptions& options,
                            const ForceConstantModel& atoms = ForceConstantModel{});

/// The stage count whose final CG spacing along x is closest to `spacing_m`:
/// N_r = 1 + round(log2(spacing / (4 sqrt(3) d))), at least 1. Throws
/// std::invalid_argument for a spacing that needs more than 16 stages or is not positive.
int rcgp_stages_for_spacing(double spacing_m, double bond_length_m = GrapheneLattice::kBondLengthM);

/// A hash of everything the construction depends on (options that change it, force
/// constants, bond length, mass, code version), as 16 hex digits: the cache key.
std::string rcgp_input_hash(const RcgpOptions& options, const ForceConstantModel& atoms);

}  // namespace cosim::solid
