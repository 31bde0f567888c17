// Aligned structure-of-arrays storage for the 19 populations of one lattice block, as doubles
// (the default), as floats (FluidParams::precision: the "mixed" and "single" modes) or as
// 16-bit codes of f_q - w_q ("half", fluid/lattice/half.hpp).
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <type_traits>

#include "fluid/lattice/half.hpp"

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
///  - Half ("half"): 16-bit store, float arithmetic (FluidX3D's approach): each population is
///    stored as the shifted f_q - w_q in FP16S, IEEE binary16 of (f_q - w_q) 2^15
///    (fluid/lattice/half.hpp: the format, its range and its rounding); the kernel is the
///    single mode's float kernel, its loads and stores converting (F16C on x86-64-v3 and v4,
///    the same bits by a portable conversion below). 76 bytes moved per update.
enum class Precision { Double, Mixed, Single, Half };
/// The modes, in the order of their scene names.
inline constexpr Precision kPrecisionModes[] = {Precision::Double, Precision::Mixed, Precision::Single,
                                                Precision::Half};
/// Its scene name: "double", "mixed", "single", "half".
const char* precision_name(Precision p);
/// Whether the populations are stored as floats (PopulationFieldSingle).
constexpr bool stores_floats(Precision p) { return p == Precision::Mixed || p == Precision::Single; }
/// Whether the populations are stored as 16-bit codes (PopulationFieldHalf).
constexpr bool stores_halves(Precision p) { return p == Precision::Half; }
/// Whether the kernel computes in float ("single", "half").
constexpr bool float_arithmetic(Precision p) { return p == Precision::Single || p == Precision::Half; }
/// Why the populations of a checkpoint (fluid_run.cpp) written in the mode named `written`
/// cannot continue a run in mode `run`; empty if they can. `marked`: the checkpoint names its
/// arithmetic, as every build since issue 35 does; an unmarked one is an older build's, whose
/// "single" (float store, double arithmetic) is today's "mixed". Such a checkpoint is refused:
/// its scene file says "single", which now computes in float, and renaming the scene's mode
/// changes the scene hash the restart checks (protocol/checkpoint_identity.hpp).
std::string precision_problem(const std::string& written, bool marked, Precision run);
constexpr std::size_t bytes_per_value(Precision p) {
  return stores_halves(p) ? sizeof(Half16) : stores_floats(p) ? sizeof(float) : sizeof(double);
}

/// The layout of a population array of a grid in a precision (64-byte lines of 8 doubles,
/// 16 floats or 32 halves).
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
using PopulationFieldHalf = BasicPopulationField<Half16>;

extern template class BasicPopulationField<double>;
extern template class BasicPopulationField<float>;
extern template class BasicPopulationField<Half16>;

/// A stored population as a double and back, for the code outside the kernel that computes
/// on stored values (boundary fills, the forced cells' collision, moments, initial state):
/// q is the population (its array, or the opposite one: w_q = w_opp q). The double and float
/// stores convert as a cast does; the half store decodes f_q = w_q + value and encodes
/// value = f_q - w_q (half.hpp). Copies of stored values between the slots of q, opp q and
/// mirror(q) need no conversion: they have the same weight.
inline double decode_population(double v, int) { return v; }
inline double decode_population(float v, int) { return static_cast<double>(v); }
inline double decode_population(Half16 v, int q) { return half_decode(v, D3Q19::w[q]); }
template <class T>
inline T encode_population(double v, int q) {
  if constexpr (std::is_same_v<T, Half16>)
    return half_encode(v, D3Q19::w[q]);
  else
    return static_cast<T>(v);
}
}  // namespace cosim::fluid
