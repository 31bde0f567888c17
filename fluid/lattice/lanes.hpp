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

#include <cstring>

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

}  // namespace cosim::fluid::COSIM_ISA_NS
