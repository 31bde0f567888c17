// The elastic sheet models of the solid server (DESIGN 2.5, 4.3): graphene sheets of CGPs
// with the RCGP constants, integrated by velocity Verlet (Eq. 20).
//   "rcgp"          the linear model (the paper's harmonic CGPs; exact for small
//                   deflection, reads a finite rotation as strain)
//   "corotational"  the same energy in a rotating frame per term, for large deflection
// Both are written against the SolidModel interface only; nothing outside solid/ knows them.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "solid/contact/lj_contact.hpp"
#include "solid/rcgp/rcgp_construction.hpp"
#include "solid/models/elastic_sheet/sheet_forces.hpp"
#include "solid/models/elastic_sheet/sheet_stiffness.hpp"
#include "solid/model/solid_config.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::solid {

enum class SheetKinematics { Linear, Corotational };

class ElasticSheetModel final : public SolidModel {
 public:
  static constexpr std::string_view kRcgpName = "rcgp";
  static constexpr std::string_view kCorotationalName = "corotational";

  /// Runs (or loads from config.rcgp.cache_dir) the RCGP construction and assembles the
  /// sheets. Throws std::invalid_argument for a config it cannot take and
  /// std::runtime_error when the construction or the cache fails.
  ElasticSheetModel(const SolidConfig& config, SheetKinematics kinematics);
  ~ElasticSheetModel() override;
  // The force evaluator refers to sheets_: the model stays where it was built.
  ElasticSheetModel(const ElasticSheetModel&) = delete;
  ElasticSheetModel& operator=(const ElasticSheetModel&) = delete;

  std::string_view name() const override;
  Eigen::Index num_cgps() const override { return x_.cols(); }
  const Eigen::Matrix3Xd& positions() const override { return x_; }
  const Eigen::Matrix3Xd& velocities() const override { return v_; }
  const Eigen::VectorXd& masses() const override { return mass_; }
  double stable_time_step() const override { return stable_dt_; }
  void substep(double dt, const Eigen::Matrix3Xd& external_forces) override;
  SolidObservables observables() const override;
  std::string startup_report() const override;
  std::vector<double> vacuum_eigenfrequencies_hz() const override { return frequencies_hz_; }
  SolidState state() const override;
  void restore(const SolidState& state) override;

  // --- for validation -----------------------------------------------------------------
  /// Internal forces (elastic, contact and the body force m g of [solid] gravity_m_s2) at
  /// x, written into f (3 x N); returns the potential energy, E_h, the body force's
  /// -sum m g . (x - x_flat) included (zero at the flat sheet). Clamped CGPs get their
  /// (reaction) forces too.
  double internal_forces(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f);
  double potential_energy(const Eigen::Matrix3Xd& x);
  /// The RCGP construction; empty (no stages) for a sheet of [material].
  const RcgpConstruction& construction() const { return rcgp_; }
  const PlateConstantsAu& plate_constants() const { return plate_; }
  const std::vector<SheetBlock>& sheets() const { return sheets_; }
  const Eigen::VectorXd& inverse_masses() const { return inv_mass_; }
  bool has_contact() const { return contact_.has_value(); }
  /// How the construction was obtained (built, or loaded from the cache).
  const std::string& construction_source() const { return rcgp_source_; }

 private:
  SolidConfig config_;
  SheetKinematics kinematics_;
  RcgpConstruction rcgp_;
  std::string rcgp_source_;
  SheetConstants material_constants_;  ///< of config_.material, when set
  PlateConstantsAu plate_;
  /// The RCGP lines of startup_report().
  std::string rcgp_report() const;
  std::vector<SheetBlock> sheets_;
  std::unique_ptr<SheetForce> force_;
  std::optional<LjContact> contact_;
  Eigen::Matrix3Xd x_, v_, f_int_, f_ext_;
  Eigen::VectorXd mass_, inv_mass_;
  double potential_energy_ = 0.0;  ///< at x_
  Eigen::Vector3d gravity_au_ = Eigen::Vector3d::Zero();  ///< g, bohr / t_AU^2
  /// Adds m_l g to every column of f; returns -sum_l m_l g . (x_l - x_l,flat).
  double add_body_forces(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const;
  double stable_dt_ = 0.0;
  std::vector<double> frequencies_hz_;
  double flexural_hz_ = 0.0;  ///< the first flexural (out-of-plane) mode of sheet 0, Hz
};

/// Area strain eps_l = (|dA_l| - |dA_l0|) / |dA_l0| per CGP (the paper's section 3.2),
/// with dA_l = t_a x t_b from central differences along the width and height (one-sided
/// at edges): exactly zero for the reference positions.
Eigen::VectorXd area_strain(const SheetSpec& spec, const Eigen::Matrix3Xd& x,
                            const Eigen::Matrix3Xd& reference);

}  // namespace cosim::solid
