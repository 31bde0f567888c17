// A spring-network sheet on the solid library (sdk/include/cosim/solid.hpp): the scene's
// sheets as point masses joined by linear springs to their 8 neighbours (edges and
// diagonals of the marker grid, rest lengths from the flat sheet), the clamped rows held,
// in the fluid's reaction (Eqs. 18-20) with the sample frozen over the A_T substeps.
// Lattice units (dx, dt_LB, rho_air). Parameters (after the scene on the command line):
//   --areal-density S  mass per area in rho_air dx (default 10; graphene at dx = 0.2561 um is
//                      about 2.5), a marker's mass m_l = S dA_l
//   --stiffness K      spring constant in rho_air dx c^2 (default 0.02)
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cosim/solid.hpp"

namespace spring_sheet {

using Eigen::Index;
using Eigen::Matrix3Xd;
using Eigen::Vector3d;

class SpringSheet : public cosim::sdk::Solid {
 public:
  std::string model() const override { return "spring-sheet"; }

  cosim::sdk::Markers start(const cosim::sdk::Scene& scene) override {
    density_ = scene.param("areal-density", 10.0);
    k_ = scene.param("stiffness", 0.02);
    if (!(density_ > 0.0) || !(k_ > 0.0))
      throw std::invalid_argument("--areal-density and --stiffness must be > 0");
    dt_lb_s_ = scene.dt_lb_s;
    x_ = scene.position_lb;
    v_ = Matrix3Xd::Zero(3, x_.cols());
    mass_ = density_ * scene.area_lb;
    area_ = scene.area_lb;
    held_.assign(std::size_t(x_.cols()), false);
    Index first = 0;
    for (const cosim::sdk::Sheet& s : scene.sheets) {
      const auto at = [&](int i, int j) { return first + i + Index(s.nx) * j; };
      for (int j = 0; j < s.ny; ++j)
        for (int i = 0; i < s.nx; ++i) {
          if (j < s.clamped_rows) held_[std::size_t(at(i, j))] = true;
          for (const auto& [di, dj] : {std::pair{1, 0}, {0, 1}, {1, 1}, {-1, 1}})
            if (i + di >= 0 && i + di < s.nx && j + dj < s.ny) add_spring(at(i, j), at(i + di, j + dj));
        }
      first += Index(s.nx) * s.ny;
    }
    return {x_, area_};
  }

  cosim::sdk::Answer step(const cosim::sdk::Interval& in) override {
    const Index n = x_.cols();
    const double dt = 1.0 / in.substeps;
    cosim::sdk::Answer a;
    a.impulse_lb = Matrix3Xd::Zero(3, n);
    a.position_lb = 0.5 * x_;  // the trapezoid mean over the substep boundaries
    Matrix3Xd f(3, n);
    for (int k = 0; k < in.substeps; ++k) {
      spring_forces(f);
      for (Index l = 0; l < n; ++l) {
        const Vector3d u = in.velocity_lb.col(l);
        // g dA at the marker's velocity U_B (0 for a held one): to the fluid, and its
        // opposite to the marker (Eqs. 18-19); J_l is its mean over the substeps (Eq. 24).
        const Vector3d g = cosim::sdk::momentum_exchange(in.rho_lb[l], v_.col(l), u, area_[l]);
        a.impulse_lb.col(l) += g / in.substeps;
        if (held_[std::size_t(l)]) continue;
        v_.col(l) += dt / mass_[l] * (f.col(l) - g);  // symplectic Euler (Eq. 20)
        x_.col(l) += dt * v_.col(l);
      }
      a.position_lb += (k + 1 < in.substeps ? 1.0 : 0.5) * x_;
    }
    a.position_lb /= in.substeps;
    return a;
  }

  /// 2 / omega_max, omega_max^2 <= max over markers of 2 sum_s k / m (Gershgorin).
  double stable_dt_cg_s() const override {
    double w2 = 0.0;
    for (Index l = 0; l < x_.cols(); ++l) w2 = std::max(w2, 2.0 * k_ * springs_at_[std::size_t(l)] / mass_[l]);
    return w2 > 0.0 ? 2.0 / std::sqrt(w2) * dt_lb_s_ : cosim::sdk::Solid::stable_dt_cg_s();
  }

  /// Checkpoints: the positions and velocities.
  std::vector<double> save() const override {
    std::vector<double> s(x_.data(), x_.data() + x_.size());
    s.insert(s.end(), v_.data(), v_.data() + v_.size());
    return s;
  }
  void restore(const std::vector<double>& s) override {
    if (s.size() != std::size_t(2 * x_.size())) throw std::invalid_argument("a state of another marker count");
    x_ = Eigen::Map<const Matrix3Xd>(s.data(), 3, x_.cols());
    v_ = Eigen::Map<const Matrix3Xd>(s.data() + x_.size(), 3, x_.cols());
  }

  /// Kinetic + elastic energy, rho_air dx^3 c^2: the library writes it to solid.h5 and checks
  /// it against the fluid's work on the markers.
  double energy_lb() const override {
    double e = 0.0;
    for (Index l = 0; l < x_.cols(); ++l) e += 0.5 * mass_[l] * v_.col(l).squaredNorm();
    for (const Spring& s : springs_) {
      const double stretch = (x_.col(s.b) - x_.col(s.a)).norm() - s.rest;
      e += 0.5 * k_ * stretch * stretch;
    }
    return e;
  }

 private:
  struct Spring {
    Index a, b;
    double rest;
  };

  void add_spring(Index a, Index b) {
    springs_.push_back({a, b, (x_.col(b) - x_.col(a)).norm()});
    springs_at_.resize(std::size_t(x_.cols()), 0);
    ++springs_at_[std::size_t(a)];
    ++springs_at_[std::size_t(b)];
  }

  void spring_forces(Matrix3Xd& f) const {
    f.setZero();
    for (const Spring& s : springs_) {
      const Vector3d d = x_.col(s.b) - x_.col(s.a);
      const double len = d.norm();
      const Vector3d t = k_ * (len - s.rest) / len * d;
      f.col(s.a) += t;
      f.col(s.b) -= t;
    }
  }

  double density_ = 10.0, k_ = 0.02, dt_lb_s_ = 0.0;
  Matrix3Xd x_, v_;
  Eigen::VectorXd mass_, area_;
  std::vector<bool> held_;
  std::vector<Spring> springs_;
  std::vector<int> springs_at_;
};

}  // namespace spring_sheet
