#include "solid/models/elastic_sheet/elastic_sheet_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Dense>

#include "protocol/units.hpp"
#include "solid/rcgp/rcgp_cache.hpp"
#include "solid/model/model_checks.hpp"
#include "solid/model/velocity_verlet.hpp"

namespace cosim::solid {

namespace {

using protocol::PhysicalConstants;

/// How many vacuum eigenfrequencies the model reports.
constexpr std::size_t kReportedModes = 6;
/// Neighbour-list skin of the contact, as a fraction of its cut-off.
constexpr double kContactSkin = 0.3;

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

double hartree_J() {
  const double v = PhysicalConstants::bohr_m / PhysicalConstants::time_au_s;
  return PhysicalConstants::electron_mass_kg * v * v;
}

/// Natural angular frequencies (rad / t_AU, ascending) of one clamped sheet: the
/// generalized problem K v = omega^2 M v on the free DOFs, lumped M.
/// The angular eigenfrequencies of a sheet's free CGPs in vacuum, ascending: of all three
/// directions, or (normal_only) of the motion along the sheet's normal alone, the flexural
/// modes, which the flat sheet's linear energy decouples from the in-plane ones
/// (sheet_stiffness.hpp: local axes a, b, n, DOF 3 l + c).
Eigen::VectorXd sheet_omegas(const SheetBlock& s, const SheetSpec& spec, bool normal_only = false) {
  const Eigen::MatrixXd k = Eigen::MatrixXd(s.stiffness);
  std::vector<Eigen::Index> free;
  for (Eigen::Index l = 0; l < s.count; ++l)
    if (!spec.is_clamped(l))
      for (int c = normal_only ? 2 : 0; c < 3; ++c) free.push_back(3 * l + c);
  const auto n = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd a(n, n);
  for (Eigen::Index p = 0; p < n; ++p)
    for (Eigen::Index q = 0; q < n; ++q)
      a(p, q) = k(free[static_cast<std::size_t>(p)], free[static_cast<std::size_t>(q)]) /
                spec.cgp_mass_me;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(a, Eigen::EigenvaluesOnly);
  return es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
}


/// sheet_omegas() of every sheet, solved once per distinct eigenproblem: sheets with the
/// same stiffness (local axes: where a sheet stands and how it is turned do not enter), CGP
/// mass and clamped CGPs share their frequencies: a scene of many equal sheets solves one.
class SheetOmegas {
 public:
  const Eigen::VectorXd& of(const SheetBlock& s, const SheetSpec& spec) {
    const std::uint64_t key = fingerprint(s, spec);
    const auto [first, last] = seen_.equal_range(key);
    for (auto it = first; it != last; ++it)
      if (same(*it->second.block, *it->second.spec, s, spec)) return it->second.omegas;
    return seen_.emplace(key, Entry{&s, &spec, sheet_omegas(s, spec)})->second.omegas;
  }

 private:
  struct Entry {
    const SheetBlock* block;
    const SheetSpec* spec;
    Eigen::VectorXd omegas;
  };
  static void mix(std::uint64_t& h, const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < bytes; ++k) h = (h ^ p[k]) * 1099511628211ull;  // FNV-1a
  }
  static std::uint64_t fingerprint(const SheetBlock& s, const SheetSpec& spec) {
    std::uint64_t h = 14695981039346656037ull;
    const Eigen::Index clamped = Eigen::Index{spec.clamped_rows} * spec.nx_cg;
    mix(h, &s.count, sizeof s.count);
    mix(h, &clamped, sizeof clamped);
    mix(h, &spec.cgp_mass_me, sizeof spec.cgp_mass_me);
    const auto nnz = static_cast<std::size_t>(s.stiffness.nonZeros());
    mix(h, s.stiffness.valuePtr(), nnz * sizeof(double));
    return h;
  }
  static bool same(const SheetBlock& a, const SheetSpec& as, const SheetBlock& b, const SheetSpec& bs) {
    if (a.count != b.count || Eigen::Index{as.clamped_rows} * as.nx_cg != Eigen::Index{bs.clamped_rows} * bs.nx_cg ||
        as.cgp_mass_me != bs.cgp_mass_me || a.stiffness.rows() != b.stiffness.rows() ||
        a.stiffness.cols() != b.stiffness.cols() || a.stiffness.nonZeros() != b.stiffness.nonZeros())
      return false;
    const auto nnz = static_cast<std::size_t>(a.stiffness.nonZeros());
    const auto outer = static_cast<std::size_t>(a.stiffness.outerSize()) + 1;
    return std::equal(a.stiffness.valuePtr(), a.stiffness.valuePtr() + nnz, b.stiffness.valuePtr()) &&
           std::equal(a.stiffness.innerIndexPtr(), a.stiffness.innerIndexPtr() + nnz, b.stiffness.innerIndexPtr()) &&
           std::equal(a.stiffness.outerIndexPtr(), a.stiffness.outerIndexPtr() + outer, b.stiffness.outerIndexPtr());
  }
  std::unordered_multimap<std::uint64_t, Entry> seen_;
};

}  // namespace

ElasticSheetModel::ElasticSheetModel(const SolidConfig& config, SheetKinematics kinematics)
    : config_(config), kinematics_(kinematics) {
  if (config_.sheets.empty())
    fail(__LINE__, "the " + std::string(name()) + " model needs at least one sheet; the scene "
                   "names none");
  for (const SheetSpec& s : config_.sheets) check_sheet_spec(s);
  if (config_.material) {
    // A continuum sheet: the plane-strain bar's constants (sheet_material.hpp), no graphene.
    material_constants_ = plane_strain_sheet_constants(*config_.material);
    plate_ = plate_constants_au(material_constants_, 0.0);
    rcgp_source_ = "not used ([material])";
  } else {
    if (config_.rcgp.stages == 0)  // stage count from Lambda = dx_CG / dx_MD
      config_.rcgp.stages = rcgp_stages_for_spacing(config_.sheets.front().width_spacing_bohr *
                                                    PhysicalConstants::bohr_m);
    rcgp_ = load_or_build_rcgp(config_.rcgp, ForceConstantModel{}, &rcgp_source_);
    plate_ = plate_constants_au(rcgp_.final_stage().constants, config_.rcgp.bending_poisson);
  }

  const Eigen::Index n = total_cgps(config_);
  x_.resize(3, n);
  mass_.resize(n);
  inv_mass_.resize(n);
  std::vector<int> sheet_of;
  // Reserved: a SheetBlock is copied, not moved, when the vector grows (Eigen's sparse
  // matrix has no noexcept move), and each copy allocates every term again.
  sheets_.reserve(config_.sheets.size());
  for (std::size_t s = 0; s < config_.sheets.size(); ++s) {
    const SheetSpec& spec = config_.sheets[s];
    SheetBlock b;
    b.first = first_cgp(config_, s);
    b.count = spec.num_cgps();
    b.axes = sheet_axes(spec);
    b.reference_bohr = flat_sheet_positions(spec);
    b.terms = sheet_stiffness_terms(spec, plate_);
    b.stiffness = assemble_stiffness(b.terms, b.count);
    x_.middleCols(b.first, b.count) = b.reference_bohr;
    for (Eigen::Index l = 0; l < b.count; ++l) {
      mass_[b.first + l] = spec.cgp_mass_me;
      inv_mass_[b.first + l] = spec.is_clamped(l) ? 0.0 : 1.0 / spec.cgp_mass_me;
      sheet_of.push_back(static_cast<int>(s));
    }
    sheets_.push_back(std::move(b));
  }
  if (kinematics_ == SheetKinematics::Linear)
    force_ = std::make_unique<LinearSheetForce>(sheets_);
  else
    force_ = std::make_unique<CorotationalSheetForce>(sheets_);

  if (config_.sheets.size() >= 2) {  // contact only where there is something to touch
    double sigma = config_.contact.cutoff_bohr;
    if (sigma == 0.0) {
      sigma = config_.sheets.front().width_spacing_bohr;
      for (const SheetSpec& s : config_.sheets)
        sigma = std::min({sigma, s.width_spacing_bohr, s.height_spacing_bohr});
    }
    const double eps = config_.contact.epsilon_eV / PhysicalConstants::hartree_eV;
    contact_.emplace(sheet_of, eps, sigma, kContactSkin * sigma);
  }

  // Vacuum eigenfrequencies and the stable step 2 / omega_max (velocity Verlet).
  std::vector<double> omegas;
  double omega_max = 0.0;
  SheetOmegas solved;
  for (std::size_t s = 0; s < sheets_.size(); ++s) {
    const Eigen::VectorXd& w = solved.of(sheets_[s], config_.sheets[s]);
    omega_max = std::max(omega_max, w.maxCoeff());
    for (Eigen::Index k = 0; k < w.size(); ++k) omegas.push_back(w[k]);
  }
  // The lowest kReportedModes only.
  const std::size_t reported = std::min(kReportedModes, omegas.size());
  std::partial_sort(omegas.begin(), omegas.begin() + static_cast<std::ptrdiff_t>(reported), omegas.end());
  for (std::size_t k = 0; k < reported; ++k)
    frequencies_hz_.push_back(omegas[k] / (2.0 * std::numbers::pi * PhysicalConstants::time_au_s));
  // The first flexural mode of the first sheet: on a slender sheet (L/b of 30) the in-plane
  // bending mode comes first, and a strip theory such as Sader's is about the flexural one.
  flexural_hz_ = sheet_omegas(sheets_.front(), config_.sheets.front(), true).minCoeff() /
                 (2.0 * std::numbers::pi * PhysicalConstants::time_au_s);
  stable_dt_ = omega_max > 0.0 ? 2.0 / omega_max : std::numeric_limits<double>::infinity();

  // g in atomic units (bohr / t_AU^2).
  gravity_au_ = config_.body.gravity_m_s2 * (PhysicalConstants::time_au_s * PhysicalConstants::time_au_s /
                                             PhysicalConstants::bohr_m);
  v_ = Eigen::Matrix3Xd::Zero(3, n);
  f_ext_ = Eigen::Matrix3Xd::Zero(3, n);
  f_int_.resize(3, n);
  potential_energy_ = internal_forces(x_, f_int_);
}

ElasticSheetModel::~ElasticSheetModel() = default;

std::string_view ElasticSheetModel::name() const {
  return kinematics_ == SheetKinematics::Linear ? kRcgpName : kCorotationalName;
}

double ElasticSheetModel::add_body_forces(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const {
  if (gravity_au_.isZero(0.0)) return 0.0;
  double e = 0.0;
  for (const SheetBlock& b : sheets_)
    for (Eigen::Index l = 0; l < b.count; ++l) {
      const Eigen::Index k = b.first + l;
      f.col(k) += mass_[k] * gravity_au_;
      e -= mass_[k] * gravity_au_.dot(x.col(k) - b.reference_bohr.col(l));
    }
  return e;
}

double ElasticSheetModel::internal_forces(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) {
  double e = force_->evaluate(x, f);
  if (contact_) e += contact_->add_forces(x, f);
  return e + add_body_forces(x, f);
}

double ElasticSheetModel::potential_energy(const Eigen::Matrix3Xd& x) {
  Eigen::Matrix3Xd f(3, x.cols());
  double e = force_->evaluate(x, f);
  if (contact_) e += contact_->energy(x);
  return e + add_body_forces(x, f);
}

void ElasticSheetModel::substep(double dt, const Eigen::Matrix3Xd& external_forces) {
  check_substep_args(dt, external_forces, num_cgps());
  f_ext_ = external_forces;
  velocity_verlet_substep(x_, v_, inv_mass_, f_int_, f_ext_, dt,
                          [this](const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) {
                            potential_energy_ = internal_forces(x, f);
                          });
}

SolidObservables ElasticSheetModel::observables() const {
  SolidObservables o;
  o.area_strain.resize(num_cgps());
  for (std::size_t s = 0; s < sheets_.size(); ++s) {
    const SheetBlock& b = sheets_[s];
    const SheetSpec& spec = config_.sheets[s];
    const Eigen::Index marked = b.first + spec.marked_cgp();
    o.marked_displacement_bohr.push_back(x_.col(marked) - b.reference_bohr.col(spec.marked_cgp()));
    o.total_external_force_au.push_back(f_ext_.middleCols(b.first, b.count).rowwise().sum());
    o.area_strain.segment(b.first, b.count) =
        area_strain(spec, x_.middleCols(b.first, b.count), b.reference_bohr);
  }
  o.kinetic_energy_au = 0.5 * (v_.colwise().squaredNorm().transpose().cwiseProduct(mass_)).sum();
  o.elastic_energy_au = potential_energy_;
  return o;
}

std::string ElasticSheetModel::startup_report() const {
  const SheetSpec& s0 = config_.sheets.front();
  std::string r;
  char buf[512];
  std::snprintf(buf, sizeof buf, "solid model: %s (%s), %zu sheet(s), %ld CGPs%s\n",
                std::string(name()).c_str(),
                kinematics_ == SheetKinematics::Linear ? "linear" : "corotational, large deflection",
                sheets_.size(), static_cast<long>(num_cgps()),
                contact_ ? ", LJ contact between sheets" : "");
  r += buf;
  if (config_.material) {
    const SheetMaterial& m = *config_.material;
    const SheetConstants& c = material_constants_;
    std::snprintf(buf, sizeof buf,
                  "material: E %.6g Pa, nu %.4g, rho %.6g kg/m^3, thickness %.6g m: a plane-strain bar "
                  "(docs/validation.md, \"Turek & Hron's bar\")\n"
                  "plate: stretching E h / (1 - nu^2) = %.6g N/m, bending D = E h^3 / (12 (1 - nu^2)) = %.6g J "
                  "per width, rho h = %.6g kg/m^2, no Poisson coupling (C12 = D12 = 0)\n",
                  m.youngs_modulus_Pa, m.poisson_ratio, m.density_kg_m3, m.thickness_m, c.c22_N_m, c.d22_J,
                  m.mass_per_area_kg_m2());
    r += buf;
    std::snprintf(buf, sizeof buf, "sheet CGP spacing %.6g x %.6g m; CGP mass %.6g kg\n",
                  s0.width_spacing_bohr * PhysicalConstants::bohr_m, s0.height_spacing_bohr * PhysicalConstants::bohr_m,
                  s0.cgp_mass_me * PhysicalConstants::electron_mass_kg);
    r += buf;
  } else {
    r += rcgp_report();
  }
  r += "eigenfrequencies in vacuum:";
  for (std::size_t k = 0; k < std::min<std::size_t>(3, frequencies_hz_.size()); ++k) {
    std::snprintf(buf, sizeof buf, " %.5g Hz%s", frequencies_hz_[k], k < 2 ? "," : "");
    r += buf;
  }
  std::snprintf(buf, sizeof buf, "\nfirst flexural eigenfrequency in vacuum (sheet 0, out of plane): %.5g Hz",
                flexural_hz_);
  r += buf;
  std::snprintf(buf, sizeof buf, "\nstable dt_CG (2 / omega_max, velocity Verlet): %.5g s\n",
                stable_dt_ * PhysicalConstants::time_au_s);
  r += buf;
  if (!config_.body.gravity_m_s2.isZero(0.0)) {
    const Eigen::Vector3d& g = config_.body.gravity_m_s2;
    std::snprintf(buf, sizeof buf, "body force: gravity [%.5g, %.5g, %.5g] m/s^2 on every CGP (m g)\n", g[0], g[1],
                  g[2]);
    r += buf;
  }
  bool pinned = false;
  for (const SheetSpec& s : config_.sheets) pinned = pinned || s.pinned;
  if (pinned) r += "leading edge: pinned (held, free to rotate: no bending moment across the held row)\n";
  return r;
}

std::string ElasticSheetModel::rcgp_report() const {
  const RcgpStage& fin = rcgp_.final_stage();
  const SheetConstants& c = fin.constants;
  const double ev = PhysicalConstants::hartree_eV / hartree_J();  // eV per J
  const SheetSpec& s0 = config_.sheets.front();
  const bool paper = config_.rcgp.flexural_scaling == FlexuralScaling::Paper;
  std::string r;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "RCGP: %zu stages, Lambda = %.0f, CG lattice %.4f x %.4f um, %.4g atoms per CGP; "
                "%s\n",
                rcgp_.stages.size(), rcgp_.coarse_graining_ratio(), fin.kernel.ax_m * 1e6,
                fin.kernel.ay_m * 1e6, fin.atoms_per_cgp, rcgp_source_.c_str());
  r += buf;
  std::snprintf(buf, sizeof buf,
                "sheet CGP spacing %.4f x %.4f um = %.4f x %.4f of the RCGP lattice's; CGP mass "
                "%.4g kg (%.4g of the construction's)\n",
                s0.width_spacing_bohr * PhysicalConstants::bohr_m * 1e6,
                s0.height_spacing_bohr * PhysicalConstants::bohr_m * 1e6,
                s0.width_spacing_bohr * PhysicalConstants::bohr_m / fin.kernel.ax_m,
                s0.height_spacing_bohr * PhysicalConstants::bohr_m / fin.kernel.ay_m,
                s0.cgp_mass_me * PhysicalConstants::electron_mass_kg,
                s0.cgp_mass_me * PhysicalConstants::electron_mass_kg / fin.lumped_mass_kg);
  r += buf;
  std::snprintf(buf, sizeof buf,
                "in-plane: C11 %.1f, C22 %.1f, C12 %.1f, C66 %.1f N/m, E_2D %.1f N/m\n",
                c.c11_N_m, c.c22_N_m, c.c12_N_m, c.c66_N_m, c.youngs_x_N_m());
  r += buf;
  std::snprintf(buf, sizeof buf,
                "effective bending rigidity: D = %.4g J = %.4g eV (flexural_scaling \"%s\"; "
                "graphene's kappa %.3f eV)\n",
                c.d11_J, c.d11_J * ev, paper ? "paper" : "physical", rcgp_.atomistic_kappa_J * ev);
  r += buf;
  return r;
}

SolidState ElasticSheetModel::state() const { return {std::string(name()), x_, v_, f_ext_}; }

void ElasticSheetModel::restore(const SolidState& state) {
  check_state_shape(name(), state, num_cgps());
  x_ = state.positions_bohr;
  v_ = state.velocities_au;
  f_ext_ = state.external_forces_au;
  potential_energy_ = internal_forces(x_, f_int_);
}

Eigen::VectorXd area_strain(const SheetSpec& spec, const Eigen::Matrix3Xd& x,
                            const Eigen::Matrix3Xd& reference) {
  Eigen::VectorXd eps(spec.num_cgps());
  const auto area = [&](const Eigen::Matrix3Xd& p, int i, int j) {
    const int i0 = std::max(i - 1, 0), i1 = std::min(i + 1, spec.nx_cg - 1);
    const int j0 = std::max(j - 1, 0), j1 = std::min(j + 1, spec.ny_cg - 1);
    const Eigen::Vector3d ta = (p.col(spec.index(i1, j)) - p.col(spec.index(i0, j))) / (i1 - i0);
    const Eigen::Vector3d tb = (p.col(spec.index(i, j1)) - p.col(spec.index(i, j0))) / (j1 - j0);
    return ta.cross(tb).norm();
  };
  for (int j = 0; j < spec.ny_cg; ++j)
    for (int i = 0; i < spec.nx_cg; ++i) {
      const double a0 = area(reference, i, j);
      eps[spec.index(i, j)] = (area(x, i, j) - a0) / a0;
    }
  return eps;
}

}  // namespace cosim::solid
