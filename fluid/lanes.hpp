// A group of kLanes doubles processed as one SIMD value by the bulk kernel: a GCC/Clang
// vector type as wide as the target's vector registers (AVX-512: 8, AVX: 4, else 2).
// Arithmetic is elementwise; scalars broadcast.
#pragma once

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include <cstring>

namespace cosim::fluid {

#if defined(__AVX512F__)
constexpr int kLanes = 8;
#elif defined(__AVX__)
constexpr int kLanes = 4;
#else
constexpr int kLanes = 2;
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

}  // namespace cosim::fluid
