#include "fluid/domain/fluid_domain.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "common/run/peak_memory.hpp"
#include "fluid/io/store_io.hpp"
#include "fluid/lattice/d3q19.hpp"

namespace cosim::fluid {

void FluidDomain::set_inlet_scale(double) {
  throw std::logic_error("FluidDomain::set_inlet_scale: this domain cannot ramp its inlet (a coupled run over MPI ranks)");
}

void ramp_inlet(FluidDomain& domain, const FluidScene& scene, std::int64_t step) {
  if (scene.inlet_ramp_steps > 0.0 && double(step) <= scene.inlet_ramp_steps + 1.0)
    domain.set_inlet_scale(inlet_ramp(double(step), scene.inlet_ramp_steps));
}

namespace {

StoreShare whole_share(const FluidSolver& solver) {
  StoreShare share;
  share.value_bytes = bytes_per_value(solver.precision());
  share.whole_stride = share.local_stride = share.count = solver.layout().stride();
  return share;
}

}  // namespace

std::string SerialDomain::write_store(bool kept, const std::string& file, const std::string& name) {
  const void* store = kept ? kept_.data() : solver_.state_data();
  return write_store_share(file, name, store, whole_share(solver_), nullptr);
}

std::string SerialDomain::read_store(const std::string& file, const std::string& name, std::int64_t step) {
  void* store = solver_.mutable_state_data();
  const std::string error = read_store_share(file, name, store, whole_share(solver_));
  if (error.empty()) solver_.set_step_count(step);
  return error;
}

std::string peak_memory_line(const std::vector<double>& peaks) {
  char v[32];
  std::snprintf(v, sizeof v, "%.1f", peaks.empty() ? 0.0 : peaks[0]);
  std::string line = std::string("peak memory ") + v + " MiB (largest resident set)";
  if (peaks.size() > 1) {
    line += "; per rank:";
    for (const double p : peaks) {
      std::snprintf(v, sizeof v, " %.1f", p);
      line += v;
    }
    line += " MiB";
  }
  return line;
}

std::vector<double> SerialDomain::peak_memory_mib() { return {protocol::peak_rss_mib()}; }

}  // namespace cosim::fluid
