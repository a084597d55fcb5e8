// The portable GEMM micro-kernel and element-wise loops: plain C++ shaped so the compiler's
// auto-vectoriser turns them into SIMD code for whatever baseline the build targets (SSE2 on
// x86-64, Advanced SIMD on aarch64, anything else GCC/Clang vectorise for):
// - a fixed-size register block (MR x NR accumulators, NR a multiple of 4 lanes) held in a
//   local array the compiler keeps in registers, fully unrolled (#pragma GCC unroll) so it
//   vectorises at -O2 as well as -O3;
// - __restrict on every pointer (no aliasing between panels, tile and outputs);
// - unit-stride inner loops without branches in the loop body.
// The same op bodies are instantiated with x86 target attributes in gemm_x86.hpp.
//
// micro_kernel_portable<MR, NR>(K, a, b, out): same contract as micro_kernel_reference
//   (gemm_reference.hpp), accumulated in float in k order: out differs from the reference
//   only by float rounding.
// No state; callable from any thread.
#pragma once

#include <shadowsense/core/version.hpp>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

#define SHADOWSENSE_PRAGMA(x) _Pragma(#x)
#if defined(__clang__)
#define SHADOWSENSE_UNROLL(n) SHADOWSENSE_PRAGMA(unroll n)
#elif defined(__GNUC__)
#define SHADOWSENSE_UNROLL(n) SHADOWSENSE_PRAGMA(GCC unroll n)
#else
#define SHADOWSENSE_UNROLL(n)
#endif

template <int MR, int NR>
inline void micro_kernel_portable(int K, const float* __restrict a, const float* __restrict b,
                                  float* __restrict out) {
  static_assert(MR >= 1 && NR % 4 == 0, "the register block is whole 4-lane vectors wide");
  float acc[MR * NR];
  SHADOWSENSE_UNROLL(64)
  for (int i = 0; i < MR * NR; ++i) acc[i] = 0.0f;
  for (int k = 0; k < K; ++k, a += MR, b += NR) {
    SHADOWSENSE_UNROLL(16)
    for (int r = 0; r < MR; ++r) {
      const float x = a[r];
      SHADOWSENSE_UNROLL(32)
      for (int j = 0; j < NR; ++j) acc[r * NR + j] += x * b[j];
    }
  }
  SHADOWSENSE_UNROLL(64)
  for (int i = 0; i < MR * NR; ++i) out[i] = acc[i];
}

// Element-wise loops, one definition per instruction set (ATTR: a target attribute or empty).
// ReLU is (v < 0 ? 0 : v): NaN propagates, as in PyTorch.
#define SHADOWSENSE_DEFINE_VECTOR_OPS(SUFFIX, ATTR)                                                \
  ATTR inline void affine_relu_##SUFFIX(const float* __restrict s, float* __restrict d, int n,     \
                                        float sc, float sh) {                                      \
    for (int i = 0; i < n; ++i) {                                                                  \
      const float v = s[i] * sc + sh;                                                              \
      d[i] = v < 0.0f ? 0.0f : v;                                                                  \
    }                                                                                              \
  }                                                                                                \
  ATTR inline void bias_relu_##SUFFIX(const float* __restrict s, float* __restrict d, int n,       \
                                      float b) {                                                   \
    for (int i = 0; i < n; ++i) {                                                                  \
      const float v = s[i] + b;                                                                    \
      d[i] = v < 0.0f ? 0.0f : v;                                                                  \
    }                                                                                              \
  }                                                                                                \
  /* the 9 taps of a 3x3 convolution on the padded grid: row t = s[ky * pw + kx + j] */            \
  ATTR inline void pack3x3_##SUFFIX(const float* __restrict s, float* __restrict d, int cols,      \
                                    int nr, int pw) {                                              \
    for (int ky = 0; ky < 3; ++ky)                                                                 \
      for (int kx = 0; kx < 3; ++kx, d += nr) {                                                    \
        const float* __restrict r = s + ky * pw + kx;                                              \
        for (int j = 0; j < cols; ++j) d[j] = r[j];                                                \
        for (int j = cols; j < nr; ++j) d[j] = 0.0f;                                               \
      }                                                                                            \
  }                                                                                                \
  /* d[j] = mean of relu(affine) over the 2x2 window at columns 2j, 2j+1 of rows r0, r1 */         \
  ATTR inline void pool_affine_relu_##SUFFIX(const float* __restrict r0,                           \
                                             const float* __restrict r1, float* __restrict d,      \
                                             int n, float sc, float sh) {                          \
    for (int j = 0; j < n; ++j) {                                                                  \
      float a = r0[2 * j] * sc + sh, b = r0[2 * j + 1] * sc + sh;                                  \
      float c = r1[2 * j] * sc + sh, e = r1[2 * j + 1] * sc + sh;                                  \
      a = a < 0.0f ? 0.0f : a;                                                                     \
      b = b < 0.0f ? 0.0f : b;                                                                     \
      c = c < 0.0f ? 0.0f : c;                                                                     \
      e = e < 0.0f ? 0.0f : e;                                                                     \
      d[j] = ((a + b) + (c + e)) * 0.25f;                                                          \
    }                                                                                              \
  }

SHADOWSENSE_DEFINE_VECTOR_OPS(portable, )

} // namespace detail
SHADOWSENSE_NAMESPACE_END
