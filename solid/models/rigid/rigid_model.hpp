// The `rigid` solid model (DESIGN 2.5): sheets held in place, for the spin-up phase and
// drag validation. It integrates nothing; it reports the forces it is handed.
#pragma once

#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "solid/model/solid_config.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::solid {

/// Every CGP stays at its flat-sheet position (flat_sheet_positions) with zero velocity;
/// substep() only records the external forces, summed per sheet in observables().
class RigidModel final : public SolidModel {
 public:
  static constexpr std::string_view kName = "rigid";

  /// Throws std::invalid_argument when the config has no sheet or a sheet is invalid.
  explicit RigidModel(const SolidConfig& config);

  std::string_view name() const override { return kName; }
  Eigen::Index num_cgps() const override { return positions_.cols(); }
  const Eigen::Matrix3Xd& positions() const override { return positions_; }
  const Eigen::Matrix3Xd& velocities() const override { return velocities_; }
  const Eigen::VectorXd& masses() const override { return masses_; }
  /// +infinity: a rigid model has no dynamics to destabilise.
  double stable_time_step() const override;
  void substep(double dt, const Eigen::Matrix3Xd& external_forces) override;
  SolidObservables observables() const override;
  std::string startup_report() const override;
  std::vector<double> vacuum_eigenfrequencies_hz() const override { return {}; }
  SolidState state() const override;
  /// Accepts only a rigid model's state of the same CGP count whose positions are the
  /// reference positions and whose velocities are zero.
  void restore(const SolidState& state) override;

 private:
  SolidConfig config_;
  Eigen::Matrix3Xd positions_;
  Eigen::Matrix3Xd velocities_;
  Eigen::VectorXd masses_;
  Eigen::Matrix3Xd external_forces_;  ///< of the latest substep
};

}  // namespace cosim::solid
