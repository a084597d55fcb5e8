// The portable GEMM micro-kernel and element-wise loops: C++ shaped so the compiler turns it
// into SIMD code for whatever baseline the build targets (SSE2 on x86-64, Advanced SIMD on
// aarch64, AVX/FMA when the build enables them, anything else GCC/Clang vectorise for):
// - a fixed-size register block of MR x NR accumulators; with GCC/Clang written as generic
//   vectors (__attribute__((vector_size)), which the compiler lowers to the target's SIMD
//   registers, or to scalar code where there are none), elsewhere as plain unrolled loops.
//   The dispatch uses portable_mr x portable_nr = 2 x 24 with 4-lane vectors (12 accumulators
//   + a broadcast + a temporary fit the 16 SSE registers with no spill; each k step costs 2
//   broadcasts per 12 vector multiply-adds), 4 x 24 with 8 lanes when __AVX__ is defined;
// - __restrict on every pointer (no aliasing between panels, tile and outputs);
// - unit-stride inner loops without branches in the loop body; the full-panel case of the
//   element-wise loops (n == portable_nr) inlined with a constant length.
// The same element-wise bodies (SHADOWSENSE_DEFINE_VECTOR_OPS) are instantiated with x86 target
// attributes in gemm_x86.hpp.
//
// micro_kernel_portable<MR, NR>(K, a, b, out): same contract as micro_kernel_reference
//   (gemm_reference.hpp), accumulated in float in k order (a multiply-add may be fused where
//   the target has FMA and the compiler contracts): out differs from the reference only by
//   float rounding.
// affine_relu_portable, bias_relu_portable, pool_affine_relu_portable, pack3x3_portable,
//   max_pool3s2_portable: the VectorOps contracts of gemm.hpp (any n, cols <= nr; exact copies
//   for pack3x3).
// portable_mr / portable_nr depend on __AVX__: build every translation unit of a program with
// the same instruction-set flags (as for any inline code).
// No state; callable from any thread.
#pragma once

#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <cstddef>
#include <cstring>

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

// Vector lanes of the portable kernel: 4 (16 bytes: SSE2, Advanced SIMD), 8 where the build
// enables AVX (e.g. -march=x86-64-v3).
#if defined(__AVX__)
inline constexpr int portable_lanes = 8;
#else
inline constexpr int portable_lanes = 4;
#endif

#if defined(__GNUC__) // GCC and Clang, any target: generic vectors
using PortableVec = float __attribute__((vector_size(portable_lanes * sizeof(float))));
#endif

template <int MR, int NR>
inline void micro_kernel_portable(int K, const float* __restrict a, const float* __restrict b,
                                  float* __restrict out) {
  static_assert(MR >= 1 && NR % 4 == 0, "the register block is whole 4-lane vectors wide");
#if defined(__GNUC__)
  // The block as MR x NV generic vectors: GCC's SLP vectoriser turns the equivalent scalar
  // loop into extra lane shuffles (a reversal per B vector and per accumulator) or worse; with
  // explicit vectors every step is one broadcast of a[r] and MR * NV vector multiply-adds.
  static_assert(NR % portable_lanes == 0, "the register block is whole vectors wide");
  constexpr int NV = NR / portable_lanes;
  PortableVec acc[MR][NV];
  SHADOWSENSE_UNROLL(16)
  for (int r = 0; r < MR; ++r) {
    SHADOWSENSE_UNROLL(16)
    for (int j = 0; j < NV; ++j) acc[r][j] = PortableVec{};
  }
  // One k step: acc[r][:] += a[r] * b[:].
  auto step = [&acc](const float* __restrict ak, const float* __restrict bk) {
    SHADOWSENSE_UNROLL(16)
    for (int r = 0; r < MR; ++r) {
      const float s = ak[r];
#if defined(__AVX__)
      const PortableVec x = {s, s, s, s, s, s, s, s};
#else
      const PortableVec x = {s, s, s, s};
#endif
      SHADOWSENSE_UNROLL(16)
      for (int j = 0; j < NV; ++j) {
        PortableVec v;
        std::memcpy(&v, bk + portable_lanes * j, sizeof v);
        acc[r][j] += x * v;
      }
    }
  };
  // Two k steps per iteration (still in k order): the loop bookkeeping is shared, which the
  // SSE2 front end notices (measured +5% on 2 x 24); four steps spill accumulators.
  int k = 0;
  for (; k + 2 <= K; k += 2, a += 2 * MR, b += 2 * NR) {
    step(a, b);
    step(a + MR, b + NR);
  }
  if (k < K) step(a, b);
  SHADOWSENSE_UNROLL(16)
  for (int r = 0; r < MR; ++r) {
    SHADOWSENSE_UNROLL(16)
    for (int j = 0; j < NV; ++j)
      std::memcpy(out + r * NR + portable_lanes * j, &acc[r][j], sizeof acc[r][j]);
  }
#else
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
#endif
}

// Element-wise loops, one definition per instruction set (ATTR: a target attribute or empty).
// ReLU is (v < 0 ? 0 : v): NaN propagates, as in PyTorch.
#define SHADOWSENSE_DEFINE_ELEMENTWISE_OPS(SUFFIX, ATTR)                                           \
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

#define SHADOWSENSE_DEFINE_PACK3X3(SUFFIX, ATTR)                                                   \
  /* the 9 taps of a 3x3 convolution on the padded grid: row t = s[ky * pw + kx + j] */            \
  ATTR inline void pack3x3_##SUFFIX(const float* __restrict s, float* __restrict d, int cols,      \
                                    int nr, int pw) {                                              \
    for (int ky = 0; ky < 3; ++ky)                                                                 \
      for (int kx = 0; kx < 3; ++kx, d += nr) {                                                    \
        const float* __restrict r = s + ky * pw + kx;                                              \
        for (int j = 0; j < cols; ++j) d[j] = r[j];                                                \
        for (int j = cols; j < nr; ++j) d[j] = 0.0f;                                               \
      }                                                                                            \
  }

#define SHADOWSENSE_DEFINE_VECTOR_OPS(SUFFIX, ATTR)                                                \
  SHADOWSENSE_DEFINE_ELEMENTWISE_OPS(SUFFIX, ATTR)                                                 \
  SHADOWSENSE_DEFINE_PACK3X3(SUFFIX, ATTR)

// The portable kernel's register block (gemm.hpp dispatches micro_kernel_portable<these>).
// 12 accumulators either way: 2 x (24 / 4) with 4 lanes, 4 x (24 / 8) with 8.
inline constexpr int portable_mr = portable_lanes == 8 ? 4 : 2;
inline constexpr int portable_nr = 24;

SHADOWSENSE_DEFINE_ELEMENTWISE_OPS(portable_any, )

inline void pool_affine_relu_portable(const float* __restrict r0, const float* __restrict r1,
                                      float* __restrict d, int n, float sc, float sh) {
  pool_affine_relu_portable_any(r0, r1, d, n, sc, sh);
}
// max_pool3s2: VectorOps' contract (gemm.hpp). Its loops are written for the compiler to
// vectorise (SHADOWSENSE_VECTORISE: at GCC's -O2 they ran scalar, pool0 2.5x its -O3 time).
SHADOWSENSE_VECTORISE inline void max_pool3s2_portable(const float* s, int h0, int w0, int bh,
                                                       int bw, float* vm, float* vs, float* dst) {
  for (int y = 0; y < bh; ++y) {
    const int y0 = std::max(2 * y - 1, 0), y1 = std::min(2 * y + 1, h0 - 1);
    const float* r = s + static_cast<std::size_t>(y0) * w0;
    for (int x = 0; x < w0; ++x) {
      vm[x] = r[x];
      vs[x] = r[x];
    }
    for (int iy = y0 + 1; iy <= y1; ++iy) {
      r = s + static_cast<std::size_t>(iy) * w0;
      for (int x = 0; x < w0; ++x) {
        vm[x] = std::max(vm[x], r[x]);
        vs[x] += r[x];
      }
    }
    float* d = dst + static_cast<std::size_t>(y) * bw;
    auto window = [&](int x) { // clipped at the image's edges
      const int x0 = std::max(2 * x - 1, 0), x1 = std::min(2 * x + 1, w0 - 1);
      float mx = vm[x0], nan_probe = vs[x0];
      for (int ix = x0 + 1; ix <= x1; ++ix) {
        mx = std::max(mx, vm[ix]);
        nan_probe += vs[ix];
      }
      return nan_probe == nan_probe ? mx : nan_probe;
    };
    // Windows with all three columns inside (2x + 1 <= w0 - 1) in a loop of fixed shape
    // the compiler vectorises; the same values in the same order as window(x).
    const int inner = std::min(bw, w0 / 2);
    int x = 0;
    for (; x < std::min(1, bw); ++x) d[x] = window(x);
    for (; x < inner; ++x) {
      const float mx = std::max(std::max(vm[2 * x - 1], vm[2 * x]), vm[2 * x + 1]);
      const float nan_probe = (vs[2 * x - 1] + vs[2 * x]) + vs[2 * x + 1];
      d[x] = nan_probe == nan_probe ? mx : nan_probe;
    }
    for (; x < bw; ++x) d[x] = window(x);
  }
}

// affine_relu / bias_relu mostly run on one full panel row (n == portable_nr): that case is
// inlined with a constant n (straight-line vector code, no loop tail).
inline void affine_relu_portable(const float* __restrict s, float* __restrict d, int n, float sc,
                                 float sh) {
  if (n == portable_nr)
    affine_relu_portable_any(s, d, portable_nr, sc, sh);
  else
    affine_relu_portable_any(s, d, n, sc, sh);
}
inline void bias_relu_portable(const float* __restrict s, float* __restrict d, int n, float b) {
  if (n == portable_nr)
    bias_relu_portable_any(s, d, portable_nr, b);
  else
    bias_relu_portable_any(s, d, n, b);
}

// pack3x3 for the portable kernel: a full panel (cols == nr == portable_nr, all but the last
// panel of a layer) is 9 fixed-size row copies the compiler inlines as vector moves; the
// generic loops become a library memcpy/memset call per row (18 calls per channel).
inline void pack3x3_portable(const float* __restrict s, float* __restrict d, int cols, int nr,
                             int pw) {
  if (cols == portable_nr && nr == portable_nr) {
    for (int ky = 0; ky < 3; ++ky)
      for (int kx = 0; kx < 3; ++kx, d += portable_nr)
        std::memcpy(d, s + ky * pw + kx, portable_nr * sizeof(float));
    return;
  }
  for (int ky = 0; ky < 3; ++ky)
    for (int kx = 0; kx < 3; ++kx, d += nr) {
      const float* __restrict r = s + ky * pw + kx;
      for (int j = 0; j < cols; ++j) d[j] = r[j];
      for (int j = cols; j < nr; ++j) d[j] = 0.0f;
    }
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
