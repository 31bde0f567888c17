#include "solid/rcgp/rcgp_construction.hpp"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

namespace cosim::solid {

namespace {

constexpr double kLambda = 2.0;  ///< spacing ratio of successive stages (Fig. 1c)
/// Bump when the construction changes its result: old cache entries then miss.
constexpr int kRcgpVersion = 1;
/// K(q) of a matched kernel may dip this far below zero (relative) from round-off only.
constexpr double kPositivityTolerance = 1e-10;

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

/// Periodic bilinear hat functions: N(a, I) of fine site a for coarse site I = J n + I_x
/// at origin + (I_x sx, J sy), in a cell of the given period. Rows sum to one.
Eigen::MatrixXd shape_functions(const std::vector<Eigen::Vector2d>& fine,
                                const Eigen::Vector2d& period, int n,
                                const Eigen::Vector2d& spacing, const Eigen::Vector2d& origin) {
  Eigen::MatrixXd shape = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(fine.size()), n * n);
  for (std::size_t a = 0; a < fine.size(); ++a) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        Eigen::Vector2d d = fine[a] - origin - Eigen::Vector2d(i * spacing.x(), j * spacing.y());
        for (int c = 0; c < 2; ++c) d(c) -= period(c) * std::round(d(c) / period(c));
        const double hx = std::max(0.0, 1.0 - std::abs(d.x()) / spacing.x());
        const double hy = std::max(0.0, 1.0 - std::abs(d.y()) / spacing.y());
        shape(static_cast<Eigen::Index>(a), j * n + i) = hx * hy;
      }
    }
  }
  return shape;
}

/// Orthonormal rigid translations of `sites` sites with `dof` components (DOF dof i + c).
Eigen::MatrixXd translations(Eigen::Index sites, int dof) {
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(sites * dof, dof);
  const double v = 1.0 / std::sqrt(static_cast<double>(sites));
  for (Eigen::Index i = 0; i < sites; ++i)
    for (int c = 0; c < dof; ++c) t(dof * i + c, c) = v;
  return t;
}

/// phi (x) I_dof: the weights acting on every component alike.
Eigen::MatrixXd per_component(const Eigen::MatrixXd& phi, int dof) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(phi.rows() * dof, phi.cols() * dof);
  for (Eigen::Index r = 0; r < phi.rows(); ++r)
    for (Eigen::Index c = 0; c < phi.cols(); ++c)
      for (int k = 0; k < dof; ++k) out(dof * r + k, dof * c + k) = phi(r, c);
  return out;
}

/// The pseudo-inverse of a symmetric positive semi-definite K whose null space is exactly
/// span(T) (orthonormal columns): (K + s T T^T)^-1 = K^+ + T T^T / s. Cholesky fails (and
/// this throws) when K has any other non-positive mode.
Eigen::LLT<Eigen::MatrixXd> shifted_cholesky(const Eigen::MatrixXd& k, const Eigen::MatrixXd& t,
                                             double s, const std::string& what) {
  Eigen::LLT<Eigen::MatrixXd> llt(k + s * t * t.transpose());
  if (llt.info() != Eigen::Success)
    throw std::runtime_error("RCGP: " + what +
                             " is not positive definite apart from the rigid translations: "
                             "the stiffness has an unstable mode");
  return llt;
}

/// Eq. 4: K_CG = (phi K^+ phi^T)^+ with the rigid translations removed at both levels.
Eigen::MatrixXd project_block(const Eigen::MatrixXd& k_fine, const Eigen::MatrixXd& phi, int dof,
                              const std::string& what) {
  const Eigen::MatrixXd t_fine = translations(k_fine.rows() / dof, dof);
  const double s = k_fine.diagonal().mean();
  const auto llt = shifted_cholesky(k_fine, t_fine, s, what + " (fine level)");
  const Eigen::MatrixXd phi_t = phi * t_fine;
  Eigen::MatrixXd g = phi * llt.solve(phi.transpose()) - phi_t * phi_t.transpose() / s;
  g = 0.5 * (g + g.transpose()).eval();
  const Eigen::MatrixXd t_coarse = translations(phi.rows() / dof, dof);
  const double sg = g.diagonal().mean();
  const auto llt_g = shifted_cholesky(g, t_coarse, sg, what + " (projected compliance)");
  Eigen::MatrixXd kc =
      llt_g.solve(Eigen::MatrixXd::Identity(g.rows(), g.cols())) -
      t_coarse * t_coarse.transpose() / sg;
  return 0.5 * (kc + kc.transpose());
}

/// The kernel of a translation-invariant n x n periodic stiffness (site J n + I), averaged
/// over the sites; `defect` gets the largest deviation relative to the largest entry.
CgKernel extract_kernel(const Eigen::MatrixXd& k_ip, const Eigen::MatrixXd& k_fl, int n,
                        double ax, double ay, double& defect) {
  const int r = (n - 1) / 2;
  CgKernel k = CgKernel::zero(ax, ay, r);
  const auto site = [n](int i, int j) { return ((j % n + n) % n) * n + ((i % n + n) % n); };
  const double inv_sites = 1.0 / (n * n);
  for (int ry = -r; ry <= r; ++ry)
    for (int rx = -r; rx <= r; ++rx)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const int a = site(i, j), b = site(i + rx, j + ry);
          k.ip(rx, ry) += inv_sites * k_ip.block<2, 2>(2 * a, 2 * b);
          k.zz(rx, ry) += inv_sites * k_fl(a, b);
        }
  double dev = 0.0;
  for (int ry = -r; ry <= r; ++ry)
    for (int rx = -r; rx <= r; ++rx)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const int a = site(i, j), b = site(i + rx, j + ry);
          dev = std::max(dev, (k_ip.block<2, 2>(2 * a, 2 * b) - k.ip(rx, ry)).cwiseAbs().maxCoeff() /
                                  k_ip.cwiseAbs().maxCoeff());
          dev = std::max(dev, std::abs(k_fl(a, b) - k.zz(rx, ry)) / k_fl.cwiseAbs().maxCoeff());
        }
  defect = dev;
  return k;
}

/// The stiffness of an m x m periodic lattice (m > 2 range) carrying kernel k.
void assemble_periodic(const CgKernel& k, int m, Eigen::MatrixXd& k_ip, Eigen::MatrixXd& k_fl) {
  k_ip = Eigen::MatrixXd::Zero(2 * m * m, 2 * m * m);
  k_fl = Eigen::MatrixXd::Zero(m * m, m * m);
  const auto site = [m](int i, int j) { return ((j % m + m) % m) * m + ((i % m + m) % m); };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i)
      for (int ry = -k.range; ry <= k.range; ++ry)
        for (int rx = -k.range; rx <= k.range; ++rx) {
          const int a = site(i, j), b = site(i + rx, j + ry);
          k_ip.block<2, 2>(2 * a, 2 * b) += k.ip(rx, ry);
          k_fl(a, b) += k.zz(rx, ry);
        }
}

KernelMoments scaled(KernelMoments m, double f) {
  m.in_plane_sum *= f;
  m.in_plane_second *= f;
  m.flexural_sum *= f;
  m.flexural_second *= f;
  m.flexural_fourth *= f;
  return m;
}

void scale_flexural(CgKernel& k, double f) {
  for (double& v : k.flexural) v *= f;
}

/// Truncates (the projection already has the cell's range), matches and checks one stage.
void finish_stage(RcgpStage& st, const KernelMoments& target, const RcgpOptions& opt,
                  double paper_factor) {
  st.kernel = st.projected;
  symmetrize(st.kernel);
  st.target = target;
  if (opt.moment_matching) match_moments(st.kernel, target);
  if (opt.flexural_scaling == FlexuralScaling::Paper) {
    scale_flexural(st.kernel, paper_factor);
    st.target.flexural_fourth *= paper_factor;
  }
  st.constants = constants_from_moments(kernel_moments(st.kernel), st.kernel.cell_area_m2());
  st.spectrum = kernel_spectrum(st.kernel);
  if (opt.moment_matching && (st.spectrum.in_plane_min_rel < -kPositivityTolerance ||
                              st.spectrum.flexural_min_rel < -kPositivityTolerance)) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "RCGP stage %d: the matched kernel has K(q) < 0 (in-plane %.3e, flexural "
                  "%.3e of the largest)",
                  st.stage, st.spectrum.in_plane_min_rel, st.spectrum.flexural_min_rel);
    throw std::runtime_error(buf);
  }
  const double k_max = std::max(st.spectrum.in_plane_max_N_m, st.spectrum.flexural_max_N_m);
  st.stable_time_step_s = 2.0 / std::sqrt(k_max / st.lumped_mass_kg);
}

std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (const unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace

double RcgpConstruction::coarse_graining_ratio() const {
  return final_stage().kernel.ax_m / (std::sqrt(3.0) * bond_length_m);
}

RcgpConstruction build_rcgp(const RcgpOptions& opt, const ForceConstantModel& atoms) {
  if (opt.stages < 1 || opt.stages > 16)
    fail(__LINE__, "rcgp stages = " + std::to_string(opt.stages) + ": allowed 1..16");
  if (opt.truncation_range < 2 || opt.truncation_range > 3)
    fail(__LINE__, "rcgp truncation_range = " + std::to_string(opt.truncation_range) +
                       ": allowed 2 or 3 (range 1 cannot carry bending; the periodic cell of "
                       "range r has 2 r + 1 CGPs a side)");
  RcgpConstruction out;
  out.options = opt;
  out.force_constants = atoms.constants();
  out.bond_length_m = atoms.lattice().bond_length_m();
  out.atom_mass_kg = atoms.mass_kg();
  out.atomistic = atoms.elastic_constants();
  out.atomistic_kappa_J = atoms.bending_rigidity_from_shells_J();

  const int n = 2 * opt.truncation_range + 1;  // CGPs per side of the periodic cell
  const double d = out.bond_length_m;
  const double lam2 = kLambda * kLambda;

  // ---- Stage 1: atoms -> n x n CGPs, each CG cell 2 x 2 rectangular unit cells.
  {
    const PeriodicCell cell = atoms.lattice().rectangular_supercell(2 * n, 2 * n);
    const Eigen::MatrixXd k_atoms = atoms.force_constant_matrix(cell);
    const double ax = 4.0 * std::sqrt(3.0) * d, ay = 6.0 * d;
    // CGPs on a bond centre, an inversion centre of the lattice with both mirror lines
    // through it: the CG kernel is then centrosymmetric and K_xy(R) odd in R_x and R_y.
    const Eigen::Vector2d origin(0.0, 0.5 * d);
    const Eigen::MatrixXd shape =
        shape_functions(cell.positions_m, cell.lattice_m.diagonal(), n, {ax, ay}, origin);
    const Eigen::MatrixXd ntn = shape.transpose() * shape;
    const Eigen::MatrixXd phi = ntn.ldlt().solve(shape.transpose());

    RcgpStage st;
    st.stage = 1;
    const Eigen::MatrixXd kc_ip = project_block(ForceConstantModel::in_plane_block(k_atoms),
                                                per_component(phi, 2), 2, "stage 1 in-plane");
    const Eigen::MatrixXd kc_fl = project_block(ForceConstantModel::out_of_plane_block(k_atoms),
                                                phi, 1, "stage 1 flexural");
    st.projected = extract_kernel(kc_ip, kc_fl, n, ax, ay, st.translation_invariance_defect);
    st.atoms_per_cgp = static_cast<double>(cell.size()) / (n * n);
    st.lumped_mass_kg = st.atoms_per_cgp * out.atom_mass_kg;

    // Consistent mass m N^T N, and its identity with (phi m^-1 phi^T)^-1.
    const Eigen::MatrixXd m_consistent = out.atom_mass_kg * ntn;
    const Eigen::MatrixXd m_projected =
        (phi * phi.transpose() / out.atom_mass_kg).inverse();
    out.stage1_mass_identity_defect =
        (m_projected - m_consistent).cwiseAbs().maxCoeff() / m_consistent.cwiseAbs().maxCoeff();
    Eigen::MatrixXd zero_ip = Eigen::MatrixXd::Zero(2 * n * n, 2 * n * n);
    double mass_defect = 0.0;
    const CgKernel mass_kernel = extract_kernel(zero_ip + per_component(m_consistent, 2),
                                                m_consistent, n, ax, ay, mass_defect);
    out.stage1_consistent_mass_kg = mass_kernel.flexural;

    SheetConstants atomistic;
    atomistic.c11_N_m = atomistic.c22_N_m = out.atomistic.c11_N_m;
    atomistic.c12_N_m = out.atomistic.c12_N_m;
    atomistic.c66_N_m = out.atomistic.c66_N_m;
    atomistic.d11_J = atomistic.d22_J = atomistic.d_mixed_J = out.atomistic_kappa_J;
    const double paper = (ax / (std::sqrt(3.0) * d)) * (ax / (std::sqrt(3.0) * d));
    finish_stage(st, moments_from_constants(atomistic, ax * ay), opt, paper);
    out.stages.push_back(std::move(st));
  }

  // ---- Stages 2..N_r: 2 x 2 copies of the n x n cell projected back on n x n.
  for (int s = 2; s <= opt.stages; ++s) {
    const RcgpStage& prev = out.stages.back();
    const int m = 2 * n;
    Eigen::MatrixXd kf_ip, kf_fl;
    assemble_periodic(prev.kernel, m, kf_ip, kf_fl);
    const double ax = prev.kernel.ax_m, ay = prev.kernel.ay_m;
    std::vector<Eigen::Vector2d> fine;
    fine.reserve(static_cast<std::size_t>(m * m));
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) fine.emplace_back(i * ax, j * ay);
    const Eigen::MatrixXd shape =
        shape_functions(fine, {m * ax, m * ay}, n, {kLambda * ax, kLambda * ay}, {0.0, 0.0});
    const Eigen::MatrixXd phi =
        (shape.transpose() * shape).ldlt().solve(shape.transpose());

    RcgpStage st;
    st.stage = s;
    const std::string tag = "stage " + std::to_string(s);
    const Eigen::MatrixXd kc_ip = project_block(kf_ip, per_component(phi, 2), 2, tag + " in-plane");
    const Eigen::MatrixXd kc_fl = project_block(kf_fl, phi, 1, tag + " flexural");
    st.projected = extract_kernel(kc_ip, kc_fl, n, kLambda * ax, kLambda * ay,
                                  st.translation_invariance_defect);
    st.atoms_per_cgp = prev.atoms_per_cgp * lam2;
    st.lumped_mass_kg = prev.lumped_mass_kg * lam2;
    // C fixed and the cell area x lambda^2: every target moment scales by lambda^2.
    finish_stage(st, scaled(kernel_moments(prev.kernel), lam2), opt, lam2);
    out.stages.push_back(std::move(st));
  }
  return out;
}

int rcgp_stages_for_spacing(double spacing_m, double bond_length_m) {
  const double h1 = 4.0 * std::sqrt(3.0) * bond_length_m;
  if (!(spacing_m > 0.0) || !std::isfinite(spacing_m))
    fail(__LINE__, "the CGP spacing must be positive and finite; got " + std::to_string(spacing_m) + " m");
  const int stages = std::max(1, 1 + static_cast<int>(std::lround(std::log2(spacing_m / h1))));
  if (stages > 16)
    fail(__LINE__, "a CGP spacing of " + std::to_string(spacing_m) + " m needs " +
                       std::to_string(stages) + " RCGP stages; at most 16 are allowed");
  return stages;
}

std::string rcgp_input_hash(const RcgpOptions& opt, const ForceConstantModel& atoms) {
  std::string s = "rcgp v" + std::to_string(kRcgpVersion);
  char buf[64];
  const auto add = [&](double v) {
    std::snprintf(buf, sizeof buf, " %a", v);
    s += buf;
  };
  s += " stages " + std::to_string(opt.stages) + " range " +
       std::to_string(opt.truncation_range) + " matching " +
       std::to_string(opt.moment_matching ? 1 : 0) + " scaling " +
       (opt.flexural_scaling == FlexuralScaling::Paper ? "paper" : "physical");
  for (const ShellForceConstants& c : atoms.constants().shells) {
    add(c.radial_N_m);
    add(c.tangential_in_N_m);
    add(c.tangential_out_N_m);
  }
  add(atoms.lattice().bond_length_m());
  add(atoms.mass_kg());
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(fnv1a(s)));
  return buf;
}

}  // namespace cosim::solid
