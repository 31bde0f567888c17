// A group of kLanes doubles processed as one SIMD value by the bulk kernel: a GCC/Clang
// vector type as wide as the target's vector registers (AVX-512: 8, AVX: 4, else 2).
// Arithmetic is elementwise; scalars broadcast. Loads and stores exist for double and for
// float storage (converted to and from double lanes).
//
// Only for the translation units compiled once per instruction-set level (fluid/CMakeLists.txt,
// cosim_isa_objects): everything here lives in that level's namespace COSIM_ISA_NS, so the
// levels' inline functions never mix at link time.
#pragma once

#if !defined(COSIM_ISA_NS) || !defined(COSIM_ISA_LEVEL)
#error "fluid/lattice/lanes.hpp belongs to the per-level kernel sources (cosim_isa_objects in fluid/CMakeLists.txt)"
#endif

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include <cstdint>
#include <cstring>
#include <type_traits>

#include "fluid/lattice/half.hpp"

namespace cosim::fluid::COSIM_ISA_NS {

/// The level this unit is compiled for (fluid/collision/kernel_dispatch.hpp) and its vectors.
constexpr const char* kIsaLevel = COSIM_ISA_LEVEL;
#if defined(__AVX512F__)
constexpr int kLanes = 8;
constexpr const char* kIsaVectors = "AVX-512, 8 doubles per group";
#elif defined(__AVX__)
constexpr int kLanes = 4;
constexpr const char* kIsaVectors = "AVX2, 4 doubles per group";
#elif defined(__SSE2__)
constexpr int kLanes = 2;
constexpr const char* kIsaVectors = "SSE, 2 doubles per group";
#else
constexpr int kLanes = 2;
constexpr const char* kIsaVectors = "generic vectors, 2 doubles per group";
#endif
using Lanes = double __attribute__((vector_size(kLanes * sizeof(double))));

/// Whether store_stream is a non-temporal store on this target (x86 with SSE2 or later).
#if defined(__SSE2__)
constexpr bool kHasStreamingStores = true;
#else
constexpr bool kHasStreamingStores = false;
#endif

/// kLanes consecutive doubles from any 8-byte aligned address.
inline Lanes load(const double* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

/// kLanes consecutive doubles to an address aligned to sizeof(Lanes).
inline void store_aligned(double* p, Lanes v) {
  *static_cast<Lanes*>(__builtin_assume_aligned(p, sizeof(Lanes))) = v;
}

/// kLanes consecutive doubles to an address aligned to sizeof(Lanes) with a non-temporal
/// store (no read for ownership, bypasses the caches); an ordinary store where the target
/// has none. Needs store_fence() before other threads read the data.
inline void store_stream(double* p, Lanes v) {
#if defined(__AVX512F__)
  _mm512_stream_pd(p, v);
#elif defined(__AVX__)
  _mm256_stream_pd(p, v);
#elif defined(__SSE2__)
  _mm_stream_pd(p, v);
#else
  store_aligned(p, v);
#endif
}

inline void store_fence() {
#if defined(__SSE2__)
  _mm_sfence();
#endif
}

// The single-precision store (Precision::Mixed): kLanes floats are loaded into and stored
// from the same double Lanes; the conversion to float rounds to nearest.
using LanesSingle = float __attribute__((vector_size(kLanes * sizeof(float))));

inline Lanes load(const float* p) {
  LanesSingle v;
  std::memcpy(&v, p, sizeof v);
  return __builtin_convertvector(v, Lanes);
}

/// To an address aligned to sizeof(LanesSingle) (half a double group).
inline void store_aligned(float* p, Lanes v) {
  *static_cast<LanesSingle*>(__builtin_assume_aligned(p, sizeof(LanesSingle))) =
      __builtin_convertvector(v, LanesSingle);
}

/// kLanes floats to an address aligned to sizeof(LanesSingle), non-temporal where the
/// target has a store that wide (AVX-512: 256 bits, AVX: 128 bits), else an ordinary store.
/// Half a cache line (or less) at a time: the kernel writes the parts of a line back to
/// back (fluid/collision/stream_collide.cpp), or the write-combining buffer flushes partial lines.
inline void store_stream(float* p, LanesSingle w) {
#if defined(__AVX512F__)
  _mm256_stream_ps(p, w);
#elif defined(__AVX__)
  _mm_stream_ps(p, w);
#else
  *static_cast<LanesSingle*>(__builtin_assume_aligned(p, sizeof(LanesSingle))) = w;
#endif
}

inline LanesSingle to_single(Lanes v) { return __builtin_convertvector(v, LanesSingle); }

inline LanesSingle load_aligned_single(const float* p) {
  return *static_cast<const LanesSingle*>(__builtin_assume_aligned(p, sizeof(LanesSingle)));
}

#if defined(__AVX512F__)
/// Two groups of 8 floats, lo then hi, as one 64-byte non-temporal store to an aligned p.
inline void store_stream_pair(float* p, LanesSingle lo, LanesSingle hi) {
  using Line = float __attribute__((vector_size(64)));
  const Line v = __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  _mm512_stream_ps(p, reinterpret_cast<__m512>(v));
}
#endif

/// One 64-byte line of floats from an aligned buffer to an aligned address p, with the
/// widest non-temporal store the target has (AVX-512: one, AVX: two, SSE2: four).
inline void store_stream_line(float* p, const float* line) {
#if defined(__AVX512F__)
  _mm512_stream_ps(p, _mm512_load_ps(line));
#elif defined(__AVX__)
  _mm256_stream_ps(p, _mm256_load_ps(line));
  _mm256_stream_ps(p + 8, _mm256_load_ps(line + 8));
#elif defined(__SSE2__)
  for (int i = 0; i < 16; i += 4) _mm_stream_ps(p + i, _mm_load_ps(line + i));
#else
  std::memcpy(p, line, 64);
#endif
}

/// One 64-byte line of doubles from an aligned buffer to an aligned address p, with the
/// widest non-temporal store the target has (AVX-512: one, AVX: two, SSE2: four).
inline void store_stream_line(double* p, const double* line) {
#if defined(__AVX512F__)
  _mm512_stream_pd(p, _mm512_load_pd(line));
#elif defined(__AVX__)
  _mm256_stream_pd(p, _mm256_load_pd(line));
  _mm256_stream_pd(p + 4, _mm256_load_pd(line + 4));
#elif defined(__SSE2__)
  for (int i = 0; i < 8; i += 2) _mm_stream_pd(p + i, _mm_load_pd(line + i));
#else
  std::memcpy(p, line, 64);
#endif
}

/// The first n < kLanes lanes from p; the others are 1 (a harmless density).
inline Lanes load_partial(const double* p, int n) {
  Lanes v = Lanes{} + 1.0;
  std::memcpy(&v, p, sizeof(double) * unsigned(n));
  return v;
}

/// The first n < kLanes lanes of v to p.
inline void store_partial(double* p, Lanes v, int n) {
  std::memcpy(p, &v, sizeof(double) * unsigned(n));
}

inline Lanes load_partial(const float* p, int n) {
  LanesSingle v = LanesSingle{} + 1.0f;
  std::memcpy(&v, p, sizeof(float) * unsigned(n));
  return __builtin_convertvector(v, Lanes);
}

inline void store_partial(float* p, Lanes v, int n) {
  const LanesSingle w = __builtin_convertvector(v, LanesSingle);
  std::memcpy(p, &w, sizeof(float) * unsigned(n));
}

/// kLanes values at any address (a group of doubles, or floats rounded from it).
inline void store_unaligned(double* p, Lanes v) { std::memcpy(p, &v, sizeof v); }
inline void store_unaligned(float* p, Lanes v) {
  const LanesSingle w = __builtin_convertvector(v, LanesSingle);
  std::memcpy(p, &w, sizeof w);
}

// ---- Groups of any arithmetic type on any store (the kernel, fluid/collision/stream_collide.cpp,
// and the bench's peer pattern): a group V is Lanes (double arithmetic: the modes "double" and
// "mixed") or LanesFloat (float arithmetic: "single"); its values are stored as T (double or
// float), converted on the way in and out where T is not V's scalar (round to nearest). The
// double-store and mixed forms do what the overloads above do, bit for bit.

/// The float-arithmetic group: as many floats as the level's vector registers hold (AVX-512:
/// 16, AVX: 8, else 4), twice the doubles of a Lanes.
using LanesFloat = float __attribute__((vector_size(sizeof(Lanes))));

/// The scalar type of a group V (double for Lanes, float for LanesFloat) and its width.
template <class V>
using Scalar = std::remove_cvref_t<decltype(V{}[0])>;
template <class V>
constexpr int lanes_of = int(sizeof(V) / sizeof(Scalar<V>));

/// The group of V's width as stored: lanes_of<V> values of T.
template <class T, class V>
struct StoredGroup {
  typedef T type __attribute__((vector_size(lanes_of<V> * sizeof(T))));
};
template <class T, class V>
using Stored = typename StoredGroup<T, V>::type;

/// A group as stored (rounded to T where V computes in a wider type).
template <class T, class V>
[[gnu::always_inline]] inline Stored<T, V> to_stored(V v) {
  if constexpr (std::is_same_v<Scalar<V>, T>)
    return v;
  else
    return __builtin_convertvector(v, Stored<T, V>);
}

template <class V, class T>
[[gnu::always_inline]] inline V from_stored(Stored<T, V> w) {
  if constexpr (std::is_same_v<Scalar<V>, T>)
    return w;
  else
    return __builtin_convertvector(w, V);
}

/// A group from any address aligned to sizeof(T).
template <class V, class T>
[[gnu::always_inline]] inline V load_group(const T* p) {
  Stored<T, V> w;
  std::memcpy(&w, p, sizeof w);
  return from_stored<V, T>(w);
}

/// A group to any address aligned to sizeof(T).
template <class V, class T>
[[gnu::always_inline]] inline void store_group(T* p, V v) {
  const Stored<T, V> w = to_stored<T>(v);
  std::memcpy(p, &w, sizeof w);
}

/// A group to an address aligned to sizeof(Stored<T, V>).
template <class V, class T>
[[gnu::always_inline]] inline void store_group_aligned(T* p, V v) {
  *static_cast<Stored<T, V>*>(__builtin_assume_aligned(p, sizeof(Stored<T, V>))) = to_stored<T>(v);
}

/// The first n < lanes_of<V> values from p; the others are 1 (a harmless density).
template <class V, class T>
inline V load_group_partial(const T* p, int n) {
  Stored<T, V> w = Stored<T, V>{} + T(1);
  std::memcpy(&w, p, sizeof(T) * unsigned(n));
  return from_stored<V, T>(w);
}

/// The first n < lanes_of<V> values of v to p.
template <class V, class T>
inline void store_group_partial(T* p, V v, int n) {
  const Stored<T, V> w = to_stored<T>(v);
  std::memcpy(p, &w, sizeof(T) * unsigned(n));
}

/// A group of one whole 64-byte line as stored, to an aligned p, with a non-temporal store
/// (an ordinary one where the target has none).
template <class V, class T>
[[gnu::always_inline]] inline void store_group_stream(T* p, V v) {
  static_assert(sizeof(Stored<T, V>) == 64, "non-temporal group stores are whole lines");
#if defined(__AVX512F__)
  const Stored<T, V> w = to_stored<T>(v);
  _mm512_stream_si512(static_cast<__m512i*>(__builtin_assume_aligned(static_cast<void*>(p), 64)),
                      reinterpret_cast<const __m512i&>(w));
#else
  store_group_aligned(p, v);
#endif
}

// ---- The half store (Precision::Half, fluid/lattice/half.hpp): a LanesFloat group stored as
// the binary16 codes of (f - w) 2^15, w the population's weight. Converted by F16C where the
// level has it (x86-64-v4: 16 values, v3: 8 an instruction), else by the portable conversion
// of half.hpp on the level's vectors: the same bits (rounded to nearest, ties to even).

template <class V>
struct StoredGroup<Half16, V> {
  typedef std::uint16_t type __attribute__((vector_size(lanes_of<V> * sizeof(Half16))));
};

/// The codes of a group, as stored.
using HalfCodes = Stored<Half16, LanesFloat>;

/// binary16 of each float of x (to nearest, ties to even).
[[gnu::always_inline]] inline HalfCodes binary16_of(LanesFloat x) {
#if defined(__AVX512F__)
  return __builtin_bit_cast(HalfCodes, _mm512_cvtps_ph(__builtin_bit_cast(__m512, x), _MM_FROUND_TO_NEAREST_INT));
#elif defined(__AVX__) && defined(__F16C__)
  return __builtin_bit_cast(HalfCodes, _mm256_cvtps_ph(__builtin_bit_cast(__m256, x), _MM_FROUND_TO_NEAREST_INT));
#else
  using U = std::uint32_t __attribute__((vector_size(sizeof(LanesFloat))));
  return __builtin_convertvector(binary16_bits_of_float_bits<U, LanesFloat>(__builtin_bit_cast(U, x)), HalfCodes);
#endif
}

/// The floats of binary16 codes (exact).
[[gnu::always_inline]] inline LanesFloat float_of(HalfCodes h) {
#if defined(__AVX512F__)
  return __builtin_bit_cast(LanesFloat, _mm512_cvtph_ps(__builtin_bit_cast(__m256i, h)));
#elif defined(__AVX__) && defined(__F16C__)
  return __builtin_bit_cast(LanesFloat, _mm256_cvtph_ps(__builtin_bit_cast(__m128i, h)));
#else
  using U = std::uint32_t __attribute__((vector_size(sizeof(LanesFloat))));
  return __builtin_bit_cast(LanesFloat, float_bits_of_binary16_bits<U, LanesFloat>(__builtin_convertvector(h, U)));
#endif
}

// A population's group in the kernel: loads and stores of population q's values (shift
// w = its weight, in the arithmetic's type). The double and float stores ignore w (as
// load_group and store_group: the same bits); the half store decodes f = code 2^-15 + w and
// encodes (f - w) 2^15, in float.

/// The group as stored.
template <class T, class V>
[[gnu::always_inline]] inline Stored<T, V> to_stored_pop(V v, Scalar<V> w) {
  if constexpr (std::is_same_v<T, Half16>) {
    static_assert(std::is_same_v<V, LanesFloat>, "the half store computes in float");
    return binary16_of((v - w) * kHalfScale);
  } else {
    (void)w;
    return to_stored<T>(v);
  }
}

template <class V, class T>
[[gnu::always_inline]] inline V from_stored_pop(Stored<T, V> s, Scalar<V> w) {
  if constexpr (std::is_same_v<T, Half16>) {
    static_assert(std::is_same_v<V, LanesFloat>, "the half store computes in float");
    return float_of(s) * kHalfUnscale + w;
  } else {
    (void)w;
    return from_stored<V, T>(s);
  }
}

/// A group from any address aligned to sizeof(T).
template <class V, class T>
[[gnu::always_inline]] inline V load_pop(const T* p, Scalar<V> w) {
  Stored<T, V> s;
  std::memcpy(&s, p, sizeof s);
  return from_stored_pop<V, T>(s, w);
}

/// A group to any address aligned to sizeof(T).
template <class V, class T>
[[gnu::always_inline]] inline void store_pop(T* p, V v, Scalar<V> w) {
  const Stored<T, V> s = to_stored_pop<T>(v, w);
  std::memcpy(p, &s, sizeof s);
}

/// A group to an address aligned to sizeof(Stored<T, V>).
template <class V, class T>
[[gnu::always_inline]] inline void store_pop_aligned(T* p, V v, Scalar<V> w) {
  *static_cast<Stored<T, V>*>(__builtin_assume_aligned(static_cast<void*>(p), sizeof(Stored<T, V>))) =
      to_stored_pop<T>(v, w);
}

/// The first n < lanes_of<V> values from p; the others harmless (load_group_partial: 1; the
/// half store: w, the rest state's population).
template <class V, class T>
inline V load_pop_partial(const T* p, int n, Scalar<V> w) {
  if constexpr (std::is_same_v<T, Half16>) {
    Stored<T, V> s{};
    std::memcpy(&s, p, sizeof(T) * unsigned(n));
    return from_stored_pop<V, T>(s, w);
  } else {
    (void)w;
    return load_group_partial<V>(p, n);
  }
}

/// The first n < lanes_of<V> values of v to p.
template <class V, class T>
inline void store_pop_partial(T* p, V v, int n, Scalar<V> w) {
  const Stored<T, V> s = to_stored_pop<T>(v, w);
  std::memcpy(p, &s, sizeof(T) * unsigned(n));
}

/// One 64-byte line of codes from an aligned buffer to an aligned p (store_stream_line).
inline void store_stream_line(Half16* p, const Half16* line) {
  store_stream_line(reinterpret_cast<float*>(static_cast<void*>(p)),
                    reinterpret_cast<const float*>(static_cast<const void*>(line)));
}

}  // namespace cosim::fluid::COSIM_ISA_NS
