#include "solid/rcgp/cg_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

namespace cosim::solid {

namespace {

using cd = std::complex<double>;

/// Second-moment column of R_j R_l: xx, xy, yy.
constexpr std::array<std::array<int, 2>, 3> kSecond{{{2, 0}, {1, 1}, {0, 2}}};
/// Fourth-moment powers (of R_x, R_y): xxxx, xxxy, xxyy, xyyy, yyyy.
constexpr std::array<std::array<int, 2>, 5> kFourth{{{4, 0}, {3, 1}, {2, 2}, {1, 3}, {0, 4}}};

double ipow(double x, int p) {
  double r = 1.0;
  for (int i = 0; i < p; ++i) r *= x;
  return r;
}

}  // namespace

CgKernel CgKernel::zero(double ax_m, double ay_m, int range) {
  CgKernel k;
  k.ax_m = ax_m;
  k.ay_m = ay_m;
  k.range = range;
  const auto n = static_cast<std::size_t>(k.width() * k.width());
  k.in_plane.assign(n, Eigen::Matrix2d::Zero());
  k.flexural.assign(n, 0.0);
  return k;
}

Eigen::Matrix2cd CgKernel::in_plane_q(const Eigen::Vector2d& q) const {
  Eigen::Matrix2cd out = Eigen::Matrix2cd::Zero();
  for (int ry = -range; ry <= range; ++ry)
    for (int rx = -range; rx <= range; ++rx)
      out += ip(rx, ry).cast<cd>() * std::polar(1.0, q.x() * rx * ax_m + q.y() * ry * ay_m);
  return out;
}

double CgKernel::flexural_q(const Eigen::Vector2d& q) const {
  double out = 0.0;  // K(R) = K(-R): the transform is real
  for (int ry = -range; ry <= range; ++ry)
    for (int rx = -range; rx <= range; ++rx)
      out += zz(rx, ry) * std::cos(q.x() * rx * ax_m + q.y() * ry * ay_m);
  return out;
}

KernelMoments kernel_moments(const CgKernel& k) {
  KernelMoments m;
  for (int ry = -k.range; ry <= k.range; ++ry) {
    for (int rx = -k.range; rx <= k.range; ++rx) {
      const double x = rx * k.ax_m, y = ry * k.ay_m;
      const Eigen::Matrix2d& b = k.ip(rx, ry);
      m.in_plane_sum += b;
      for (std::size_t c = 0; c < kSecond.size(); ++c) {
        const double w = ipow(x, kSecond[c][0]) * ipow(y, kSecond[c][1]);
        const auto col = static_cast<Eigen::Index>(c);
        m.in_plane_second(0, col) += b(0, 0) * w;
        m.in_plane_second(1, col) += b(0, 1) * w;
        m.in_plane_second(2, col) += b(1, 0) * w;
        m.in_plane_second(3, col) += b(1, 1) * w;
        m.flexural_second(col) += k.zz(rx, ry) * w;
      }
      m.flexural_sum += k.zz(rx, ry);
      for (std::size_t c = 0; c < kFourth.size(); ++c)
        m.flexural_fourth(static_cast<Eigen::Index>(c)) +=
            k.zz(rx, ry) * ipow(x, kFourth[c][0]) * ipow(y, kFourth[c][1]);
    }
  }
  return m;
}

SheetConstants constants_from_moments(const KernelMoments& m, double a) {
  SheetConstants c;
  c.c11_N_m = -m.in_plane_second(0, 0) / (2.0 * a);
  c.c22_N_m = -m.in_plane_second(3, 2) / (2.0 * a);
  c.c66_N_m = -(m.in_plane_second(0, 2) + m.in_plane_second(3, 0)) / (4.0 * a);
  c.c12_N_m = -0.5 * (m.in_plane_second(1, 1) + m.in_plane_second(2, 1)) / a - c.c66_N_m;
  c.d11_J = m.flexural_fourth(0) / (24.0 * a);
  c.d22_J = m.flexural_fourth(4) / (24.0 * a);
  c.d_mixed_J = m.flexural_fourth(2) / (8.0 * a);
  return c;
}

KernelMoments moments_from_constants(const SheetConstants& c, double a) {
  KernelMoments m;
  m.in_plane_second(0, 0) = -2.0 * a * c.c11_N_m;  // K_xx Rx^2
  m.in_plane_second(0, 2) = -2.0 * a * c.c66_N_m;  // K_xx Ry^2
  m.in_plane_second(3, 0) = -2.0 * a * c.c66_N_m;  // K_yy Rx^2
  m.in_plane_second(3, 2) = -2.0 * a * c.c22_N_m;  // K_yy Ry^2
  m.in_plane_second(1, 1) = -a * (c.c12_N_m + c.c66_N_m);  // K_xy Rx Ry
  m.in_plane_second(2, 1) = -a * (c.c12_N_m + c.c66_N_m);
  m.flexural_fourth(0) = 24.0 * a * c.d11_J;
  m.flexural_fourth(2) = 8.0 * a * c.d_mixed_J;
  m.flexural_fourth(4) = 24.0 * a * c.d22_J;
  return m;
}

void symmetrize(CgKernel& k) {
  CgKernel s = k;
  for (int ry = -k.range; ry <= k.range; ++ry)
    for (int rx = -k.range; rx <= k.range; ++rx) {
      s.ip(rx, ry) = 0.5 * (k.ip(rx, ry) + k.ip(-rx, -ry).transpose());
      s.zz(rx, ry) = 0.5 * (k.zz(rx, ry) + k.zz(-rx, -ry));
    }
  k = std::move(s);
}

CgKernel truncated(const CgKernel& k, int range) {
  CgKernel t = CgKernel::zero(k.ax_m, k.ay_m, range);
  const int r = std::min(range, k.range);
  for (int ry = -r; ry <= r; ++ry)
    for (int rx = -r; rx <= r; ++rx) {
      t.ip(rx, ry) = k.ip(rx, ry);
      t.zz(rx, ry) = k.zz(rx, ry);
    }
  return t;
}

void match_moments(CgKernel& k, const KernelMoments& target) {
  if (k.range < 2)
    throw std::invalid_argument(
        "match_moments: a kernel of range " + std::to_string(k.range) +
        " cannot carry bending (a zero second and a non-zero fourth moment need range >= 2)");
  const int w = k.width();
  const Eigen::Index n = w * w;
  // Entries are unknowns; lengths in lattice spacings keep the rows comparable, and the
  // targets are scaled to match.
  const auto rx_of = [&](Eigen::Index e) { return static_cast<int>(e % w) - k.range; };
  const auto ry_of = [&](Eigen::Index e) { return static_cast<int>(e / w) - k.range; };

  // In-plane: 4 blocks x (1 sum + 3 second moments) = 16 rows over 4 n unknowns, entry
  // (e, ab) at column 4 e + ab with ab = xx, xy, yx, yy.
  {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(16, 4 * n);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(16);
    Eigen::VectorXd x(4 * n);
    for (Eigen::Index e = 0; e < n; ++e) {
      const Eigen::Matrix2d& blk = k.in_plane[static_cast<std::size_t>(e)];
      x.segment<4>(4 * e) << blk(0, 0), blk(0, 1), blk(1, 0), blk(1, 1);
      for (int ab = 0; ab < 4; ++ab) {
        a(ab, 4 * e + ab) = 1.0;
        for (int c = 0; c < 3; ++c)
          a(4 + 4 * c + ab, 4 * e + ab) =
              ipow(rx_of(e), kSecond[static_cast<std::size_t>(c)][0]) *
              ipow(ry_of(e), kSecond[static_cast<std::size_t>(c)][1]);
      }
    }
    for (int c = 0; c < 3; ++c) {
      const double scale = ipow(k.ax_m, kSecond[static_cast<std::size_t>(c)][0]) *
                           ipow(k.ay_m, kSecond[static_cast<std::size_t>(c)][1]);
      for (int ab = 0; ab < 4; ++ab) b(4 + 4 * c + ab) = target.in_plane_second(ab, c) / scale;
    }
    const Eigen::VectorXd dx = a.completeOrthogonalDecomposition().solve(b - a * x);
    x += dx;
    for (Eigen::Index e = 0; e < n; ++e) {
      Eigen::Matrix2d& blk = k.in_plane[static_cast<std::size_t>(e)];
      blk << x(4 * e), x(4 * e + 1), x(4 * e + 2), x(4 * e + 3);
    }
  }
  // Flexural: 1 sum + 3 second moments (zero) + 5 fourth moments = 9 rows over n unknowns.
  {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(9, n);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(9);
    Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(k.flexural.data(), n);
    for (Eigen::Index e = 0; e < n; ++e) {
      a(0, e) = 1.0;
      for (int c = 0; c < 3; ++c)
        a(1 + c, e) = ipow(rx_of(e), kSecond[static_cast<std::size_t>(c)][0]) *
                      ipow(ry_of(e), kSecond[static_cast<std::size_t>(c)][1]);
      for (int c = 0; c < 5; ++c)
        a(4 + c, e) = ipow(rx_of(e), kFourth[static_cast<std::size_t>(c)][0]) *
                      ipow(ry_of(e), kFourth[static_cast<std::size_t>(c)][1]);
    }
    for (int c = 0; c < 5; ++c)
      b(4 + c) = target.flexural_fourth(c) /
                 (ipow(k.ax_m, kFourth[static_cast<std::size_t>(c)][0]) *
                  ipow(k.ay_m, kFourth[static_cast<std::size_t>(c)][1]));
    x += a.completeOrthogonalDecomposition().solve(b - a * x);
    Eigen::Map<Eigen::VectorXd>(k.flexural.data(), n) = x;
  }
}

KernelSpectrum kernel_spectrum(const CgKernel& k, int n) {
  KernelSpectrum s;
  double ip_min = 0.0, fl_min = 0.0;
  bool first = true;
  for (int iy = 0; iy < n; ++iy) {
    for (int ix = 0; ix < n; ++ix) {
      if (ix == 0 && iy == 0) continue;
      const Eigen::Vector2d q(2.0 * std::numbers::pi * ix / (n * k.ax_m),
                              2.0 * std::numbers::pi * iy / (n * k.ay_m));
      const Eigen::Matrix2cd kq = k.in_plane_q(q);
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2cd> es(kq, Eigen::EigenvaluesOnly);
      const double fq = k.flexural_q(q);
      if (first) {
        ip_min = es.eigenvalues()(0);
        fl_min = fq;
        first = false;
      }
      ip_min = std::min(ip_min, es.eigenvalues()(0));
      fl_min = std::min(fl_min, fq);
      s.in_plane_max_N_m = std::max(s.in_plane_max_N_m, es.eigenvalues()(1));
      s.flexural_max_N_m = std::max(s.flexural_max_N_m, fq);
    }
  }
  s.in_plane_min_rel = s.in_plane_max_N_m > 0.0 ? ip_min / s.in_plane_max_N_m : ip_min;
  s.flexural_min_rel = s.flexural_max_N_m > 0.0 ? fl_min / s.flexural_max_N_m : fl_min;
  return s;
}

}  // namespace cosim::solid
