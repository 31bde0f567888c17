#include "fluid/io/snapshots.hpp"

#include <cmath>
#include <string>

namespace cosim::fluid {

Snapshots::Snapshots(const FluidScene& scene, double dt_us)
    : fields_every_(scene.fields_every), planes_every_(scene.planes_every) {
  if (fields_every_ > 0) fields_.emplace(scene.output_dir, scene.dx_um, dt_us);
  if (planes_every_ > 0) {
    const int ny = scene.params.shape.ny;
    for (const double f : scene.planes_y) {
      // The nearest cell centre to y = f L, with L = ny dx (cell y spans [y - 1/2, y + 1/2]).
      const int y = std::min(ny - 1, std::max(0, int(std::lround(f * ny - 0.5))));
      planes_.emplace_back(scene.output_dir, scene.dx_um, dt_us,
                           "plane_y" + std::to_string(y), y);
    }
  }
}

bool Snapshots::due(std::int64_t fields_every, std::int64_t planes_every, std::int64_t step, bool last) {
  const auto on = [&](std::int64_t every) {
    return every > 0 && (step % every == 0 || last);
  };
  return on(fields_every) || on(planes_every);
}

void Snapshots::adopt_up_to(std::int64_t step) {
  if (fields_)
    for (std::int64_t s = 0; s <= step; s += fields_every_) fields_->adopt(s);
  if (planes_every_ > 0)
    for (FieldWriter& w : planes_)
      for (std::int64_t s = 0; s <= step; s += planes_every_) w.adopt(s);
}

void Snapshots::write(const FluidSolver& solver, bool last) {
  const std::int64_t step = solver.step_count();
  if (fields_ && (step % fields_every_ == 0 || last)) fields_->write(solver);
  if (planes_every_ > 0 && (step % planes_every_ == 0 || last))
    for (FieldWriter& w : planes_) w.write(solver);
}

}  // namespace cosim::fluid
