#include "solid/coupled/initial_deflection.hpp"

#include "solid/model/sheet_spec.hpp"
#include "solid/config/solid_scene.hpp"
#include "solid/model/solid_state.hpp"

namespace cosim::solid {

void apply_initial_deflection(const SolidConfig& config, double tip_bohr, DeflectionShape shape,
                              SolidModel& model) {
  SolidState state = model.state();
  for (std::size_t k = 0; k < config.sheets.size(); ++k) {
    const SheetSpec& sh = config.sheets[k];
    const Eigen::Vector3d n = sheet_normal(sh);
    const Eigen::Index first = first_cgp(config, k);
    const double free_rows = double(sh.ny_cg - sh.clamped_rows);
    const bool translation = shape == DeflectionShape::Translation;
    for (int j = translation ? 0 : sh.clamped_rows; j < sh.ny_cg; ++j) {
      const double height = double(j - (sh.clamped_rows - 1)) / free_rows;
      const double w = translation ? tip_bohr : tip_bohr * cantilever_load_shape(height);
      for (int i = 0; i < sh.nx_cg; ++i) state.positions_bohr.col(first + sh.index(i, j)) += w * n;
    }
  }
  state.velocities_au.setZero();
  model.restore(state);
}

}  // namespace cosim::solid
