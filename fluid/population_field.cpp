#include "fluid/population_field.hpp"

#include <cstdlib>
#include <new>

namespace cosim::fluid {

void PopulationField::FreeDeleter::operator()(double* p) const { std::free(p); }

PopulationField::PopulationField(const GridLayout& layout) : layout_(layout) {
  const std::size_t bytes = std::size_t(D3Q19::Q) * layout.stride() * sizeof(double);
  void* p = std::aligned_alloc(64, bytes);
  if (p == nullptr) throw std::bad_alloc();
  data_.reset(static_cast<double*>(p));
  // First touch in parallel so that pages land near the threads that use them.
  double* d = data_.get();
  const std::ptrdiff_t n = std::ptrdiff_t(D3Q19::Q * layout.stride());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i) d[i] = 0.0;
}

}  // namespace cosim::fluid
