// The recursive coarse-grained particle construction (DESIGN 4.3 items 2-5; the paper's
// section 2.1, Eqs. 4 and 6).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include <Eigen/Dense>

#include "solid/rcgp/rcgp_construction.hpp"

namespace {

using namespace cosim::solid;

constexpr double kEv = 1.602176634e-19;

const RcgpConstruction& paper_construction() {
  static const RcgpConstruction c = [] {
    RcgpOptions o;
    o.stages = rcgp_stages_for_spacing(0.2561e-6);  // the paper's dx_CG: 9 stages
    return build_rcgp(o);
  }();
  return c;
}

const RcgpConstruction& physical_construction() {
  static const RcgpConstruction c = [] {
    RcgpOptions o;
    o.stages = 9;
    o.flexural_scaling = FlexuralScaling::Physical;
    return build_rcgp(o);
  }();
  return c;
}

// The projected stiffness with the consistent mass m N^T N against the atomistic acoustic
// branches (TA, LA, ZA), at the wave vectors commensurate with the periodic 5 x 5 CG cell.
// The projection's frequencies are a harmonic mean over the aliased branches,
//   omega_CG^2(q) = sum_G w_G / sum_G (w_G / omega^2(q + G)),  w_G = |N^(q + G)|^2,
// so omega_CG >= omega (for the scalar ZA branch), close at long wavelength and rising towards the CG zone
// edge. Within 1 %: the wave vectors whose wavelength is at least the cell (|i|, |j| <= 1
// in units of 2 pi / L). At |i| or |j| = 2 (0.8 of the zone edge) the overshoot is larger
// (up to 13 %, printed): a property of the method, not a defect of this implementation.
TEST(Rcgp, Stage1MatchesAtomisticFrequencies) {
  const ForceConstantModel atoms;
  const RcgpConstruction& c = paper_construction();
  const RcgpStage& s1 = c.stages.front();
  const CgKernel& k = s1.projected;
  const int n = k.width();
  EXPECT_LT(s1.translation_invariance_defect, 1e-12);
  EXPECT_LT(c.stage1_mass_identity_defect, 1e-12) << "(phi m^-1 phi^T)^-1 = m N^T N";

  double worst_long = 0.0, worst_short = 0.0;
  int compared = 0;
  for (int j = -k.range; j <= k.range; ++j) {
    for (int i = -k.range; i <= k.range; ++i) {
      if (i == 0 && j == 0) continue;
      const Eigen::Vector2d q(2.0 * std::numbers::pi * i / (n * k.ax_m),
                              2.0 * std::numbers::pi * j / (n * k.ay_m));
      double mq = 0.0;  // consistent mass M(q), kg
      for (int ry = -k.range; ry <= k.range; ++ry)
        for (int rx = -k.range; rx <= k.range; ++rx)
          mq += c.stage1_consistent_mass_kg[k.index(rx, ry)] *
                std::cos(q.x() * rx * k.ax_m + q.y() * ry * k.ay_m);
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2cd> cg(k.in_plane_q(q) / mq,
                                                               Eigen::EigenvaluesOnly);
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4cd> at(
          ForceConstantModel::in_plane_block(atoms.dynamical_matrix(q)), Eigen::EigenvaluesOnly);
      std::array<double, 3> ratio{};
      for (int b = 0; b < 2; ++b)
        ratio[static_cast<std::size_t>(b)] = std::sqrt(cg.eigenvalues()(b) / at.eigenvalues()(b));
      ratio[2] = std::sqrt(k.flexural_q(q) / mq / atoms.flexural_omega_squared(q)[0]);
      const bool long_wave = std::abs(i) <= 1 && std::abs(j) <= 1;
      // For the scalar ZA branch the harmonic mean is above omega^2(q) (all aliased
      // branches lie higher); the in-plane 2 x 2 blocks mix TA and LA, so not for them.
      EXPECT_GT(ratio[2], 1.0 - 1e-9) << "omega_ZA,CG >= omega_ZA at i = " << i << ", j = " << j;
      for (const double r : ratio) {
        (long_wave ? worst_long : worst_short) =
            std::max(long_wave ? worst_long : worst_short, std::abs(r - 1.0));
      }
      ++compared;
    }
  }
  std::printf("stage 1 against atoms (TA, LA, ZA): worst %.3f %% at the 8 q with |i|, |j| <= 1; "
              "worst %.2f %% at the 16 with |i| or |j| = 2\n",
              100.0 * worst_long, 100.0 * worst_short);
  EXPECT_EQ(compared, n * n - 1);
  EXPECT_LT(worst_long, 0.01);
}

TEST(Rcgp, ElasticConstantsInvariantAcrossStages) {
  for (const RcgpConstruction* c : {&paper_construction(), &physical_construction()}) {
    const SheetConstants& s1 = c->stages.front().constants;
    EXPECT_NEAR(s1.c11_N_m / c->atomistic.c11_N_m, 1.0, 1e-9);
    for (const RcgpStage& s : c->stages) {
      std::printf("stage %d: C11 %.2f C22 %.2f C66 %.2f C12 %.2f N/m, E_2D %.1f N/m\n",
                  s.stage, s.constants.c11_N_m, s.constants.c22_N_m, s.constants.c66_N_m,
                  s.constants.c12_N_m, s.constants.youngs_x_N_m());
      EXPECT_NEAR(s.constants.c11_N_m / s1.c11_N_m, 1.0, 0.02) << "stage " << s.stage;
      EXPECT_NEAR(s.constants.c66_N_m / s1.c66_N_m, 1.0, 0.02) << "stage " << s.stage;
      EXPECT_NEAR(s.constants.youngs_x_N_m() / 340.0, 1.0, 0.10) << "stage " << s.stage;
      // The matched kernel is stable over the whole Brillouin zone and sums to zero.
      EXPECT_GE(s.spectrum.in_plane_min_rel, 0.0);
      EXPECT_GE(s.spectrum.flexural_min_rel, 0.0);
      const KernelMoments m = kernel_moments(s.kernel);
      EXPECT_LT(m.in_plane_sum.cwiseAbs().maxCoeff(), 1e-10 * s.spectrum.in_plane_max_N_m);
      EXPECT_LT(std::abs(m.flexural_sum), 1e-10 * s.spectrum.flexural_max_N_m);
    }
  }
}

TEST(Rcgp, StageScalingLaws) {
  const double lambda = 2.0;
  for (const RcgpConstruction* c : {&paper_construction(), &physical_construction()}) {
    const bool paper = c->options.flexural_scaling == FlexuralScaling::Paper;
    for (std::size_t s = 1; s < c->stages.size(); ++s) {
      const RcgpStage& a = c->stages[s - 1];
      const RcgpStage& b = c->stages[s];
      // M^(j+1) = lambda^d M^(j), d = 2; the lattice doubles.
      EXPECT_NEAR(b.lumped_mass_kg / a.lumped_mass_kg, lambda * lambda, 1e-12);
      EXPECT_NEAR(b.kernel.ax_m / a.kernel.ax_m, lambda, 1e-12);
      // In-plane stiffness unchanged (lambda^(d-2) = 1): same on-site block, same C.
      EXPECT_NEAR(b.kernel.ip(0, 0)(0, 0) / a.kernel.ip(0, 0)(0, 0), 1.0, 0.10);
      // Flexural: bending rigidity D fixed (physical, K ~ lambda^-2) or lambda^2 larger
      // per stage (paper, K ~ lambda^0).
      const double d_ratio = b.constants.d11_J / a.constants.d11_J;
      const double k_ratio = b.kernel.zz(0, 0) / a.kernel.zz(0, 0);
      if (paper) {
        EXPECT_NEAR(d_ratio, lambda * lambda, 1e-9);
        EXPECT_NEAR(k_ratio, 1.0, 0.25);
      } else {
        EXPECT_NEAR(d_ratio, 1.0, 1e-9);
        EXPECT_NEAR(k_ratio, 1.0 / (lambda * lambda), 0.25 / (lambda * lambda));
      }
    }
    // Nine stages: Lambda = 4 x 2^8 = 1024, about 0.25 um and 2^21 atoms per CGP.
    EXPECT_EQ(c->stages.size(), 9u);
    EXPECT_NEAR(c->coarse_graining_ratio(), 1024.0, 1e-9);
    EXPECT_NEAR(c->final_stage().atoms_per_cgp, 32.0 * std::pow(4.0, 8), 1e-6);
    const double kappa = c->atomistic_kappa_J;
    const double d_final = c->final_stage().constants.d11_J;
    EXPECT_NEAR(d_final / kappa, paper ? 1024.0 * 1024.0 : 1.0, paper ? 1e-3 : 1e-9);
    // The stable step grows by lambda per stage (the in-plane block bounds it):
    // dt_CG ~ Lambda dt_MD, to within the change of the kernel's shape over the first stages.
    for (std::size_t s = 1; s < c->stages.size(); ++s)
      EXPECT_NEAR(c->stages[s].stable_time_step_s / c->stages[s - 1].stable_time_step_s, lambda,
                  0.15) << "stage " << c->stages[s].stage;
  }
}

// Regression that documents why moment matching exists: the projection folds the long
// tail of the exact kernel onto the cell's range, which loses about 5 % of C11 at stage 1,
// and recursing on such a kernel leaves the flexural block with an unstable mode at once.
TEST(Rcgp, NaiveRecursionLosesStiffnessAndStability) {
  const RcgpStage& s1 = paper_construction().stages.front();
  const SheetConstants raw =
      constants_from_moments(kernel_moments(s1.projected), s1.projected.cell_area_m2());
  EXPECT_LT(raw.c11_N_m / paper_construction().atomistic.c11_N_m, 0.97);
  EXPECT_EQ(rcgp_stages_for_spacing(0.2561e-6), 9);
  EXPECT_EQ(rcgp_stages_for_spacing(1e-9), 1);
  EXPECT_THROW((void)rcgp_stages_for_spacing(1.0), std::invalid_argument);
  RcgpOptions naive;
  naive.moment_matching = false;
  naive.stages = 3;
  EXPECT_THROW((void)build_rcgp(naive), std::runtime_error);
}

TEST(Rcgp, OptionsOutOfRangeAreRefused) {
  RcgpOptions o;
  o.stages = 0;  // must be resolved from the spacing first
  EXPECT_THROW((void)build_rcgp(o), std::invalid_argument);
  o = RcgpOptions{};
  o.stages = 2;
  o.truncation_range = 1;
  EXPECT_THROW((void)build_rcgp(o), std::invalid_argument);
  // The cache key changes with every input that changes the result.
  const ForceConstantModel atoms;
  RcgpOptions a, b;
  a.stages = b.stages = 9;
  b.flexural_scaling = FlexuralScaling::Physical;
  EXPECT_NE(rcgp_input_hash(a, atoms), rcgp_input_hash(b, atoms));
  RcgpOptions c;
  c.stages = 9;
  EXPECT_EQ(rcgp_input_hash(a, atoms), rcgp_input_hash(c, ForceConstantModel{}));
  b = a;
  b.stages = 8;
  EXPECT_NE(rcgp_input_hash(a, atoms), rcgp_input_hash(b, atoms));
}

}  // namespace
