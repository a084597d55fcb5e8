// The aarch64 Advanced SIMD (NEON) GEMM micro-kernel (8 x 12 tile: 24 accumulator registers of
// the 32) and the element-wise loops of the forward pass written with NEON intrinsics. NEON is
// mandatory on aarch64, so these are chosen at compile time: SHADOWSENSE_NEON_KERNELS is 1 on
// aarch64 with GCC/Clang and the functions exist only there.
//
// micro_kernel_neon<Cols>(K, a, b, out): same contract as micro_kernel_reference<8, 12>
//   (gemm_reference.hpp), accumulated with fused multiply-add in k order, for the first Cols
//   (4, 8 or 12, the default) columns only: the other columns of out are not written. For a
//   last panel of at most 4 or 8 columns: the multiply-adds of those only.
// affine_relu_neon, bias_relu_neon, pack3x3_neon, pool_affine_relu_neon: same contracts as the
//   portable loops (gemm_portable.hpp, documented in gemm.hpp's VectorOps); ReLU is vmaxq_f32,
//   which propagates NaN like PyTorch's ReLU.
// No state; callable from any thread.
#pragma once

#include <shadowsense/core/version.hpp>

#if defined(__aarch64__) && defined(__ARM_NEON) && (defined(__GNUC__) || defined(__clang__))
#define SHADOWSENSE_NEON_KERNELS 1
#include <arm_neon.h>
#else
#define SHADOWSENSE_NEON_KERNELS 0
#endif

#if SHADOWSENSE_NEON_KERNELS
SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

template <int Cols = 12>
inline void micro_kernel_neon(int K, const float* a, const float* b, float* out) {
  static_assert(Cols == 4 || Cols == 8 || Cols == 12, "4, 8 or 12 columns");
  constexpr int NV = Cols / 4; // vectors a row; the others are neither computed nor stored
  const float32x4_t z = vdupq_n_f32(0.0f);
  float32x4_t c00 = z, c01 = z, c02 = z, c10 = z, c11 = z, c12 = z, c20 = z, c21 = z, c22 = z,
              c30 = z, c31 = z, c32 = z, c40 = z, c41 = z, c42 = z, c50 = z, c51 = z, c52 = z,
              c60 = z, c61 = z, c62 = z, c70 = z, c71 = z, c72 = z;
  for (int k = 0; k < K; ++k, a += 8, b += 12) {
    const float32x4_t b0 = vld1q_f32(b);
    const float32x4_t b1 = NV > 1 ? vld1q_f32(b + 4) : z, b2 = NV > 2 ? vld1q_f32(b + 8) : z;
    const float32x4_t a0 = vld1q_f32(a), a1 = vld1q_f32(a + 4);
#define SHADOWSENSE_NEON_ROW(R, A, L)                                                              \
  c##R##0 = vfmaq_laneq_f32(c##R##0, b0, A, L);                                                    \
  if constexpr (NV > 1) c##R##1 = vfmaq_laneq_f32(c##R##1, b1, A, L);                              \
  if constexpr (NV > 2) c##R##2 = vfmaq_laneq_f32(c##R##2, b2, A, L)
    SHADOWSENSE_NEON_ROW(0, a0, 0);
    SHADOWSENSE_NEON_ROW(1, a0, 1);
    SHADOWSENSE_NEON_ROW(2, a0, 2);
    SHADOWSENSE_NEON_ROW(3, a0, 3);
    SHADOWSENSE_NEON_ROW(4, a1, 0);
    SHADOWSENSE_NEON_ROW(5, a1, 1);
    SHADOWSENSE_NEON_ROW(6, a1, 2);
    SHADOWSENSE_NEON_ROW(7, a1, 3);
#undef SHADOWSENSE_NEON_ROW
  }
#define SHADOWSENSE_NEON_STORE(R)                                                                  \
  vst1q_f32(out + R * 12, c##R##0);                                                                \
  if constexpr (NV > 1) vst1q_f32(out + R * 12 + 4, c##R##1);                                      \
  if constexpr (NV > 2) vst1q_f32(out + R * 12 + 8, c##R##2)
  SHADOWSENSE_NEON_STORE(0);
  SHADOWSENSE_NEON_STORE(1);
  SHADOWSENSE_NEON_STORE(2);
  SHADOWSENSE_NEON_STORE(3);
  SHADOWSENSE_NEON_STORE(4);
  SHADOWSENSE_NEON_STORE(5);
  SHADOWSENSE_NEON_STORE(6);
  SHADOWSENSE_NEON_STORE(7);
#undef SHADOWSENSE_NEON_STORE
}

inline float relu_neon_scalar(float v) {
  return v < 0.0f ? 0.0f : v;
}

inline void affine_relu_neon(const float* s, float* d, int n, float sc, float sh) {
  const float32x4_t vsc = vdupq_n_f32(sc), vsh = vdupq_n_f32(sh), z = vdupq_n_f32(0.0f);
  int i = 0;
  for (; i + 4 <= n; i += 4)
    vst1q_f32(d + i, vmaxq_f32(vaddq_f32(vmulq_f32(vld1q_f32(s + i), vsc), vsh), z));
  for (; i < n; ++i) d[i] = relu_neon_scalar(s[i] * sc + sh);
}

inline void bias_relu_neon(const float* s, float* d, int n, float b) {
  const float32x4_t vb = vdupq_n_f32(b), z = vdupq_n_f32(0.0f);
  int i = 0;
  for (; i + 4 <= n; i += 4) vst1q_f32(d + i, vmaxq_f32(vaddq_f32(vld1q_f32(s + i), vb), z));
  for (; i < n; ++i) d[i] = relu_neon_scalar(s[i] + b);
}

inline void pack3x3_neon(const float* s, float* d, int cols, int nr, int pw) {
  for (int ky = 0; ky < 3; ++ky)
    for (int kx = 0; kx < 3; ++kx, d += nr) {
      const float* r = s + ky * pw + kx;
      int j = 0;
      for (; j + 4 <= cols; j += 4) vst1q_f32(d + j, vld1q_f32(r + j));
      for (; j < cols; ++j) d[j] = r[j];
      for (; j < nr; ++j) d[j] = 0.0f;
    }
}

inline void pool_affine_relu_neon(const float* r0, const float* r1, float* d, int n, float sc,
                                  float sh) {
  const float32x4_t vsc = vdupq_n_f32(sc), vsh = vdupq_n_f32(sh), z = vdupq_n_f32(0.0f),
                    q = vdupq_n_f32(0.25f);
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    const float32x4x2_t top = vld2q_f32(r0 + 2 * j), bottom = vld2q_f32(r1 + 2 * j);
    const float32x4_t a = vmaxq_f32(vaddq_f32(vmulq_f32(top.val[0], vsc), vsh), z);
    const float32x4_t b = vmaxq_f32(vaddq_f32(vmulq_f32(top.val[1], vsc), vsh), z);
    const float32x4_t c = vmaxq_f32(vaddq_f32(vmulq_f32(bottom.val[0], vsc), vsh), z);
    const float32x4_t e = vmaxq_f32(vaddq_f32(vmulq_f32(bottom.val[1], vsc), vsh), z);
    vst1q_f32(d + j, vmulq_f32(vaddq_f32(vaddq_f32(a, b), vaddq_f32(c, e)), q));
  }
  for (; j < n; ++j) {
    const float a = relu_neon_scalar(r0[2 * j] * sc + sh);
    const float b = relu_neon_scalar(r0[2 * j + 1] * sc + sh);
    const float c = relu_neon_scalar(r1[2 * j] * sc + sh);
    const float e = relu_neon_scalar(r1[2 * j + 1] * sc + sh);
    d[j] = ((a + b) + (c + e)) * 0.25f;
  }
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
#endif
