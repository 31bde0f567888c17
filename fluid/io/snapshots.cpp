#include "fluid/io/snapshots.hpp"

#include <cmath>
#include <string>

#include "common/text/text.hpp"

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
  if (!due(solver.step_count(), last)) return;
  FieldPart::whole(solver, whole_);
  write(whole_, nullptr, last);
}

void Snapshots::write(const FieldPart& part, const protocol::WriteGroup* group, bool last) {
  const std::int64_t step = part.step;
  if (fields_ && (step % fields_every_ == 0 || last)) fields_->write(part, group);
  if (planes_every_ > 0 && (step % planes_every_ == 0 || last))
    for (FieldWriter& w : planes_) w.write(part, group);
}

SilentWrite largest_silent_write(const FluidScene& scene) {
  SilentWrite w;
  if (scene.fields_every > 0) {
    w.bytes = 7.0 * 8.0 * double(scene.params.shape.cells());
    w.what = "a field snapshot (rho, u, vorticity)";
  }
  if (scene.coupling && scene.coupling->checkpoint_every > 0) {
    const int grids = scene.params.propagation == Propagation::InPlace ? 1 : 2;
    const double store =
        double(population_bytes(scene.params.shape, scene.params.precision, scene.params.propagation)) / grids;
    if (store > w.bytes) w = {store, "a checkpoint (one population store)"};
  }
  return w;
}

std::string silent_write_warning(const FluidScene& scene) {
  if (!scene.coupling) return "";
  const SilentWrite w = largest_silent_write(scene);
  const double seconds = w.bytes / kAssumedWriteBytesPerS, timeout = scene.coupling->peer_timeout_s;
  if (!(seconds > 0.5 * timeout)) return "";
  return w.what + " is " + protocol::fmt("%.3g", w.bytes * 1e-6) + " MB: at " +
         protocol::fmt("%.0f", kAssumedWriteBytesPerS * 1e-6) + " MB/s it takes " + protocol::fmt("%.3g", seconds) +
         " s, more than half of coupling.peer_timeout_s = " + protocol::fmt("%.3g", timeout) +
         " s, during which the solid hears nothing from the fluid and may declare it lost (exit 4); raise "
         "peer_timeout_s above " + protocol::fmt("%.3g", 2.0 * seconds) + " s or write less often";
}

}  // namespace cosim::fluid
