// Aitken's dynamic relaxation of a fixed-point iteration x = G(x), the acceleration that
// partitioned fluid-structure codes use for their sub-iterations (Irons & Tuck 1969;
// Kuettler & Wall, Comput. Mech. 43 (2008) 61-72, Eq. 44; preCICE's "aitken"):
//
//   r_k = G(x_k) - x_k,     x_{k+1} = x_k + omega_k r_k,
//   omega_k = -omega_{k-1} r_{k-1} . (r_k - r_{k-1}) / |r_k - r_{k-1}|^2   (k >= 1).
//
// For a linear map with a single eigenvalue omega_1 is exact and the iteration converges in
// two steps.
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

namespace cosim::solid {

class AitkenRelaxation {
 public:
  /// @param first  omega_0 of the first step, in (0, 1]
  explicit AitkenRelaxation(double first) : start_(first) {}

  /// A new time step: its first relaxation uses the magnitude of the previous step's last
  /// factor (at most 1; the run's first step: `first`).
  void new_step() {
    if (have_last_ && std::isfinite(omega_) && omega_ != 0.0) start_ = std::min(std::abs(omega_), 1.0);
    omega_ = start_;
    have_previous_ = false;
  }

  /// The next iterate from x_k and g = G(x_k).
  Eigen::Matrix3Xd next(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& g) {
    const Eigen::Matrix3Xd r = g - x;
    if (have_previous_) {
      const Eigen::Matrix3Xd dr = r - previous_residual_;
      const double dr2 = dr.squaredNorm();
      if (dr2 > 0.0) omega_ = -omega_ * (previous_residual_.cwiseProduct(dr).sum()) / dr2;
    }
    previous_residual_ = r;
    have_previous_ = true;
    have_last_ = true;
    return x + omega_ * r;
  }

  /// The factor the last next() used.
  double omega() const { return omega_; }
  /// The factor the first next() of the current step used.
  double step_start() const { return start_; }
  /// For checkpoints: the factor a restart's next new_step() starts from.
  void restore_start(double start) {
    start_ = start;
    omega_ = start;
    have_last_ = false;
  }

 private:
  double start_;
  double omega_ = 0.0;
  bool have_previous_ = false;
  bool have_last_ = false;
  Eigen::Matrix3Xd previous_residual_;
};

}  // namespace cosim::solid
