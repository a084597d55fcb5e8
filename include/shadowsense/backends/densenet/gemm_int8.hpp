// The int8 GEMM of the DenseNet's quantised convolutions: int8 weights (rows) times unsigned
// 7-bit activations (columns), accumulated exactly in int32. Three kernels with one contract:
// the portable reference (plain loops), AVX2 (vpmaddubsw + vpmaddwd, chosen at run time when
// the CPU has AVX2), AVX-512 VNNI (vpdpbusd on 256-bit registers, chosen before AVX2 when the
// CPU has AVX512_VNNI and AVX512VL) and NEON (vmull_s8 / vmlal_s8 + vpadal, aarch64).
// vpdpbusd adds four u8 x s8 products into an int32 lane without saturation, so the VNNI kernel
// would be exact for 8-bit activations too; it keeps the 7-bit contract of the others.
//
// Why 7-bit activations: vpmaddubsw multiplies unsigned bytes by signed bytes and adds pairs
// into int16 with saturation. With activations in 0..127 and weights in -127..127 a pair sum is
// at most 2 x 127 x 127 = 32258 < 32767, so it never saturates and every kernel is exact; with
// 8-bit activations (255 x 127 x 2 = 64770) it would saturate and differ from the reference.
// The same bound lets NEON add two int8 x int8 products in one int16 lane (vmlal_s8). The
// DenseNet's conv inputs follow a ReLU, so they are >= 0 and unsigned codes lose no sign bit.
//
// gemm_s8u7_<kind>(w, m, x, n, kp, c, ldc)
//   requires: w holds m rows of kp int8 values in -127..127; x holds n rows of kp uint8 values
//             in 0..127 (row j = column j of the product: one pixel's inputs, contiguous);
//             kp a positive multiple of int8_k_align (pad both with zeros); c holds m rows of
//             ldc >= n int32 and overlaps neither.
//   ensures:  c[i * ldc + j] = sum over k of w[i * kp + k] * x[j * kp + k], exactly (every
//             kernel gives the same bits). Values outside the ranges are undefined behaviour
//             of the result (never of memory): the callers quantise into the ranges.
// int8_code(x, inv_scale) -> 0..127
//   requires: x >= 0 (a ReLU output) or NaN.
//   ensures:  min(127, floor(x * inv_scale + 0.5)) as float arithmetic computes it; NaN gives
//             127 (callers that must see a NaN test for it themselves). The one rounding rule
//             of every activation quantisation (DenseNet's int8 path and the reference).
// select_int8_gemm(kind) -> Int8Gemm: the kernel of that kind (automatic: the fastest this CPU
//   runs); InvalidArgument when the kind is not available on this CPU.
// No state; callable from any thread.
#pragma once

#include <shadowsense/backends/densenet/gemm.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

inline constexpr int int8_k_align = 32;     // kp is a multiple of this (one AVX2 register)
inline constexpr int int8_act_max = 127;    // activation codes 0..127 (see the header comment)
inline constexpr int int8_weight_max = 127; // weight codes -127..127

inline int int8_padded_k(int k) {
  return (k + int8_k_align - 1) / int8_k_align * int8_k_align;
}

inline std::uint8_t int8_code(float x, float inv_scale) {
  const float q = x * inv_scale + 0.5f;
  return q < float(int8_act_max) ? static_cast<std::uint8_t>(q) : std::uint8_t(int8_act_max);
}

using Int8GemmFn = void (*)(const std::int8_t* w, int m, const std::uint8_t* x, int n, int kp,
                            std::int32_t* c, std::size_t ldc);

inline void gemm_s8u7_reference(const std::int8_t* w, int m, const std::uint8_t* x, int n, int kp,
                                std::int32_t* c, std::size_t ldc) {
  for (int i = 0; i < m; ++i) {
    const std::int8_t* wr = w + static_cast<std::size_t>(i) * kp;
    for (int j = 0; j < n; ++j) {
      const std::uint8_t* xr = x + static_cast<std::size_t>(j) * kp;
      std::int32_t acc = 0;
      for (int k = 0; k < kp; ++k) acc += std::int32_t(wr[k]) * std::int32_t(xr[k]);
      c[static_cast<std::size_t>(i) * ldc + j] = acc;
    }
  }
}

#if SHADOWSENSE_X86_KERNELS
__attribute__((target("avx2"))) inline std::int32_t int8_hsum_avx2(__m256i v) {
  __m128i s = _mm_add_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0x4e));
  s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0xb1));
  return _mm_cvtsi128_si32(s);
}

// acc + the 16 u7 x s8 pair sums of xv, wv (exact: see the header comment) widened to int32.
__attribute__((target("avx2"))) inline __m256i int8_madd_avx2(__m256i acc, __m256i xv, __m256i wv,
                                                              __m256i ones) {
  return _mm256_add_epi32(acc, _mm256_madd_epi16(_mm256_maddubs_epi16(xv, wv), ones));
}

// Rows weight rows (w0, K apart) x 2 pixels (x0, x1) into c (rows ldc apart, 2 columns): the
// block of gemm_s8u7_avx2 (Rows = 4: 8 accumulators, 6 operand registers) and its remainder
// rows (Rows = 1). The loops over Rows have constant bounds and unroll to straight code.
template <std::size_t Rows>
__attribute__((target("avx2"))) inline void
int8_rows_x2_avx2(const std::int8_t* w0, const std::uint8_t* x0, const std::uint8_t* x1,
                  std::size_t K, std::int32_t* c, std::size_t ldc) {
  const __m256i ones = _mm256_set1_epi16(1);
  __m256i a[Rows][2];
  for (std::size_t r = 0; r < Rows; ++r) a[r][0] = a[r][1] = _mm256_setzero_si256();
  for (std::size_t k = 0; k < K; k += 32) {
    const __m256i p0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x0 + k));
    const __m256i p1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x1 + k));
    for (std::size_t r = 0; r < Rows; ++r) {
      const __m256i wr = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(w0 + r * K + k));
      a[r][0] = int8_madd_avx2(a[r][0], p0, wr, ones);
      a[r][1] = int8_madd_avx2(a[r][1], p1, wr, ones);
    }
  }
  for (std::size_t r = 0; r < Rows; ++r) {
    c[r * ldc] = int8_hsum_avx2(a[r][0]);
    c[r * ldc + 1] = int8_hsum_avx2(a[r][1]);
  }
}

// 4 weight rows x 2 pixels per step, remainders one row or one pixel at a time with the same
// instructions.
__attribute__((target("avx2"))) inline void gemm_s8u7_avx2(const std::int8_t* w, int m,
                                                           const std::uint8_t* x, int n, int kp,
                                                           std::int32_t* c, std::size_t ldc) {
  const __m256i ones = _mm256_set1_epi16(1);
#define madd(acc, xv, wv) int8_madd_avx2(acc, xv, wv, ones)
#define load(p) _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))
  const std::size_t K = static_cast<std::size_t>(kp);
  int j = 0;
  for (; j + 2 <= n; j += 2) {
    const std::uint8_t* x0 = x + j * K;
    const std::uint8_t* x1 = x0 + K;
    std::int32_t* cj = c + j;
    int i = 0;
    for (; i + 4 <= m; i += 4)
      int8_rows_x2_avx2<4>(w + i * K, x0, x1, K, cj + static_cast<std::size_t>(i) * ldc, ldc);
    for (; i < m; ++i)
      int8_rows_x2_avx2<1>(w + i * K, x0, x1, K, cj + static_cast<std::size_t>(i) * ldc, ldc);
  }
  for (; j < n; ++j) {
    const std::uint8_t* x0 = x + j * K;
    for (int i = 0; i < m; ++i) {
      const std::int8_t* w0 = w + i * K;
      __m256i a0 = _mm256_setzero_si256();
      for (std::size_t k = 0; k < K; k += 32) a0 = madd(a0, load(x0 + k), load(w0 + k));
      c[static_cast<std::size_t>(i) * ldc + j] = int8_hsum_avx2(a0);
    }
  }
#undef madd
#undef load
}

// AVX-512 VNNI on 256-bit registers (kp is a multiple of 32, one register): Rows weight rows x
// Pix pixels (Pix = 4 or 1) per block, Rows x Pix int32 accumulators of eight lanes each.
#define SHADOWSENSE_VNNI __attribute__((target("avx2,avx512f,avx512vl,avx512vnni")))

// The four pixels' sums of a row, from their four accumulators: pairwise adds within 128-bit
// lanes, then the two halves.
SHADOWSENSE_VNNI inline __m128i int8_hsum4_vnni(__m256i a0, __m256i a1, __m256i a2, __m256i a3) {
  const __m256i h = _mm256_hadd_epi32(_mm256_hadd_epi32(a0, a1), _mm256_hadd_epi32(a2, a3));
  return _mm_add_epi32(_mm256_castsi256_si128(h), _mm256_extracti128_si256(h, 1));
}

template <std::size_t Rows, std::size_t Pix>
SHADOWSENSE_VNNI inline void int8_block_vnni(const std::int8_t* w0, const std::uint8_t* x0,
                                             std::size_t K, std::int32_t* c, std::size_t ldc) {
  static_assert(Pix == 4 || Pix == 1);
  __m256i a[Rows][Pix];
  for (std::size_t r = 0; r < Rows; ++r)
    for (std::size_t p = 0; p < Pix; ++p) a[r][p] = _mm256_setzero_si256();
  for (std::size_t k = 0; k < K; k += 32) {
    __m256i xv[Pix];
    for (std::size_t p = 0; p < Pix; ++p)
      xv[p] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x0 + p * K + k));
    for (std::size_t r = 0; r < Rows; ++r) {
      const __m256i wr = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(w0 + r * K + k));
      for (std::size_t p = 0; p < Pix; ++p) a[r][p] = _mm256_dpbusd_epi32(a[r][p], xv[p], wr);
    }
  }
  for (std::size_t r = 0; r < Rows; ++r) {
    if constexpr (Pix == 4)
      _mm_storeu_si128(reinterpret_cast<__m128i*>(c + r * ldc),
                       int8_hsum4_vnni(a[r][0], a[r][1], a[r][2], a[r][3]));
    else
      c[r * ldc] = int8_hsum_avx2(a[r][0]);
  }
}

// Every weight row against Pix pixels from pixel j: blocks of 4 rows, then one at a time.
template <std::size_t Pix>
SHADOWSENSE_VNNI inline void int8_rows_vnni(const std::int8_t* w, int m, const std::uint8_t* x,
                                            int j, std::size_t K, std::int32_t* c,
                                            std::size_t ldc) {
  int i = 0;
  for (; i + 4 <= m; i += 4)
    int8_block_vnni<4, Pix>(w + i * K, x + j * K, K, c + static_cast<std::size_t>(i) * ldc + j,
                            ldc);
  for (; i < m; ++i)
    int8_block_vnni<1, Pix>(w + i * K, x + j * K, K, c + static_cast<std::size_t>(i) * ldc + j,
                            ldc);
}

// 4 weight rows x 4 pixels per step (16 accumulators, 4 pixel and 1 weight register of the 32),
// remainders one row or one pixel at a time with the same instructions.
SHADOWSENSE_VNNI inline void gemm_s8u7_vnni(const std::int8_t* w, int m, const std::uint8_t* x,
                                            int n, int kp, std::int32_t* c, std::size_t ldc) {
  const std::size_t K = static_cast<std::size_t>(kp);
  int j = 0;
  for (; j + 4 <= n; j += 4) int8_rows_vnni<4>(w, m, x, j, K, c, ldc);
  for (; j < n; ++j) int8_rows_vnni<1>(w, m, x, j, K, c, ldc);
}
#undef SHADOWSENSE_VNNI
#endif

#if SHADOWSENSE_NEON_KERNELS
// One 16-byte step: two int8 x int8 products per int16 lane (|sum| <= 32258, see the header
// comment), then pairwise into the int32 accumulator. Activations 0..127 are valid int8.
inline int32x4_t int8_madd_neon(int32x4_t acc, int8x16_t xv, int8x16_t wv) {
  int16x8_t p = vmull_s8(vget_low_s8(xv), vget_low_s8(wv));
  p = vmlal_high_s8(p, xv, wv);
  return vpadalq_s16(acc, p);
}

// 4 weight rows x 2 pixels per step, remainders one row or one pixel at a time.
inline void gemm_s8u7_neon(const std::int8_t* w, int m, const std::uint8_t* x, int n, int kp,
                           std::int32_t* c, std::size_t ldc) {
  const std::size_t K = static_cast<std::size_t>(kp);
  auto lx = [](const std::uint8_t* p) { return vreinterpretq_s8_u8(vld1q_u8(p)); };
  int j = 0;
  for (; j + 2 <= n; j += 2) {
    const std::uint8_t* x0 = x + j * K;
    const std::uint8_t* x1 = x0 + K;
    int i = 0;
    for (; i + 4 <= m; i += 4) {
      const std::int8_t* w0 = w + i * K;
      int32x4_t a00 = vdupq_n_s32(0), a01 = a00, a10 = a00, a11 = a00, a20 = a00, a21 = a00,
                a30 = a00, a31 = a00;
      for (std::size_t k = 0; k < K; k += 16) {
        const int8x16_t p0 = lx(x0 + k), p1 = lx(x1 + k);
        const int8x16_t r0 = vld1q_s8(w0 + k), r1 = vld1q_s8(w0 + K + k),
                        r2 = vld1q_s8(w0 + 2 * K + k), r3 = vld1q_s8(w0 + 3 * K + k);
        a00 = int8_madd_neon(a00, p0, r0);
        a01 = int8_madd_neon(a01, p1, r0);
        a10 = int8_madd_neon(a10, p0, r1);
        a11 = int8_madd_neon(a11, p1, r1);
        a20 = int8_madd_neon(a20, p0, r2);
        a21 = int8_madd_neon(a21, p1, r2);
        a30 = int8_madd_neon(a30, p0, r3);
        a31 = int8_madd_neon(a31, p1, r3);
      }
      std::int32_t* cr = c + static_cast<std::size_t>(i) * ldc + j;
      cr[0] = vaddvq_s32(a00);
      cr[1] = vaddvq_s32(a01);
      cr[ldc] = vaddvq_s32(a10);
      cr[ldc + 1] = vaddvq_s32(a11);
      cr[2 * ldc] = vaddvq_s32(a20);
      cr[2 * ldc + 1] = vaddvq_s32(a21);
      cr[3 * ldc] = vaddvq_s32(a30);
      cr[3 * ldc + 1] = vaddvq_s32(a31);
    }
    for (; i < m; ++i) {
      const std::int8_t* w0 = w + i * K;
      int32x4_t a0 = vdupq_n_s32(0), a1 = a0;
      for (std::size_t k = 0; k < K; k += 16) {
        const int8x16_t r0 = vld1q_s8(w0 + k);
        a0 = int8_madd_neon(a0, lx(x0 + k), r0);
        a1 = int8_madd_neon(a1, lx(x1 + k), r0);
      }
      c[static_cast<std::size_t>(i) * ldc + j] = vaddvq_s32(a0);
      c[static_cast<std::size_t>(i) * ldc + j + 1] = vaddvq_s32(a1);
    }
  }
  for (; j < n; ++j) {
    const std::uint8_t* x0 = x + j * K;
    for (int i = 0; i < m; ++i) {
      const std::int8_t* w0 = w + i * K;
      int32x4_t a0 = vdupq_n_s32(0);
      for (std::size_t k = 0; k < K; k += 16) a0 = int8_madd_neon(a0, lx(x0 + k), vld1q_s8(w0 + k));
      c[static_cast<std::size_t>(i) * ldc + j] = vaddvq_s32(a0);
    }
  }
}
#endif

enum class Int8KernelKind { automatic, reference, avx2, neon, vnni };

struct Int8Gemm {
  Int8KernelKind kind = Int8KernelKind::reference;
  const char* name = "int8-reference";
  Int8GemmFn fn = gemm_s8u7_reference;
};

inline bool cpu_has_int8(Int8KernelKind kind) {
  switch (kind) {
  case Int8KernelKind::automatic:
  case Int8KernelKind::reference:
    return true;
  case Int8KernelKind::avx2:
#if SHADOWSENSE_X86_KERNELS
    return __builtin_cpu_supports("avx2");
#else
    return false;
#endif
  case Int8KernelKind::neon:
    return SHADOWSENSE_NEON_KERNELS != 0;
  case Int8KernelKind::vnni:
#if SHADOWSENSE_X86_KERNELS
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512f") &&
           __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512vnni");
#else
    return false;
#endif
  }
  return false;
}

inline Int8Gemm select_int8_gemm(Int8KernelKind kind) {
  if (kind == Int8KernelKind::automatic) {
    if (cpu_has_int8(Int8KernelKind::vnni))
      kind = Int8KernelKind::vnni;
    else if (cpu_has_int8(Int8KernelKind::avx2))
      kind = Int8KernelKind::avx2;
    else if (cpu_has_int8(Int8KernelKind::neon))
      kind = Int8KernelKind::neon;
    else
      kind = Int8KernelKind::reference;
  }
  require(cpu_has_int8(kind), "select_int8_gemm: the requested int8 kernel (" +
                                  std::to_string(static_cast<int>(kind)) +
                                  ") is not available on this CPU");
#if SHADOWSENSE_X86_KERNELS
  if (kind == Int8KernelKind::avx2) return {kind, "int8-avx2", gemm_s8u7_avx2};
  if (kind == Int8KernelKind::vnni) return {kind, "int8-vnni", gemm_s8u7_vnni};
#endif
#if SHADOWSENSE_NEON_KERNELS
  if (kind == Int8KernelKind::neon) return {kind, "int8-neon", gemm_s8u7_neon};
#endif
  return {};
}

// The kernels this CPU runs, reference first.
inline std::vector<Int8KernelKind> available_int8_kernels() {
  std::vector<Int8KernelKind> out;
  for (auto k : {Int8KernelKind::reference, Int8KernelKind::avx2, Int8KernelKind::vnni,
                 Int8KernelKind::neon})
    if (cpu_has_int8(k)) out.push_back(k);
  return out;
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
