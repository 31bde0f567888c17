// The internal forces of the elastic sheet models: the linear energy of
// sheet_stiffness.hpp, and its corotational variant for large deflection (DESIGN 4.3
// item 7). Hartree atomic units.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "solid/models/elastic_sheet/sheet_stiffness.hpp"

namespace cosim::solid {

/// One sheet of a model: where its CGPs sit in the model's arrays, its axes, its
/// reference (flat) positions and its energy terms.
struct SheetBlock {
  Eigen::Index first = 0;
  Eigen::Index count = 0;
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  ///< local (a, b, n) -> scene axes
  Eigen::Matrix3Xd reference_bohr;                     ///< 3 x count
  std::vector<StiffnessTerm> terms;                    ///< local axes, local CGP indices
  Eigen::SparseMatrix<double> stiffness;               ///< their sum, local axes
};

/// F^int(x) = -grad E(x) over all sheets; evaluate() writes the forces into f (3 x N,
/// sized by the caller) and returns E, E_h.
class SheetForce {
 public:
  virtual ~SheetForce() = default;
  virtual double evaluate(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const = 0;
};

/// E = 1/2 u^T K u with u = A^T (x - X) in each sheet's axes A: exact for small
/// displacements, and it reads a finite rotation as strain.
class LinearSheetForce final : public SheetForce {
 public:
  explicit LinearSheetForce(const std::vector<SheetBlock>& sheets) : sheets_(sheets) {}
  double evaluate(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const override;

 private:
  const std::vector<SheetBlock>& sheets_;
};

/// Corotational: each term is evaluated in its own rotated frame,
///   E_t = 1/2 u_t^T K_t u_t,  u_k = R_t^T (x_k - c_t) - (X_k - C_t),
/// with R_t the rotation of the polar decomposition F = R S of the frame's cross-covariance
/// F = sum_f (x_f - c_t)(X_f - C_t)^T (c, C: centroids of the frame's CGPs). The reference
/// frame is flat, so F = A P^T with A = sum_f (x_f - c) xi_f^T (3 x 2, xi the in-plane
/// coordinates) and P = (e_a, e_b); then R P = Q = A (A^T A)^(-1/2) (closed form for 2 x 2),
/// R n = q_1 x q_2, and S = R^T F = P (A^T A)^(1/2) P^T: the polar factor with det R = +1,
/// without a 3 x 3 SVD. E is
/// invariant under any rigid motion, equals the linear energy to second order, and the
/// force is its exact gradient, dR included (a term with an empty frame, tied to the
/// plate, is evaluated in the fixed frame): with R^T dR = Omega (axial omega),
///   (tr S I - S) omega = sum_f (X_f - C) x R^T dx_f.
/// The terms are evaluated in groups of equal shape and stiffness, kLanes terms at a time
/// (one SIMD lane each); the per-term evaluation it replaced is kept as the reference of
/// the tests (tests/support/corotational_reference.hpp), which it matches to round-off.
class CorotationalSheetForce final : public SheetForce {
 public:
  /// Which kernels evaluate the groups: those compiled for a rectangular sheet's term
  /// shapes where they fit (the default), or the general one for every group (for the
  /// tests: the same forces to round-off).
  enum class Kernels { Compiled, General };
  explicit CorotationalSheetForce(const std::vector<SheetBlock>& sheets,
                                  Kernels kernels = Kernels::Compiled);
  double evaluate(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const override;

  /// How many groups of terms (same shape, coupling and K) evaluate() runs.
  std::size_t num_groups() const { return groups_.size(); }

  /// Which local components a term's stiffness couples. On a flat reference sheet the
  /// membrane (Q4) terms touch only the in-plane (a, b) components and the plate terms only
  /// the normal one (a cell term both, in two uncoupled blocks), so each is applied as a
  /// 2m x 2m and/or m x m matrix instead of 3m x 3m.
  enum class Coupling { InPlane, Normal, Split, All };

  /// Terms are evaluated in batches of this many, one term per SIMD lane (one AVX-512
  /// register; 16 lanes, two registers, measured no faster).
  static constexpr int kLanes = 8;
  using Lanes = Eigen::Array<double, kLanes, 1>;

 private:
  /// Terms of one shape (frame size, node count, which frame point each node is), one
  /// coupling and one stiffness matrix (bit-equal), stored structure-of-arrays by batch:
  /// entry [batch][point or node][component][lane]. A term's points are its frame (in
  /// the frame's order) followed by its nodes outside the frame.
  struct Group {
    int nf = 0, m = 0, np = 0;          ///< frame points, nodes, all points
    Coupling coupling = Coupling::All;
    std::vector<int> slot;              ///< m: the point of each node
    std::vector<double> k_plane;        ///< 2m x 2m row-major, (a, b) of every node
    std::vector<double> k_normal;       ///< m x m row-major, n of every node
    std::vector<double> k_all;          ///< 3m x 3m row-major (coupling All)
    Eigen::Matrix3d axes;               ///< the sheet's axes (used when nf == 0)
    int count = 0, batches = 0;
    std::size_t first_out = 0;          ///< where its forces start in out_
    /// evaluate_batches for its sizes and coupling: compiled for those of a rectangular
    /// sheet's terms, the general one for any other.
    void (CorotationalSheetForce::*kernel)(const Group&, const double*, double&) const = nullptr;
    std::vector<int> offsets;           ///< [batch][np][lane] 3 x the model-wide CGP index
    std::vector<Lanes> ref_frame;       ///< [batch][nf][3] X - C of the frame, local axes
    std::vector<Lanes> ref_nodes;       ///< [batch][m][3] X - C of the nodes, local axes
  };
  /// The batches of one group; a size or coupling of -1 is read from the group.
  template <int kNf, int kNp, int kM, int kCoupling>
  void evaluate_batches(const Group& g, const double* x, double& energy) const;
  std::vector<Group> groups_;
  /// Each batch's forces on its points, [group's first_out + (batch np + point) 3 + c]
  /// (scene axes, one lane per term); scratch of evaluate(), which is therefore not
  /// reentrant.
  mutable std::vector<Lanes> out_;
  /// The entries of out_ (as doubles, component a; b and n follow kLanes and 2 kLanes
  /// later) that add up to each CGP's force: CGP l sums gather_per_cgp_ of them from
  /// gather_[l gather_per_cgp_] on (the shorter lists padded with zeros).
  std::vector<std::size_t> gather_;
  std::size_t gather_per_cgp_ = 0;
};

}  // namespace cosim::solid
