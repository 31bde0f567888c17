#include "fluid/domain/fluid_domain.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "fluid/lattice/d3q19.hpp"

namespace cosim::fluid {

template <class T>
StoreView store_view(const BasicPopulationField<T>& f) {
  StoreView v;
  if constexpr (std::is_same_v<T, double>)
    v.d = f.q(0);
  else
    v.s = f.q(0);
  v.size = std::size_t(D3Q19::Q) * f.layout().stride();
  return v;
}
template StoreView store_view(const PopulationField&);
template StoreView store_view(const PopulationFieldSingle&);

void FluidDomain::set_inlet_scale(double) {
  throw std::logic_error("FluidDomain::set_inlet_scale: this domain cannot ramp its inlet (a coupled run over MPI ranks)");
}

void ramp_inlet(FluidDomain& domain, const FluidScene& scene, std::int64_t step) {
  if (scene.inlet_ramp_steps > 0.0 && double(step) <= scene.inlet_ramp_steps + 1.0)
    domain.set_inlet_scale(inlet_ramp(double(step), scene.inlet_ramp_steps));
}

StoreView SerialDomain::whole_store(bool kept) {
  if (solver_.precision() == Precision::Double) return store_view(kept ? kept_.field() : solver_.state());
  return store_view(kept ? kept_.field_single() : solver_.state_single());
}

void SerialDomain::load_store(const StoreView& from, std::int64_t step) {
  const std::size_t size = std::size_t(D3Q19::Q) * solver_.layout().stride();
  const bool dbl = solver_.precision() == Precision::Double;
  if (from.size != size || (dbl ? from.d == nullptr : from.s == nullptr))
    throw std::invalid_argument("SerialDomain::load_store: " + std::to_string(from.size) + " values of the other precision or size; " +
                                std::to_string(size) + " expected");
  if (from.d != nullptr)
    std::copy(from.d, from.d + size, solver_.mutable_state().q(0));
  else
    std::copy(from.s, from.s + size, solver_.mutable_state_single().q(0));
  solver_.set_step_count(step);
}

}  // namespace cosim::fluid
