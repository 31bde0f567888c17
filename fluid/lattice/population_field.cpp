#include "fluid/lattice/population_field.hpp"

#include <cstdlib>
#include <new>

namespace cosim::fluid {

const char* precision_name(Precision p) {
  switch (p) {
    case Precision::Double: return "double";
    case Precision::Mixed: return "mixed";
    case Precision::Single: return "single";
    case Precision::Half: return "half";
  }
  return "?";
}

std::string precision_problem(const std::string& written, bool marked, Precision run) {
  const std::string want = precision_name(run);
  if (!marked && written == "single")
    return "precision = 'single': this checkpoint was written by an older build, whose \"single\" (float "
           "store, double arithmetic) is now [run] precision = \"mixed\"; it cannot continue a run of this "
           "build (start the run again with precision = \"mixed\", or restart it with the build that wrote it)";
  if (written != want)
    return "precision = '" + written + "': the checkpoint's populations are of another precision mode than "
           "this run's [run] precision = \"" + want + "\"";
  return "";
}

template <class T>
void BasicPopulationField<T>::FreeDeleter::operator()(T* p) const {
  if (owns) std::free(p);
}

template <class T>
BasicPopulationField<T>::BasicPopulationField(const GridLayout& layout) : layout_(layout) {
  const std::size_t bytes = std::size_t(D3Q19::Q) * layout.stride() * sizeof(T);
  void* p = std::aligned_alloc(64, bytes);
  if (p == nullptr) throw std::bad_alloc();
  data_.reset(static_cast<T*>(p));
  // First touch in parallel so that pages land near the threads that use them.
  T* d = data_.get();
  const std::ptrdiff_t n = std::ptrdiff_t(D3Q19::Q * layout.stride());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i) d[i] = T{};
}

template class BasicPopulationField<double>;
template class BasicPopulationField<float>;
template class BasicPopulationField<Half16>;

}  // namespace cosim::fluid
