// Aligned structure-of-arrays storage for the 19 populations of one lattice block.
#pragma once

#include <cstddef>
#include <memory>

#include "fluid/d3q19.hpp"
#include "fluid/grid_layout.hpp"

namespace cosim::fluid {

class PopulationField {
 public:
  PopulationField() = default;
  explicit PopulationField(const GridLayout& layout);

  double* q(int q) { return data_.get() + std::size_t(q) * layout_.stride(); }
  const double* q(int q) const { return data_.get() + std::size_t(q) * layout_.stride(); }
  double& at(int q, int x, int y, int z) { return this->q(q)[layout_.index(x, y, z)]; }
  double at(int q, int x, int y, int z) const { return this->q(q)[layout_.index(x, y, z)]; }
  const GridLayout& layout() const { return layout_; }

 private:
  struct FreeDeleter {
    void operator()(double* p) const;
  };
  GridLayout layout_;
  std::unique_ptr<double, FreeDeleter> data_;
};

}  // namespace cosim::fluid
