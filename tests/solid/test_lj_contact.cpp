// The inter-sheet Lennard-Jones contact (section 3.2 of the paper, DESIGN 4.3 item 8):
// force against energy, the cut-off, the sheet rule, and the neighbour list against an
// all-pairs evaluation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "protocol/units.hpp"
#include "solid/contact/lj_contact.hpp"

namespace {

using cosim::solid::hartree_from_eV;
using cosim::solid::LjContact;

/// All-pairs reference, written from the paper's formula independently of the model:
/// F_i = (4 eps / s) sum_j {12 (s/r)^13 - 6 (s/r)^7} r_ij / r for r < s, different sheets.
struct BruteForce {
  Eigen::Matrix3Xd force;
  Eigen::VectorXd magnitude;  ///< per CGP, sum of |pair force|: the scale of its rounding
  double energy = 0.0;
  double energy_magnitude = 0.0;
  std::size_t pairs = 0;
};

BruteForce brute_force(const Eigen::Matrix3Xd& x, const std::vector<int>& sheet, double eps,
                       double s) {
  const Eigen::Index n = x.cols();
  BruteForce out;
  out.force = Eigen::Matrix3Xd::Zero(3, n);
  out.magnitude = Eigen::VectorXd::Zero(n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = i + 1; j < n; ++j) {
      if (sheet[static_cast<std::size_t>(i)] == sheet[static_cast<std::size_t>(j)]) continue;
      const Eigen::Vector3d rij = x.col(i) - x.col(j);
      const double r = rij.norm();
      if (r >= s) continue;
      const double sr = s / r;
      const double fmag = 4.0 * eps / s * (12.0 * std::pow(sr, 13) - 6.0 * std::pow(sr, 7));
      const Eigen::Vector3d fij = fmag * rij / r;
      out.force.col(i) += fij;
      out.force.col(j) -= fij;
      out.magnitude[i] += std::abs(fmag);
      out.magnitude[j] += std::abs(fmag);
      const double e = 4.0 * eps * (std::pow(sr, 12) - std::pow(sr, 6));
      out.energy += e;
      out.energy_magnitude += std::abs(e);
      ++out.pairs;
    }
  return out;
}

/// Two n x n sheets facing each other across x: sheet 0 in the plane x = 0, sheet 1 at
/// x = gap, both with in-plane spacing s, every coordinate jittered by up to +-jitter.
Eigen::Matrix3Xd facing_sheets(int n, double s, double gap, double jitter, std::mt19937_64& rng,
                               std::vector<int>& sheet) {
  std::uniform_real_distribution<double> u(-jitter, jitter);
  Eigen::Matrix3Xd x(3, 2 * n * n);
  sheet.assign(static_cast<std::size_t>(2 * n * n), 0);
  Eigen::Index l = 0;
  for (int k = 0; k < 2; ++k)
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b, ++l) {
        x.col(l) = Eigen::Vector3d(k * gap, a * s, b * s) + Eigen::Vector3d(u(rng), u(rng), u(rng));
        sheet[static_cast<std::size_t>(l)] = k;
      }
  return x;
}

/// A jittered cubic lattice (spacing 0.9 s, so neighbours overlap) of CGPs with random
/// labels from `num_sheets` sheets.
Eigen::Matrix3Xd lattice_cloud(int nx, int ny, int nz, double s, int num_sheets,
                               std::mt19937_64& rng, std::vector<int>& sheet) {
  std::uniform_real_distribution<double> u(-0.05 * s, 0.05 * s);
  std::uniform_int_distribution<int> label(0, num_sheets - 1);
  Eigen::Matrix3Xd x(3, nx * ny * nz);
  sheet.clear();
  Eigen::Index l = 0;
  for (int c = 0; c < nz; ++c)
    for (int b = 0; b < ny; ++b)
      for (int a = 0; a < nx; ++a, ++l) {
        x.col(l) = 0.9 * s * Eigen::Vector3d(a, b, c) + Eigen::Vector3d(u(rng), u(rng), u(rng));
        sheet.push_back(label(rng));
      }
  return x;
}

TEST(LjContact, ForceIsMinusEnergyGradient) {
  const double s = 2.0;
  const double eps = hartree_from_eV(1000.0);
  std::mt19937_64 rng(20240611);
  int accepted = 0;
  for (int attempt = 0; attempt < 200 && accepted < 6; ++attempt) {
    std::vector<int> sheet;
    const Eigen::Matrix3Xd x = facing_sheets(3, s, 0.8 * s, 0.12 * s, rng, sheet);
    // Keep configurations with several pairs in range and none near the cut, where the
    // force jumps and a difference quotient would straddle it.
    std::size_t in_range = 0;
    bool near_cut = false;
    for (Eigen::Index i = 0; i < 9; ++i)
      for (Eigen::Index j = 9; j < 18; ++j) {
        const double r = (x.col(i) - x.col(j)).norm();
        in_range += r < s ? 1 : 0;
        near_cut = near_cut || std::abs(r - s) < 0.03 * s;
      }
    if (near_cut || in_range < 3) continue;
    ++accepted;

    LjContact contact(sheet, eps, s, 0.5 * s);
    Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, x.cols());
    const double e = contact.add_forces(x, f);
    EXPECT_EQ(contact.pairs_in_cutoff(), in_range);
    EXPECT_GT(e, 0.0);
    EXPECT_NEAR(contact.energy(x), e, 1e-14 * e);
    const BruteForce ref = brute_force(x, sheet, eps, s);
    EXPECT_NEAR(e, ref.energy, 1e-12 * ref.energy_magnitude);

    const double h = 1e-6 * s;
    double f_scale = 0.0;
    for (Eigen::Index l = 0; l < f.cols(); ++l) f_scale = std::max(f_scale, f.col(l).norm());
    for (Eigen::Index l = 0; l < x.cols(); ++l)
      for (int d = 0; d < 3; ++d) {
        Eigen::Matrix3Xd xp = x, xm = x;
        xp(d, l) += h;
        xm(d, l) -= h;
        const double fd = -(contact.energy(xp) - contact.energy(xm)) / (2.0 * h);
        EXPECT_NEAR(f(d, l), fd, 1e-7 * f_scale) << "CGP " << l << ", axis " << d;
      }
  }
  EXPECT_EQ(accepted, 6);
}

TEST(LjContact, SameSheetPairsDoNotInteract) {
  const double s = 1.0;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 0.5 * s);

  // One sheet crumpled into a ball far smaller than the cut-off: no contact at all.
  {
    Eigen::Matrix3Xd x(3, 12);
    for (Eigen::Index l = 0; l < x.cols(); ++l) x.col(l) = Eigen::Vector3d(u(rng), u(rng), u(rng));
    LjContact contact(std::vector<int>(12, 7), 1.0, s, 0.2 * s);
    Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, 12);
    EXPECT_EQ(contact.add_forces(x, f), 0.0);
    EXPECT_TRUE(f.isZero(0.0));
    EXPECT_EQ(contact.energy(x), 0.0);
    EXPECT_EQ(contact.pairs_in_cutoff(), 0U);
    EXPECT_EQ(contact.listed_pairs(), 0U);
    EXPECT_EQ(contact.min_distance_bohr(), std::numeric_limits<double>::infinity());
  }

  // Interleaved labels: even CGPs (sheet 0) in a ball at the origin, odd ones (sheet 1) in
  // a ball 10 s away. Only the sheets' labels decide, not index ranges.
  const Eigen::Index n = 20;
  Eigen::Matrix3Xd x(3, n);
  std::vector<int> sheet(static_cast<std::size_t>(n));
  for (Eigen::Index l = 0; l < n; ++l) {
    const int k = static_cast<int>(l % 2);
    sheet[static_cast<std::size_t>(l)] = k;
    x.col(l) = Eigen::Vector3d(10.0 * s * k + u(rng), u(rng), u(rng));
  }
  LjContact contact(sheet, 1.0, s, 0.2 * s);
  Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, n);
  EXPECT_EQ(contact.add_forces(x, f), 0.0);
  EXPECT_TRUE(f.isZero(0.0));
  EXPECT_EQ(contact.pairs_in_cutoff(), 0U);

  // Carry one CGP of sheet 1 into sheet 0's ball: it and sheet 0's CGPs feel the contact,
  // the rest of sheet 1 (all within 0.5 s of each other) still feels nothing.
  x.col(1) = Eigen::Vector3d(0.25 * s, 0.25 * s, 1.0 * s);
  f.setZero();
  const double e = contact.add_forces(x, f);
  const BruteForce ref = brute_force(x, sheet, 1.0, s);
  EXPECT_GT(e, 0.0);
  EXPECT_EQ(contact.pairs_in_cutoff(), ref.pairs);
  for (Eigen::Index l = 3; l < n; l += 2) EXPECT_TRUE(f.col(l).isZero(0.0)) << "CGP " << l;
  EXPECT_GT(f.col(1).norm(), 0.0);
}

TEST(LjContact, NoForceBeyondCutoff) {
  const double s = 3.0;
  const double eps = 0.5;
  const double skin = 1.0;
  const Eigen::Vector3d dir = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
  auto pair_at = [&](double r) {
    Eigen::Matrix3Xd x(3, 2);
    x.col(0) = Eigen::Vector3d(4.0, 1.0, -2.0);
    x.col(1) = x.col(0) - r * dir;  // r_01 = x_0 - x_1 = r dir
    return x;
  };
  for (const double r : {s * (1.0 + 1e-12), 1.2 * s, s + 0.9 * skin, s + 2.0 * skin,
                         5.0 * s, 1e6 * s}) {
    LjContact contact({0, 1}, eps, s, skin);
    const Eigen::Matrix3Xd x = pair_at(r);
    Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, 2);
    EXPECT_EQ(contact.add_forces(x, f), 0.0) << "r / s = " << r / s;
    EXPECT_TRUE(f.isZero(0.0)) << "r / s = " << r / s;
    EXPECT_EQ(contact.energy(x), 0.0);
    EXPECT_EQ(contact.pairs_in_cutoff(), 0U);
    // Pairs in the skin are listed and watched, but exert nothing.
    EXPECT_EQ(contact.listed_pairs(), r < s + skin ? 1U : 0U) << "r / s = " << r / s;
  }

  // Exactly at the cut (r = s holds without rounding along an axis): no force.
  {
    LjContact contact({0, 1}, eps, s, skin);
    Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, 2);
    x(1, 1) = s;
    Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, 2);
    EXPECT_EQ(contact.add_forces(x, f), 0.0);
    EXPECT_TRUE(f.isZero(0.0));
    EXPECT_EQ(contact.pairs_in_cutoff(), 0U);
  }

  // Just inside: the energy is continuous (about 0) but the force jumps to 24 eps / s,
  // repulsive (on CGP 0 along r_01).
  const double r = s * (1.0 - 1e-10);
  LjContact contact({0, 1}, eps, s, skin);
  const Eigen::Matrix3Xd x = pair_at(r);
  Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, 2);
  const double e = contact.add_forces(x, f);
  EXPECT_EQ(contact.pairs_in_cutoff(), 1U);
  EXPECT_GE(e, 0.0);
  EXPECT_LT(e, 1e-8 * eps);
  EXPECT_NEAR(f.col(0).dot(dir), 24.0 * eps / s, 1e-8 * 24.0 * eps / s);
  EXPECT_NEAR((f.col(0) - f.col(0).dot(dir) * dir).norm(), 0.0, 1e-12);
  EXPECT_NEAR(contact.min_distance_bohr(), r, 1e-12 * s);
}

TEST(LjContact, NeighbourListMatchesBruteForce) {
  const double s = 1.5;
  const double eps = 2.0;
  const int calls = 300;
  for (const double skin : {0.3 * s, 0.0}) {
    std::mt19937_64 rng(12345);
    std::vector<int> sheet;
    Eigen::Matrix3Xd x = lattice_cloud(8, 8, 7, s, 4, rng, sheet);  // 448 CGPs
    LjContact contact(sheet, eps, s, skin);
    std::uniform_real_distribution<double> step(-0.02 * s, 0.02 * s);
    std::size_t total_pairs = 0;
    for (int call = 0; call < calls; ++call) {
      for (Eigen::Index l = 0; l < x.cols(); ++l)
        x.col(l) += Eigen::Vector3d(step(rng), step(rng), step(rng));
      const BruteForce ref = brute_force(x, sheet, eps, s);
      // energy() before add_forces() meets a stale list now and then: it must search anew.
      const double e_before = contact.energy(x);
      Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, x.cols());
      const double e = contact.add_forces(x, f);
      ASSERT_EQ(contact.pairs_in_cutoff(), ref.pairs) << "call " << call;
      ASSERT_NEAR(e, ref.energy, 1e-13 * ref.energy_magnitude) << "call " << call;
      ASSERT_EQ(e_before, e) << "call " << call;
      for (Eigen::Index l = 0; l < x.cols(); ++l)
        ASSERT_LE((f.col(l) - ref.force.col(l)).norm(), 1e-13 * ref.magnitude[l])
            << "call " << call << ", CGP " << l;
      total_pairs += ref.pairs;
    }
    EXPECT_GT(total_pairs, static_cast<std::size_t>(100 * calls)) << "the walk must collide";
    if (skin > 0.0) {
      EXPECT_GE(contact.num_rebuilds(), 2U) << "the walk must outgrow the skin";
      EXPECT_LT(contact.num_rebuilds(), static_cast<std::size_t>(calls / 5));
    } else {
      EXPECT_EQ(contact.num_rebuilds(), static_cast<std::size_t>(calls));
    }
  }
}

TEST(LjContact, NewtonsThirdLaw) {
  const double s = 1.0;
  std::mt19937_64 rng(99);
  std::vector<int> sheet;
  const Eigen::Matrix3Xd x = lattice_cloud(6, 6, 6, s, 3, rng, sheet);
  LjContact contact(sheet, hartree_from_eV(1000.0), s, 0.25 * s);
  // add_forces() adds: start from forces already there.
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3Xd f(3, x.cols());
  for (Eigen::Index l = 0; l < x.cols(); ++l) f.col(l) = Eigen::Vector3d(u(rng), u(rng), u(rng));
  const Eigen::Matrix3Xd f_before = f;
  (void)contact.add_forces(x, f);
  const Eigen::Matrix3Xd df = f - f_before;
  ASSERT_GT(contact.pairs_in_cutoff(), 50U);

  double force_scale = 0.0;
  double torque_scale = 0.0;
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
  for (Eigen::Index l = 0; l < x.cols(); ++l) {
    force_scale += df.col(l).norm();
    torque_scale += x.col(l).norm() * df.col(l).norm();
    torque += x.col(l).cross(df.col(l));
  }
  EXPECT_LE(df.rowwise().sum().norm(), 1e-13 * force_scale);
  // Central pair forces: the contact exerts no torque either.
  EXPECT_LE(torque.norm(), 1e-13 * torque_scale);
  const BruteForce ref = brute_force(x, sheet, contact.epsilon_hartree(), s);
  for (Eigen::Index l = 0; l < x.cols(); ++l)
    EXPECT_LE((df.col(l) - ref.force.col(l)).norm(), 1e-12 * ref.magnitude[l] + 1e-12);
}

TEST(LjContact, RejectsInvalidInputs) {
  EXPECT_DOUBLE_EQ(hartree_from_eV(cosim::protocol::PhysicalConstants::hartree_eV), 1.0);
  EXPECT_NEAR(hartree_from_eV(1000.0), 36.749322, 1e-6);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto expect_one_line_error = [](auto&& build, const char* what) {
    try {
      build();
      ADD_FAILURE() << what << " must throw";
    } catch (const std::invalid_argument& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("lj_contact.cpp:"), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
  };
  expect_one_line_error([] { LjContact({}, 1.0, 1.0, 0.1); }, "no CGPs");
  for (const double eps : {0.0, -1.0, nan, inf})
    expect_one_line_error([&] { LjContact({0, 1}, eps, 1.0, 0.1); }, "bad eps");
  for (const double sigma : {0.0, -1.0, nan, inf})
    expect_one_line_error([&] { LjContact({0, 1}, 1.0, sigma, 0.1); }, "bad sigma");
  for (const double skin : {-0.1, nan, inf})
    expect_one_line_error([&] { LjContact({0, 1}, 1.0, 1.0, skin); }, "bad skin");

  LjContact contact({0, 1}, 1.0, 1.0, 0.1);
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, 3);
  Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, 2);
  expect_one_line_error([&] { (void)contact.add_forces(x, f); }, "wrong position shape");
  expect_one_line_error([&] { (void)contact.energy(x); }, "wrong position shape");
  x = Eigen::Matrix3Xd::Zero(3, 2);
  x(0, 1) = nan;
  expect_one_line_error([&] { (void)contact.add_forces(x, f); }, "non-finite position");
}

}  // namespace
