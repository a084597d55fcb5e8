// The reference GEMM micro-kernel and element-wise loops of the DenseNet forward pass: plain
// scalar loops written for obviousness, not speed. They are the oracle the per-CPU kernels
// (gemm_portable.hpp, gemm_x86.hpp, gemm_neon.hpp) are tested against, and a kernel the forward
// pass can run with (GemmKernelKind::reference).
//
// micro_kernel_reference<MR, NR>(K, a, b, out)
//   requires: a holds K x MR floats (row k = the MR panel rows' k-th weights, interleaved),
//             b holds K x NR floats (row k = the k-th input row of NR columns), out holds
//             MR x NR floats and overlaps neither.
//   ensures:  out[r * NR + j] = sum over k of a[k * MR + r] * b[k * NR + j], accumulated in
//             double and rounded once to float (more exact than any float kernel).
// The vector ops (affine_relu, bias_relu, pack3x3, pool_affine_relu) are documented in
// gemm.hpp (VectorOps); their reference versions carry the suffix _reference.
// ReLU is written as (v < 0 ? 0 : v) everywhere so a NaN propagates as it does in PyTorch.
// No state; callable from any thread.
#pragma once

#include <shadowsense/core/version.hpp>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

template <int MR, int NR>
inline void micro_kernel_reference(int K, const float* a, const float* b, float* out) {
  for (int r = 0; r < MR; ++r)
    for (int j = 0; j < NR; ++j) {
      double acc = 0.0;
      for (int k = 0; k < K; ++k)
        acc += double(a[static_cast<long>(k) * MR + r]) * double(b[static_cast<long>(k) * NR + j]);
      out[r * NR + j] = static_cast<float>(acc);
    }
}

inline float relu_reference(float v) {
  return v < 0.0f ? 0.0f : v;
}

inline void affine_relu_reference(const float* s, float* d, int n, float sc, float sh) {
  for (int i = 0; i < n; ++i) d[i] = relu_reference(s[i] * sc + sh);
}

inline void bias_relu_reference(const float* s, float* d, int n, float b) {
  for (int i = 0; i < n; ++i) d[i] = relu_reference(s[i] + b);
}

inline void pack3x3_reference(const float* s, float* d, int cols, int nr, int pw) {
  for (int ky = 0; ky < 3; ++ky)
    for (int kx = 0; kx < 3; ++kx, d += nr)
      for (int j = 0; j < nr; ++j) d[j] = j < cols ? s[ky * pw + kx + j] : 0.0f;
}

inline void pool_affine_relu_reference(const float* r0, const float* r1, float* d, int n, float sc,
                                       float sh) {
  for (int j = 0; j < n; ++j) {
    const float a = relu_reference(r0[2 * j] * sc + sh);
    const float b = relu_reference(r0[2 * j + 1] * sc + sh);
    const float c = relu_reference(r1[2 * j] * sc + sh);
    const float e = relu_reference(r1[2 * j + 1] * sc + sh);
    d[j] = ((a + b) + (c + e)) * 0.25f;
  }
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
