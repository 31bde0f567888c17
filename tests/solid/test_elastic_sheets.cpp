// The elastic sheet models "rcgp" (linear) and "corotational" (DESIGN 2.5, 4.3 items 6-8):
// invariances, the finite sheet against plate and beam theory, time integration, contact.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "protocol/units.hpp"
#include "solid/models/elastic_sheet/elastic_sheet_model.hpp"
#include "solid/model/model_registry.hpp"
#include "solid/models/elastic_sheet/sheet_forces.hpp"
#include "tests/support/corotational_reference.hpp"

namespace {

using namespace cosim::solid;
using cosim::protocol::PhysicalConstants;

SolidConfig one_sheet(int nx, int ny, double theta_deg) {
  SolidConfig c;
  SheetSpec s;
  s.nx_cg = nx;
  s.ny_cg = ny;
  s.theta_deg = theta_deg;
  s.base_bohr = {1000.0, 0.0, -500.0};
  c.sheets = {s};
  return c;
}

const std::vector<SheetKinematics> kAll{SheetKinematics::Linear, SheetKinematics::Corotational};

const char* label(SheetKinematics k) {
  return k == SheetKinematics::Linear ? "rcgp" : "corotational";
}

/// Largest force of a typical deformation, to make round-off bounds relative.
double force_scale(ElasticSheetModel& m, double amplitude) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, amplitude);
  Eigen::Matrix3Xd x = m.positions();
  for (Eigen::Index l = 0; l < x.cols(); ++l) x.col(l) += Eigen::Vector3d(n(rng), n(rng), n(rng));
  Eigen::Matrix3Xd f(3, x.cols());
  m.internal_forces(x, f);
  return f.cwiseAbs().maxCoeff();
}

TEST(ElasticSheets, ForceIsMinusEnergyGradient) {
  for (const SheetKinematics kin : kAll) {
    SolidConfig config = one_sheet(5, 8, 37.0);
    config.sheets[0].height_spacing_bohr *= 0.85;  // a rectangular lattice, as RCGP's
    ElasticSheetModel m(config, kin);
    const double h = m.sheets()[0].reference_bohr.col(1).x() - m.sheets()[0].reference_bohr.col(0).x();
    const double spacing = std::abs(h) / std::cos(37.0 * std::numbers::pi / 180.0);
    std::mt19937 rng(11);
    std::normal_distribution<double> n(0.0, 0.03 * spacing);
    Eigen::Matrix3Xd x = m.positions();
    // A finite rotation first (the corotational model's domain), then a random strain.
    const Eigen::Matrix3d q =
        kin == SheetKinematics::Corotational
            ? Eigen::AngleAxisd(0.6, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix()
            : Eigen::Matrix3d::Identity();
    for (Eigen::Index l = 0; l < x.cols(); ++l)
      x.col(l) = q * x.col(l) + Eigen::Vector3d(n(rng), n(rng), n(rng));
    Eigen::Matrix3Xd f(3, x.cols());
    m.internal_forces(x, f);
    const double step = 1e-4 * spacing;
    double worst = 0.0;
    for (Eigen::Index l = 0; l < x.cols(); ++l)
      for (int c = 0; c < 3; ++c) {
        Eigen::Matrix3Xd xp = x, xm = x;
        xp(c, l) += step;
        xm(c, l) -= step;
        const double fd = -(m.potential_energy(xp) - m.potential_energy(xm)) / (2.0 * step);
        worst = std::max(worst, std::abs(fd - f(c, l)));
      }
    EXPECT_LT(worst, 1e-6 * f.cwiseAbs().maxCoeff()) << label(kin);
  }
}

TEST(ElasticSheets, RigidTranslationGivesZeroForce) {
  for (const SheetKinematics kin : kAll) {
    ElasticSheetModel m(one_sheet(5, 12, 60.0), kin);
    const double scale = force_scale(m, 10.0);
    Eigen::Matrix3Xd x = m.positions();
    x.colwise() += Eigen::Vector3d(123.4, -56.7, 890.1);
    Eigen::Matrix3Xd f(3, x.cols());
    const double e = m.internal_forces(x, f);
    EXPECT_LT(f.cwiseAbs().maxCoeff(), 1e-12 * scale * 1e3) << label(kin);
    // Relative to the energy scale of the translation's length in the stiffest springs.
    const double e_scale = 0.5 * Eigen::MatrixXd(m.sheets()[0].stiffness).cwiseAbs().maxCoeff() *
                           Eigen::Vector3d(123.4, -56.7, 890.1).squaredNorm();
    EXPECT_LT(std::abs(e), 1e-12 * e_scale) << label(kin);
  }
}

// The sheet's own energy is invariant under any rigid motion. (A clamped row is tied to the
// plate, which does not turn with the sheet: rotating a clamped sheet against its plate is
// a deformation, so this checks a free sheet.)
TEST(ElasticSheets, RigidRotationGivesZeroForce) {
  SolidConfig free_sheet = one_sheet(5, 12, 30.0);
  free_sheet.sheets[0].clamped_rows = 0;
  ElasticSheetModel m(free_sheet, SheetKinematics::Corotational);
  const double scale = force_scale(m, 10.0);
  for (const double angle : {0.3, 1.2, 2.5}) {
    const Eigen::Matrix3d q =
        Eigen::AngleAxisd(angle, Eigen::Vector3d(-1, 3, 2).normalized()).toRotationMatrix();
    Eigen::Matrix3Xd x = q * m.positions();
    x.colwise() += Eigen::Vector3d(-2e4, 3e3, 1e4);
    Eigen::Matrix3Xd f(3, x.cols());
    m.internal_forces(x, f);
    EXPECT_LT(f.cwiseAbs().maxCoeff(), 1e-9 * scale) << "angle " << angle;
  }
  // The linear model is invariant only under infinitesimal rotation: a finite one strains it.
  ElasticSheetModel lin(free_sheet, SheetKinematics::Linear);
  const Eigen::Matrix3d q = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Matrix3Xd f(3, lin.num_cgps());
  lin.internal_forces(q * lin.positions(), f);
  EXPECT_GT(f.cwiseAbs().maxCoeff(), 1e-3 * scale);
}

// The batched corotational force (terms grouped by shape and K, evaluated a batch of terms
// at a time) against the per-term evaluation it replaced (support/corotational_reference.hpp)
// on sheets under a large rotation, a stretch and a random strain: the same forces and
// energy up to round-off (the sums run in another order), with the kernels compiled for a
// rectangular sheet's terms and with the general one (also on couplings those do not cover).
TEST(CorotationalForce, MatchesPerTermReference) {
  std::vector<SolidConfig> configs;
  configs.push_back(one_sheet(5, 40, 90.0));  // the paper's sheet, clamped
  SolidConfig free_rect = one_sheet(5, 8, 37.0);
  free_rect.sheets[0].clamped_rows = 0;
  free_rect.sheets[0].height_spacing_bohr *= 0.85;
  configs.push_back(free_rect);
  SolidConfig narrow = one_sheet(3, 7, -20.0);
  narrow.sheets[0].clamped_rows = 2;
  configs.push_back(narrow);
  SolidConfig pair = one_sheet(5, 10, 0.0);
  SheetSpec second = pair.sheets[0];
  second.base_bohr = {0.0, 0.0, 4.0 * second.width_spacing_bohr};
  second.nx_cg = 4;
  pair.sheets.push_back(second);
  configs.push_back(pair);
  std::mt19937 rng(23);
  for (std::size_t ci = 0; ci < 2 * configs.size(); ++ci) {
    // The second time round: every group through the general kernel, and the terms of the
    // first sheet changed to couplings and shapes the compiled kernels do not cover.
    const bool general = ci >= configs.size();
    ElasticSheetModel m(configs[ci % configs.size()], SheetKinematics::Corotational);
    std::vector<SheetBlock> sheets = m.sheets();
    if (general) {
      std::uniform_real_distribution<double> coupling(-0.2, 0.2);
      for (std::size_t t = 0; t < sheets[0].terms.size(); t += 3) {
        StiffnessTerm& term = sheets[0].terms[t];
        if (term.frame.size() == 4 && t % 2 == 0) {  // a cell, in-plane only
          for (Eigen::Index i = 2; i < term.k.rows(); i += 3) {
            term.k.row(i).setZero();
            term.k.col(i).setZero();
          }
        } else {  // any term: plus a rank-one w w^T coupling every component to every other
          Eigen::VectorXd w(term.k.rows());
          for (Eigen::Index i = 0; i < w.size(); ++i) w[i] = coupling(rng);
          term.k += term.k.cwiseAbs().maxCoeff() * w * w.transpose();
        }
      }
    }
    const CorotationalSheetForce batched(
        sheets, general ? CorotationalSheetForce::Kernels::General : CorotationalSheetForce::Kernels::Compiled);
    const reference::CorotationalPerTerm per_term(sheets);
    const double h = configs[ci % configs.size()].sheets[0].width_spacing_bohr;
    std::normal_distribution<double> n(0.0, 0.05 * h);
    for (const double angle : {0.0, 0.4, 1.3, 2.9}) {
      const Eigen::Matrix3d q =
          Eigen::AngleAxisd(angle, Eigen::Vector3d(2, -1, 3).normalized()).toRotationMatrix();
      const Eigen::Matrix3d stretch = Eigen::Vector3d(1.15, 0.9, 1.05).asDiagonal();
      Eigen::Matrix3Xd x = m.positions();
      const Eigen::Vector3d c = x.rowwise().mean();
      for (Eigen::Index l = 0; l < x.cols(); ++l)
        x.col(l) = q * stretch * (x.col(l) - c) + c + Eigen::Vector3d(3e3, -1e3, 7e2) +
                   Eigen::Vector3d(n(rng), n(rng), n(rng));
      Eigen::Matrix3Xd f_new(3, x.cols()), f_ref(3, x.cols());
      const double e_new = batched.evaluate(x, f_new);
      const double e_ref = per_term.evaluate(x, f_ref);
      const double scale = f_ref.cwiseAbs().maxCoeff();
      const double diff = (f_new - f_ref).cwiseAbs().maxCoeff();
      std::printf("config %zu, angle %.1f: |f| max %.3e, |df| max %.3e (%.1e relative), "
                  "E %.6e, dE %.1e relative; %zu groups\n",
                  ci, angle, scale, diff, diff / scale, e_ref, std::abs(e_new - e_ref) / e_ref,
                  batched.num_groups());
      EXPECT_LT(diff, 1e-12 * scale) << "config " << ci << ", angle " << angle;
      EXPECT_LT(std::abs(e_new - e_ref), 1e-12 * e_ref) << "config " << ci << ", angle " << angle;
    }
  }
}

/// The out-of-plane (w) stiffness of a linear sheet on its free CGPs, and those CGPs.
struct FlexuralProblem {
  Eigen::MatrixXd k;                  ///< E_h / bohr^2
  std::vector<Eigen::Index> free;     ///< local CGP indices
};

FlexuralProblem flexural_problem(const ElasticSheetModel& m, const SheetSpec& spec) {
  const Eigen::MatrixXd k = Eigen::MatrixXd(m.sheets()[0].stiffness);
  FlexuralProblem p;
  for (Eigen::Index l = 0; l < spec.num_cgps(); ++l)
    if (!spec.is_clamped(l)) p.free.push_back(l);
  const auto n = static_cast<Eigen::Index>(p.free.size());
  p.k.resize(n, n);
  for (Eigen::Index a = 0; a < n; ++a)
    for (Eigen::Index b = 0; b < n; ++b)
      p.k(a, b) = k(3 * p.free[static_cast<std::size_t>(a)] + 2, 3 * p.free[static_cast<std::size_t>(b)] + 2);
  return p;
}

/// Free length of the cantilever: from the clamped row (the plate) to the edge of the top
/// row's cell, (ny - clamped_rows + 1/2) h, the span over which the CGP masses sit.
double free_length(const SheetSpec& s) {
  return (s.ny_cg - s.clamped_rows + 0.5) * s.height_spacing_bohr;
}

/// The paper's sheet on the square dx_CG of Table 1, and on the RCGP lattice's own
/// rectangular spacing (0.2519 x 0.2181 um: W 1.26 um, H 8.72 um for 5 x 40 CGPs).
std::vector<SolidConfig> paper_sheets() {
  SolidConfig square = one_sheet(5, 40, 90.0);
  SolidConfig rect = square;
  rect.sheets[0].width_spacing_bohr = 0.2519e-6 / PhysicalConstants::bohr_m;
  rect.sheets[0].height_spacing_bohr = 0.2181e-6 / PhysicalConstants::bohr_m;
  return {square, rect};
}

// Beam limit of a clamped-free strip: f_n = (beta_n L)^2 / (2 pi L^2) sqrt(D / rho_2D);
// with bending_poisson = 0 the narrow- and wide-strip rigidities coincide (D (1 - nu^2) = D).
/// The flexural modes of a sheet (the normal DOFs of its free CGPs), split by their symmetry
/// across the width into bending (symmetric) and torsion (antisymmetric) frequencies, Hz,
/// ascending, up to n_bending bending ones; and the beam frequency of a root beta L of the
/// beam's characteristic equation, (beta L)^2 / (2 pi L^2) sqrt(D / rho_2D).
struct FlexuralModes {
  std::vector<double> bending, torsion;
  double rho = 0.0, len = 0.0, beam_scale_hz = 0.0;
  double beam_hz(double beta_l) const { return beta_l * beta_l * beam_scale_hz; }
};

FlexuralModes flexural_modes(const ElasticSheetModel& m, const SheetSpec& spec, std::size_t n_bending) {
  const FlexuralProblem p = flexural_problem(m, spec);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(p.k / spec.cgp_mass_me);
  FlexuralModes r;
  r.rho = spec.cgp_mass_me / spec.cell_area_bohr2();
  r.len = free_length(spec);
  r.beam_scale_hz = std::sqrt(m.plate_constants().d22 / r.rho) / (2.0 * std::numbers::pi * r.len * r.len) /
                    PhysicalConstants::time_au_s;
  const double to_hz = 1.0 / (2.0 * std::numbers::pi * PhysicalConstants::time_au_s);
  for (Eigen::Index k = 0; k < es.eigenvalues().size() && r.bending.size() < n_bending; ++k) {
    const Eigen::VectorXd v = es.eigenvectors().col(k);
    double sym = 0.0, anti = 0.0;  // across the width: w(i) against w(nx - 1 - i)
    for (std::size_t a = 0; a < p.free.size(); ++a) {
      const int i = static_cast<int>(p.free[a] % spec.nx_cg);
      const double mirror = v[static_cast<Eigen::Index>(a) + (spec.nx_cg - 1 - 2 * i)];
      sym += (v[static_cast<Eigen::Index>(a)] + mirror) * (v[static_cast<Eigen::Index>(a)] + mirror);
      anti += (v[static_cast<Eigen::Index>(a)] - mirror) * (v[static_cast<Eigen::Index>(a)] - mirror);
    }
    const double f = std::sqrt(std::max(es.eigenvalues()[k], 0.0)) * to_hz;
    (sym > anti ? r.bending : r.torsion).push_back(f);
  }
  return r;
}

TEST(ElasticSheets, CantileverEigenfrequencies) {
  for (const SolidConfig& config : paper_sheets()) {
    ElasticSheetModel m(config, SheetKinematics::Linear);
    const SheetSpec& spec = config.sheets[0];
    const FlexuralModes modes = flexural_modes(m, spec, 3);
    const std::vector<double>& bending = modes.bending;
    const std::vector<double>& torsion = modes.torsion;
    const double rho = modes.rho, len = modes.len;
    const std::vector<double> beta_l{1.875104, 4.694091, 7.854757};
    ASSERT_EQ(bending.size(), 3u);
    for (std::size_t n = 0; n < 3; ++n) {
      const double theory = modes.beam_hz(beta_l[n]);
      std::printf("bending mode %zu: %.6g Hz, beam theory %.6g Hz (%+.3f %%)\n", n + 1, bending[n],
                  theory, 100.0 * (bending[n] / theory - 1.0));
      EXPECT_NEAR(bending[n] / theory, 1.0, 0.02) << "mode " << n + 1;
    }
    // The model's report starts with the same fundamental (from the full 3N problem, whose
    // in-plane eigenvalues are 1e4 times larger: round-off of the solver, 1e-16 of those).
    EXPECT_NEAR(m.vacuum_eigenfrequencies_hz().front() / bending[0], 1.0, 1e-6);
    if (!torsion.empty()) {
      // Saint-Venant torsion of a plate strip: GJ = 4 D66 W, I_p = rho W^3 / 12.
      const double w = spec.nx_cg * spec.width_spacing_bohr;
      const double theory = 1.0 / (4.0 * len) *
                            std::sqrt(4.0 * m.plate_constants().d66 * w * 12.0 / (rho * w * w * w)) /
                            PhysicalConstants::time_au_s;
      std::printf("first torsion mode: %.6g Hz, Saint-Venant strip %.6g Hz (%+.1f %%: %d CGPs "
                  "across the width)\n",
                  torsion[0], theory, 100.0 * (torsion[0] / theory - 1.0), spec.nx_cg);
    }
  }
}

TEST(ElasticSheets, StaticTipDeflection) {
  for (const SolidConfig& config : paper_sheets()) {
    ElasticSheetModel m(config, SheetKinematics::Linear);
    const SheetSpec& spec = config.sheets[0];
    const FlexuralProblem p = flexural_problem(m, spec);
    const double pressure = 1e-9;  // E_h / bohr^3: small, the model is linear anyway
    const Eigen::VectorXd load =
        Eigen::VectorXd::Constant(static_cast<Eigen::Index>(p.free.size()),
                                  pressure * spec.cell_area_bohr2());
    const Eigen::VectorXd w = p.k.ldlt().solve(load);
    const auto tip = std::find(p.free.begin(), p.free.end(), spec.marked_cgp()) - p.free.begin();
    const double len = free_length(spec);
    const double theory = pressure * std::pow(len, 4) / (8.0 * m.plate_constants().d22);
    std::printf("tip deflection %.6g bohr, p L^4 / (8 D) = %.6g bohr (%+.3f %%)\n", w[tip], theory,
                100.0 * (w[tip] / theory - 1.0));
    EXPECT_NEAR(w[tip] / theory, 1.0, 0.02);
    // Most of that difference is where the tip is measured: the top CGP sits half a spacing
    // below the free edge. Beam theory's deflection at the CGP itself,
    // w(y) = p y^2 (6 L^2 - 4 L y + y^2) / (24 D):
    const double y = len - 0.5 * spec.height_spacing_bohr;
    const double at_cgp = pressure * y * y * (6 * len * len - 4 * len * y + y * y) /
                          (24.0 * m.plate_constants().d22);
    std::printf("beam theory at the top CGP %.6g bohr (%+.3f %%)\n", at_cgp,
                100.0 * (w[tip] / at_cgp - 1.0));
    EXPECT_NEAR(w[tip] / at_cgp, 1.0, 0.002);
  }
}

// [[sheet]] leading_edge = "pinned": the held row is a hinge. A rigid rotation of the sheet
// about it costs no energy (the linear model, small angle), where the clamped sheet resists
// it; the flexural modes are a beam's hinged at one end and free at the other: a zero mode
// (the rotation) and then (beta_n L)^2 / (2 pi L^2) sqrt(D / rho_2D) with tan(beta L) =
// tanh(beta L), beta_n L = 3.926602, 7.068583.
TEST(ElasticSheets, PinnedLeadingEdgeIsAHinge) {
  for (SolidConfig config : paper_sheets()) {
    SheetSpec& spec = config.sheets[0];
    const auto rotated = [&](const ElasticSheetModel& m) {
      const Eigen::Vector3d n = sheet_normal(spec);
      Eigen::Matrix3Xd x = m.positions();
      for (Eigen::Index l = 0; l < x.cols(); ++l)
        x.col(l) += 1e-3 * double(l / spec.nx_cg) * spec.height_spacing_bohr * n;
      return x;
    };
    ElasticSheetModel clamped(config, SheetKinematics::Linear);
    Eigen::Matrix3Xd f(3, clamped.num_cgps());
    const double e_clamped = clamped.internal_forces(rotated(clamped), f);
    spec.pinned = true;
    ElasticSheetModel pinned(config, SheetKinematics::Linear);
    const double e_pinned = pinned.internal_forces(rotated(pinned), f);
    double free_force = 0.0;
    for (Eigen::Index l = spec.nx_cg; l < f.cols(); ++l) free_force = std::max(free_force, f.col(l).norm());
    EXPECT_GT(e_clamped, 0.0);
    EXPECT_LT(std::abs(e_pinned), 1e-10 * e_clamped);  // round-off of the stiff in-plane terms
    EXPECT_LT(free_force, 1e-9 * force_scale(pinned, 1e-3 * spec.height_spacing_bohr));

    const FlexuralModes modes = flexural_modes(pinned, spec, 3);
    const std::vector<double>& bending = modes.bending;
    ASSERT_EQ(bending.size(), 3u);
    std::printf("pinned sheet: rotation mode %.3g Hz; bending %.6g, %.6g Hz, hinged-free beam %.6g, %.6g Hz\n",
                bending[0], bending[1], bending[2], modes.beam_hz(3.926602), modes.beam_hz(7.068583));
    EXPECT_LT(bending[0], 1e-4 * bending[1]);  // zero up to the solver's round-off (eigenvalue 1e-8 of it)
    EXPECT_NEAR(bending[1] / modes.beam_hz(3.926602), 1.0, 0.02);
    EXPECT_NEAR(bending[2] / modes.beam_hz(7.068583), 1.0, 0.02);
  }
}

// [solid] gravity_m_s2: every CGP feels m g, and the potential energy gains -sum m g . (x - x_flat),
// so that force and energy stay consistent (ForceIsMinusEnergyGradient's check, here with g).
TEST(ElasticSheets, GravityIsABodyForce) {
  for (const SheetKinematics kin : kAll) {
    SolidConfig config = one_sheet(5, 8, 37.0);
    ElasticSheetModel plain(config, kin);
    config.body.gravity_m_s2 = {1e9, -3e9, 2e9};
    ElasticSheetModel heavy(config, kin);
    const Eigen::Vector3d g_au = config.body.gravity_m_s2 * (PhysicalConstants::time_au_s *
                                                             PhysicalConstants::time_au_s / PhysicalConstants::bohr_m);
    std::mt19937 rng(5);
    std::normal_distribution<double> n(0.0, 20.0);
    Eigen::Matrix3Xd x = plain.positions();
    for (Eigen::Index l = 0; l < x.cols(); ++l) x.col(l) += Eigen::Vector3d(n(rng), n(rng), n(rng));
    Eigen::Matrix3Xd f0(3, x.cols()), f1(3, x.cols());
    const double e0 = plain.internal_forces(x, f0), e1 = heavy.internal_forces(x, f1);
    double work = 0.0, worst = 0.0;
    for (Eigen::Index l = 0; l < x.cols(); ++l) {
      const double m = plain.masses()[l];
      worst = std::max(worst, (f1.col(l) - f0.col(l) - m * g_au).norm() / (m * g_au.norm()));
      work += m * g_au.dot(x.col(l) - plain.positions().col(l));
    }
    EXPECT_LT(worst, 1e-12) << label(kin);
    EXPECT_NEAR(e1 - e0, -work, 1e-9 * std::abs(work)) << label(kin);
    EXPECT_NEAR(heavy.potential_energy(x), e1, 1e-12 * std::abs(e1)) << label(kin);
  }
}

// Velocity Verlet is symplectic: the energy error stays bounded (no drift). Drift is the
// change of the mean energy between the first and the last 1000 of 1e4 substeps; for the
// linear model even the largest deviation is below 1e-6. The corotational model's geometric
// nonlinearity feeds a little energy into in-plane modes with omega dt near 1, whose bounded
// O((omega dt)^2) fluctuation shows in the largest deviation (printed) but not in the drift.
TEST(ElasticSheets, FreeVibrationConservesEnergy) {
  for (const SheetKinematics kin : kAll) {
    const SolidConfig config = one_sheet(5, 40, 90.0);
    ElasticSheetModel m(config, kin);
    const SheetSpec& spec = config.sheets[0];
    // Displace along the normal with the static cantilever shape, tip amplitude 0.005 L.
    SolidState s = m.state();
    const double len = free_length(spec);
    for (Eigen::Index l = 0; l < m.num_cgps(); ++l) {
      if (spec.is_clamped(l)) continue;
      const double z = static_cast<double>(l / spec.nx_cg) * spec.height_spacing_bohr / len;
      s.positions_bohr.col(l) += 0.005 * len * (6 * z * z - 4 * z * z * z + z * z * z * z) / 3.0 *
                                 sheet_normal(spec);
    }
    m.restore(s);
    const double dt = 0.5 * m.stable_time_step();
    const Eigen::Matrix3Xd no_force = Eigen::Matrix3Xd::Zero(3, m.num_cgps());
    const auto energy = [&] {
      const SolidObservables o = m.observables();
      return o.kinetic_energy_au + o.elastic_energy_au;
    };
    const double e0 = energy();
    double deviation = 0.0, first = 0.0, last = 0.0;
    for (int n = 0; n < 10000; ++n) {
      m.substep(dt, no_force);
      const double e = energy();
      deviation = std::max(deviation, std::abs(e - e0) / e0);
      if (n < 1000) first += e / 1000.0;
      if (n >= 9000) last += e / 1000.0;
    }
    const double drift = std::abs(last - first) / e0;
    std::printf("%s: over 1e4 substeps at half the stable step: drift %.2e, largest deviation "
                "%.2e\n", label(kin), drift, deviation);
    EXPECT_LT(drift, 1e-6) << label(kin);
    if (kin == SheetKinematics::Linear) {
      EXPECT_LT(deviation, 1e-6);
    }
    EXPECT_GT(m.observables().kinetic_energy_au, 0.0);
  }
}

TEST(ElasticSheets, StrainIsZeroAtRest) {
  const SolidConfig config = one_sheet(5, 40, 45.0);
  for (const SheetKinematics kin : kAll) {
    ElasticSheetModel m(config, kin);
    const Eigen::VectorXd eps = m.observables().area_strain;
    ASSERT_EQ(eps.size(), 200);
    EXPECT_EQ(eps.cwiseAbs().maxCoeff(), 0.0) << label(kin);
  }
  // A uniform biaxial stretch by s gives (1 + s)^2 - 1 everywhere.
  const SheetSpec& spec = config.sheets[0];
  const Eigen::Matrix3Xd x0 = flat_sheet_positions(spec);
  const Eigen::VectorXd eps = area_strain(spec, 1.001 * x0, x0);
  EXPECT_NEAR(eps.maxCoeff(), 1.001 * 1.001 - 1.0, 1e-12);
  EXPECT_NEAR(eps.minCoeff(), 1.001 * 1.001 - 1.0, 1e-12);
}

// Two sheets facing each other across a small span-wise gap, thrown at each other: the
// Lennard-Jones wall (section 3.2, eps = 1000 eV, cut at dx_CG) stops them, they separate
// again, nothing becomes NaN and the total energy stays bounded.
TEST(ElasticSheets, LjContactStaysStable) {
  for (const SheetKinematics kin : kAll) {
    SolidConfig config;
    SheetSpec g1;
    g1.nx_cg = 5;
    g1.ny_cg = 10;
    g1.theta_deg = 0.0;  // normal along z
    SheetSpec g2 = g1;
    g2.base_bohr = {0.0, 0.0, 1.3 * g1.width_spacing_bohr};
    config.sheets = {g1, g2};
    ElasticSheetModel m(config, kin);
    ASSERT_TRUE(m.has_contact());
    SolidState s = m.state();
    const double speed = 20.0 / cosim::protocol::UnitConverter::velocity_au_m_s();  // 20 m/s
    for (Eigen::Index l = 0; l < m.num_cgps(); ++l) {
      const bool second = l >= g1.num_cgps();
      if (g1.is_clamped(second ? l - g1.num_cgps() : l)) continue;
      s.velocities_au(2, l) = second ? -speed : speed;
    }
    m.restore(s);
    const Eigen::Matrix3Xd no_force = Eigen::Matrix3Xd::Zero(3, m.num_cgps());
    const auto energy = [&] {
      const SolidObservables o = m.observables();
      return o.kinetic_energy_au + o.elastic_energy_au;
    };
    const double e0 = energy();
    const double dt = cosim::protocol::UnitConverter{}.dt_cg_s() / PhysicalConstants::time_au_s;
    double min_gap = 1e300, e_max = e0, e_min = e0;
    bool approached = false, separated = false;
    const auto gap = [&] {
      return m.positions().row(2).segment(g1.num_cgps(), g1.num_cgps()).minCoeff() -
             m.positions().row(2).segment(0, g1.num_cgps()).maxCoeff();
    };
    for (int n = 0; n < 20000 && !separated; ++n) {
      m.substep(dt, no_force);
      ASSERT_TRUE(m.positions().allFinite() && m.velocities().allFinite()) << "substep " << n;
      const double g = gap();
      min_gap = std::min(min_gap, g);
      if (g < g1.width_spacing_bohr) approached = true;
      if (approached && g > 1.2 * g1.width_spacing_bohr) separated = true;
      e_max = std::max(e_max, energy());
      e_min = std::min(e_min, energy());
    }
    std::printf("%s: closest approach %.3f dx_CG, energy in [%.4f, %.4f] x E0\n", label(kin),
                min_gap / g1.width_spacing_bohr, e_min / e0, e_max / e0);
    EXPECT_TRUE(approached) << label(kin);
    EXPECT_TRUE(separated) << label(kin);
    EXPECT_GT(min_gap, 0.5 * g1.width_spacing_bohr) << label(kin);
    EXPECT_LT(e_max / e0, 1.1) << label(kin);
    EXPECT_GT(e_min / e0, 0.9) << label(kin);
  }
}

TEST(ElasticSheets, RegistryBuildsBothModels) {
  const SolidConfig config = one_sheet(5, 6, 90.0);
  EXPECT_EQ(make_solid_model("rcgp", config)->name(), "rcgp");
  EXPECT_EQ(make_solid_model("corotational", config)->name(), "corotational");
  const auto m = make_solid_model("rcgp", config);
  EXPECT_GE(m->vacuum_eigenfrequencies_hz().size(), 3u);
  EXPECT_TRUE(std::isfinite(m->stable_time_step()));
  EXPECT_NE(m->startup_report().find("effective bending rigidity"), std::string::npos);
}

}  // namespace
