// The 16-bit population store ([run] precision = "half", fluid/lattice/population_field.hpp):
// FP16S, FluidX3D's format (Lehmann et al., "Accuracy and performance of the lattice
// Boltzmann method with 64-bit, 32-bit, and customized 16-bit number formats", PRE 106,
// 015308, 2022): a population f_q is stored as the IEEE binary16 of (f_q - w_q) 2^15.
//
// Why the shift: f_q is w_q rho (1 + O(u)), so f_q itself needs the 11 significant bits of
// binary16 for its leading w_q, leaving a rounding error of up to 2^-11 w_q (1.6e-4 for
// w_0 = 1/3), larger than the velocity part w_q 3 c.u of a flow at u = 1e-3. The shifted
// f_q - w_q = w_q (rho - 1) + w_q 3 c.u + ... is small, and binary16 keeps 11 bits of it.
// Why the scale 2^15: binary16 is normal only from 2^-14 = 6.1e-5 on; below, its absolute
// step is 2^-24 = 6e-8, a relative error up to 3e-8 / |f_q - w_q|: 75 % for the smallest
// values of the project's test flows, whose |f_q - w_q| span 4e-8 to 1.1e-2 (measured:
// docs/performance.md, Precision modes; there the scale changed their error little, most
// values lying above 6.1e-5; it matters for slower flows). Scaled by 2^15 the
// normal range is 2^-29 (1.9e-9) to 65504 2^-15 (1.999): every f_q - w_q of a flow with
// rho < 7 (w_0 (rho - 1) < 2) keeps 11 significant bits, a relative rounding error of at most
// 2^-11 = 4.9e-4 of f_q - w_q; beyond 1.999 it overflows to infinity, which the watchdog
// reports (a state that far from rest is diverging). The scaling is exact (a power of two).
// Why binary16 and not FluidX3D's other format FP16C (1 sign, 4 exponent, 11 mantissa bits:
// one bit more, a smaller range): x86-64-v3 and v4 convert binary16 in hardware (F16C,
// vcvtps2ph / vcvtph2ps, 8 or 16 values an instruction), FP16C needs integer code at every
// level. The baseline level (no F16C) uses the portable conversion below, which rounds as
// vcvtps2ph does (to nearest, ties to even, subnormals and infinities included), so every
// level stores the same bits (test_precision: HalfConversionMatchesF16c; all 2^32 floats
// checked once).
//
// The conversions are written once for a std::uint32_t or a GCC vector of them (the kernel's
// groups at the baseline level): elementwise integer and float operations only.
#pragma once

#include <cstdint>

namespace cosim::fluid {

/// One stored population of the half store: the binary16 bits of (f_q - w_q) 2^15.
struct Half16 {
  std::uint16_t bits;
};
static_assert(sizeof(Half16) == 2);

/// The FP16S scale 2^15 and its inverse (exact).
inline constexpr float kHalfScale = 32768.0f;
inline constexpr float kHalfUnscale = 1.0f / 32768.0f;

namespace half_detail {
template <class U>
inline U splat(std::uint32_t c) {
  return U{} + c;
}
}  // namespace half_detail

/// The IEEE binary16 bits (in the low 16 bits) of the float whose bits are `f` (U), F the
/// float type of U's shape: rounded to nearest, ties to even; values from 65520 on round to
/// infinity; NaN stays NaN (quiet, the payload's top bits), as vcvtps2ph with
/// _MM_FROUND_TO_NEAREST_INT. After F. Giesen's float_to_half_fast3_rtne (public domain).
template <class U, class F>
inline U binary16_bits_of_float_bits(U f) {
  using half_detail::splat;
  const U sign = f & splat<U>(0x80000000u);
  const U a = f ^ sign;  // |x|
  // NaN, infinity, or at least 2^16 (rounds to infinity).
  const U special = a > splat<U>(0x7f800000u) ? (splat<U>(0x7e00u) | ((a >> 13) & splat<U>(0x3ffu)))
                                              : splat<U>(0x7c00u);
  // A subnormal or zero result (|x| < 2^-14): adding 0.5 aligns the 10 bits of the result
  // at the bottom of the float's mantissa, the float addition rounding them to nearest even.
  const U magic = splat<U>(126u << 23);  // 0.5f
  const U sub = __builtin_bit_cast(U, __builtin_bit_cast(F, a) + __builtin_bit_cast(F, magic)) - magic;
  // A normal result: rebias the exponent, round the 13 dropped bits to nearest even (a carry
  // into the exponent is right, up to infinity).
  const U odd = (a >> 13) & splat<U>(1u);
  const U normal = (a + splat<U>((15u - 127u) << 23) + splat<U>(0xfffu) + odd) >> 13;
  const U o = a >= splat<U>((127u + 16u) << 23) ? special : a < splat<U>(113u << 23) ? sub : normal;
  return o | (sign >> 16);
}

/// The float bits of the binary16 in the low 16 bits of `h` (exact; NaN quiet, as vcvtph2ps).
template <class U, class F>
inline U float_bits_of_binary16_bits(U h) {
  using half_detail::splat;
  const U sign = (h & splat<U>(0x8000u)) << 16;
  const U shifted = (h & splat<U>(0x7fffu)) << 13;
  const U exponent = shifted & splat<U>(0x0f800000u);
  const U normal = shifted + splat<U>((127u - 15u) << 23);
  const U top = shifted + splat<U>((255u - 31u) << 23);  // exponent all ones: infinity or NaN
  const U magic = splat<U>(113u << 23);  // 2^-14: the subnormal m 2^-24 is (2^-14 + m 2^-24) - 2^-14
  const U sub = __builtin_bit_cast(U, __builtin_bit_cast(F, shifted + magic) - __builtin_bit_cast(F, magic));
  const U special = shifted == splat<U>(0x0f800000u) ? top : top | splat<U>(0x00400000u);  // NaN made quiet
  const U o = exponent == splat<U>(0x0f800000u) ? special : exponent == splat<U>(0u) ? sub : normal;
  return o | sign;
}

/// binary16 <-> float, one value (the portable conversion).
inline std::uint16_t binary16_of_float(float x) {
  return std::uint16_t(binary16_bits_of_float_bits<std::uint32_t, float>(__builtin_bit_cast(std::uint32_t, x)));
}
inline float float_of_binary16(std::uint16_t h) {
  return __builtin_bit_cast(float, float_bits_of_binary16_bits<std::uint32_t, float>(h));
}

/// f = w + the value a code stands for, in double (the code outside the kernel).
inline double half_decode(Half16 h, double w) { return double(float_of_binary16(h.bits) * kHalfUnscale) + w; }
/// The code of f - w, the difference rounded to float first (then to binary16).
inline Half16 half_encode(double f, double w) {
  return Half16{binary16_of_float(float(f - w) * kHalfScale)};
}

}  // namespace cosim::fluid
