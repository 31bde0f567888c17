// Aligned structure-of-arrays storage for the 19 populations of one lattice block, as doubles
// (the default) or as floats (FluidParams::precision: the "mixed" and "single" modes).
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/grid_layout.hpp"

namespace cosim::fluid {

/// How the populations are stored and computed ([run] precision):
///  - Double ("double", the default): double store, double arithmetic;
///  - Mixed ("mixed"): float store, double arithmetic: halves the memory and the bytes moved
///    per update (304 -> 152) at the cost of rounding every stored population to float
///    (docs/results/precision-modes-20261206.md, docs/error-vs-runtime.md). Before issue 35 this mode was called
///    "single".
///  - Single ("single"): float store and float arithmetic (what single precision means in
///    most LB codes): the kernel collides groups of floats twice as wide as the double ones
///    (fluid/collision/stream_collide.hpp, Arithmetic). The cells an immersed boundary forces
///    are collided again by the one-cell BgkGuo in double, in every mode (FluidSolver).
enum class Precision { Double, Mixed, Single };
/// The modes, in the order of their scene names.
inline constexpr Precision kPrecisionModes[] = {Precision::Double, Precision::Mixed, Precision::Single};
/// Its scene name: "double", "mixed", "single".
const char* precision_name(Precision p);
/// Whether the populations are stored as floats (PopulationFieldSingle).
constexpr bool stores_floats(Precision p) { return p != Precision::Double; }
/// Whether the kernel computes in float ("single").
constexpr bool float_arithmetic(Precision p) { return p == Precision::Single; }
/// Why the populations of a checkpoint (fluid_run.cpp) written in the mode named `written`
/// cannot continue a run in mode `run`; empty if they can. `marked`: the checkpoint names its
/// arithmetic, as every build since issue 35 does; an unmarked one is an older build's, whose
/// "single" (float store, double arithmetic) is today's "mixed". Such a checkpoint is refused:
/// its scene file says "single", which now computes in float, and renaming the scene's mode
/// changes the scene hash the restart checks (protocol/checkpoint_identity.hpp).
std::string precision_problem(const std::string& written, bool marked, Precision run);
constexpr std::size_t bytes_per_value(Precision p) {
  return stores_floats(p) ? sizeof(float) : sizeof(double);
}

/// The layout of a population array of a grid in a precision (64-byte lines of 8 doubles or
/// 16 floats).
inline GridLayout layout_of(const GridShape& shape, Precision p) {
  return GridLayout(shape, GridLayout::kLineBytes / int(bytes_per_value(p)));
}

template <class T>
class BasicPopulationField {
 public:
  using value_type = T;
  BasicPopulationField() = default;
  explicit BasicPopulationField(const GridLayout& layout);
  /// The planes z0 .. z0 + nz - 1 of `whole` (with the ghost planes next to them) as a field
  /// of their own, in place: a view that owns nothing and must not outlive `whole`.
  static BasicPopulationField planes(BasicPopulationField& whole, int z0, int nz) {
    BasicPopulationField v;
    v.layout_ = whole.layout_.planes(nz);
    v.data_ = std::unique_ptr<T, FreeDeleter>(whole.data_.get() + std::ptrdiff_t(z0) * whole.layout_.plane_stride(),
                                              FreeDeleter{false});
    return v;
  }

  T* q(int q) { return data_.get() + std::size_t(q) * layout_.stride(); }
  const T* q(int q) const { return data_.get() + std::size_t(q) * layout_.stride(); }
  T& at(int q, int x, int y, int z) { return this->q(q)[layout_.index(x, y, z)]; }
  T at(int q, int x, int y, int z) const { return this->q(q)[layout_.index(x, y, z)]; }
  const GridLayout& layout() const { return layout_; }
  bool empty() const { return data_ == nullptr; }

 private:
  struct FreeDeleter {
    bool owns = true;  ///< false for planes(): a view
    void operator()(T* p) const;
  };
  GridLayout layout_;
  std::unique_ptr<T, FreeDeleter> data_;
};

using PopulationField = BasicPopulationField<double>;
using PopulationFieldSingle = BasicPopulationField<float>;

extern template class BasicPopulationField<double>;
extern template class BasicPopulationField<float>;

}  // namespace cosim::fluid
