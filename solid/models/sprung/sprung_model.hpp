// The `sprung` solid model: each sheet a rigid plate on a linear spring, free to translate
// along its normal only. It is the oscillator of Sader's single-mode theory exactly (one
// degree of freedom per sheet, k = M omega_vac^2; launch/sader.py), with none of a
// cantilever's mode shape: a sheet that spans a periodic box along its height is the
// infinitely long strip of his Eq. 18-22, so a free decay of it measures the coupling's
// own error against the theory, apart from a finite sheet's end effects
// (docs/validation.md, "The strip limit").
#pragma once

#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "solid/model/model_registry.hpp"
#include "solid/model/solid_config.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::solid {

/// [solid] spring_frequency_hz -> SolidConfig::spring (required by the model).
extern const ModelOptions kSpringOptions;

/// Every CGP of a sheet moves with the sheet's one displacement q along its normal n:
///   M q'' = -k q + n . sum_l F_l^ext,   M = sum_l m_l,   k = M (2 pi f_spring)^2,
/// integrated by velocity Verlet (the CGPs' Eq. 20 with the internal force replaced by the
/// spring's, shared in proportion to mass). The clamped rows are part of the plate; the
/// tangential components of the external forces are reported but do no work.
class SprungModel final : public SolidModel {
 public:
  static constexpr std::string_view kName = "sprung";

  /// Throws std::invalid_argument when the config has no sheet or no spring frequency.
  explicit SprungModel(const SolidConfig& config);

  std::string_view name() const override { return kName; }
  Eigen::Index num_cgps() const override { return positions_.cols(); }
  const Eigen::Matrix3Xd& positions() const override { return positions_; }
  const Eigen::Matrix3Xd& velocities() const override { return velocities_; }
  const Eigen::VectorXd& masses() const override { return masses_; }
  /// 2 / omega of the spring (velocity Verlet's limit).
  double stable_time_step() const override;
  void substep(double dt, const Eigen::Matrix3Xd& external_forces) override;
  SolidObservables observables() const override;
  std::string startup_report() const override;
  /// The spring's frequency, once (every sheet has it).
  std::vector<double> vacuum_eigenfrequencies_hz() const override;
  SolidState state() const override;
  /// Accepts a sprung model's state of the same CGP count in which each sheet is its flat
  /// position translated along its normal, all its CGPs with one velocity along it.
  void restore(const SolidState& state) override;

 private:
  struct Plate {
    Eigen::Index first = 0, count = 0;
    Eigen::Vector3d normal;
    double mass_me = 0.0;
  };
  /// The sheet's displacement along its normal, bohr (read off its first CGP).
  double displacement(const Plate& p) const;
  double normal_force(const Plate& p, const Eigen::Matrix3Xd& forces) const;

  SolidConfig config_;
  double omega2_ = 0.0;  ///< (2 pi f_spring)^2, t_AU^-2
  std::vector<Plate> plates_;
  Eigen::Matrix3Xd reference_, positions_, velocities_;
  Eigen::VectorXd masses_;
  Eigen::Matrix3Xd external_forces_;  ///< of the latest substep
};

}  // namespace cosim::solid
