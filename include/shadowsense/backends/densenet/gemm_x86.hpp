// The x86-64 GEMM micro-kernels (AVX-512: 8 x 32 tile, AVX2+FMA: 4 x 24 tile) and the
// element-wise loops compiled for those instruction sets. Each function carries a
// function-level target attribute, so the library needs no -march flag; gemm.hpp picks one at
// run time after checking the CPU (__builtin_cpu_supports). Compiled only with GCC/Clang on
// x86 (SHADOWSENSE_X86_KERNELS is 1), empty elsewhere.
//
// micro_kernel_avx512(K, a, b, out), micro_kernel_avx2(K, a, b, out): same contract as
//   micro_kernel_reference<8, 32> and <4, 24> (gemm_reference.hpp), accumulated with FMA in k
//   order; require the CPU to support the instruction set (undefined behaviour otherwise: call
//   them only through gemm.hpp's selection).
// micro_kernel_avx2_in_place(K, a, b, offsets, out): micro_kernel_avx2 with B row k read in
//   place at b + offsets[k] (24 readable floats each) instead of from a packed panel.
// micro_kernel_avx2_cols<Cols>(K, a, b, out), Cols = 8 or 16: micro_kernel_avx2 for the first
//   Cols columns only (B rows still 24 floats apart); the other columns of out are not
//   written. For a last panel of at most Cols columns: the multiply-adds of those only.
// micro_kernel_avx512_cols<Cols, MR>(K, a, b, out), Cols = 8, 16, 24 or 32: as
//   micro_kernel_avx512 for the first Cols columns and MR (8 or 4) rows only (B rows and A
//   panels still 32 and 8 floats apart); the other columns and rows of out are not written.
//   For a last panel of at most Cols columns or a last row panel of at most 4 rows (12 output
//   channels: 8 + 4): the multiply-adds of those columns only, the same values. An 8-column
//   part runs on 256-bit vectors: a core that splits 512-bit operations in two (AMD Zen 4)
//   issues those at twice the rate, so 24 columns cost three quarters of 32.
// micro_kernel_avx512_fused<Cols, MR>(K, a, rows, dest): the MR x Cols block (Cols = 8, 16, 24
//   or 32, MR = 8 or 4 of the A panel's 8 rows; MR defaults to 8) over B
//   rows rows(k) (PackedRows or OffsetRows), accumulated with FMA in k order, then written
//   from the registers to dest (TileDest) instead of to a tile: row r < dest.rows gets
//   dest.bias[r] added (when bias is set) and ReLU (when relu), and column j goes to
//   dest.dst + r * dest.row_stride + seg.offset[s] + j for the segment s whose mask has bit j.
//   Columns in no segment are dropped; columns >= Cols are not written.
//   requires: segments disjoint, every written address valid; mask bits >= Cols clear; the
//   CPU has AVX-512 F and VL and FMA (cpu_has(GemmKernelKind::avx512) in gemm.hpp).
// micro_kernel_avx512_fused_fit(cols, K, a, rows, dest): the fused kernel of the least width
//   (8, 16, 24 or 32) and height (4 or 8) covering cols columns and dest.rows rows.
// micro_kernel_avx512_pixel_rows<Cols, MR>(K, a, b, dest): the transposed product, pixels on
//   the rows: the MR x Cols block (MR = 8 or 4 pixels, Cols = 16 or 32 output channels) of
//   sum_k a[k * 32 + r] * b[k * 32 + j] (a: columns of a packed K x 32 input panel, 32 floats
//   apart; b: a K x 32 weight panel), accumulated with FMA in k order, + dest.bias[j] (when
//   set), ReLU (when relu); channel j < dest.rows goes to dest.dst + j * dest.row_stride, its
//   pixel r to seg.offset[s] + r for the segment s whose mask has bit r (masks of 8 bits).
//   Each output has the bits micro_kernel_avx512_fused gives it with the weights on the rows.
//   micro_kernel_avx512_pixel_rows_fit(pixels, K, a, b, dest): the least width and height.
// TileSegments: how a tile's columns map to destination offsets (at most 33 runs: a 32-column
//   panel crosses at most 32 row ends). Plain data, defined for every target.
// pack_affine_relu_avx2: VectorOps::pack_affine_relu (gemm.hpp) with AVX2 + FMA, the values of
//   affine_relu_avx2.
// max_pool3s2_avx512: VectorOps::max_pool3s2 (gemm.hpp), the bits of max_pool3s2_portable.
// No state; callable from any thread.
#pragma once

#include <shadowsense/backends/densenet/gemm_portable.hpp>
#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define SHADOWSENSE_X86_KERNELS 1
#include <immintrin.h>
#else
#define SHADOWSENSE_X86_KERNELS 0
#endif

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

// Runs of a tile's columns and where each goes (see the header comment).
struct TileSegments {
  static constexpr int max_runs = 33;
  int count = 0;
  std::uint32_t mask[max_runs] = {};    // bit j: column j belongs to this run
  std::ptrdiff_t offset[max_runs] = {}; // column j of the run goes to row + offset + j
};

// Where a fused kernel writes its rows.
struct TileDest {
  float* dst = nullptr;        // row 0 of the tile's destination
  std::size_t row_stride = 0;  // floats from one row to the next
  const float* bias = nullptr; // per row, or none
  bool relu = false;
  int rows = 0; // rows written (the rest of the 8 are padding of the last row panel)
  const TileSegments* segments = nullptr;
};

#if SHADOWSENSE_X86_KERNELS
// Rows of a packed K x 32 (or K x Stride) panel, and rows read in place at b + offsets[k] (the
// fused kernel on the zero-padded grid of a 3x3 convolution: offsets[c * 9 + ky * 3 + kx] = c *
// plane + ky * pw
// + kx, so no B panel is packed).
template <int Stride>
struct PackedRowsOf {
  const float* b;
  const float* operator()(int k) const { return b + static_cast<std::ptrdiff_t>(k) * Stride; }
};
using PackedRows = PackedRowsOf<32>;
struct OffsetRows {
  const float* b;
  const int* offsets;
  const float* operator()(int k) const { return b + offsets[k]; }
};

// The target of the AVX-512 GEMM kernels: VL and FMA for the 256-bit part of a 24- or
// 8-column block.
#define SHADOWSENSE_AVX512_GEMM_TARGET __attribute__((target("avx512f,avx512vl,fma")))

// The fused kernel (see the header comment). The accumulators are arrays the unrolled loops
// index with constants only, so they live in registers (8 x Cols / 16 of the 32).
template <int Cols, int MR = 8, class RowB>
SHADOWSENSE_AVX512_GEMM_TARGET inline void
micro_kernel_avx512_fused(int K, const float* a, RowB row_b, const TileDest& dest) {
  static_assert(Cols == 8 || Cols == 16 || Cols == 24 || Cols == 32, "8 to 32 columns");
  static_assert(MR == 8 || MR == 4, "8 or the first 4 of the A panel's 8 rows");
  constexpr int panel_rows = 8;            // A's panel height whatever MR
  constexpr int NV = Cols / 16;            // 512-bit vectors a row
  constexpr bool quarter = Cols % 16 != 0; // and one 256-bit vector after them
  __m512 c[MR][NV > 0 ? NV : 1];
  __m256 q[MR];
  SHADOWSENSE_UNROLL(8)
  for (int r = 0; r < MR; ++r) {
    SHADOWSENSE_UNROLL(2)
    for (int v = 0; v < NV; ++v) c[r][v] = _mm512_setzero_ps();
    q[r] = _mm256_setzero_ps();
  }
  for (int k = 0; k < K; ++k, a += panel_rows) {
    const float* bk = row_b(k);
    __m512 b[NV > 0 ? NV : 1];
    SHADOWSENSE_UNROLL(2)
    for (int v = 0; v < NV; ++v) b[v] = _mm512_loadu_ps(bk + 16 * v);
    const __m256 bq = quarter ? _mm256_loadu_ps(bk + 16 * NV) : _mm256_setzero_ps();
    SHADOWSENSE_UNROLL(8)
    for (int r = 0; r < MR; ++r) {
      if constexpr (NV > 0) {
        const __m512 x = _mm512_set1_ps(a[r]);
        SHADOWSENSE_UNROLL(2)
        for (int v = 0; v < NV; ++v) c[r][v] = _mm512_fmadd_ps(x, b[v], c[r][v]);
      }
      if constexpr (quarter) q[r] = _mm256_fmadd_ps(_mm256_set1_ps(a[r]), bq, q[r]);
    }
  }
  const __m512 z = _mm512_setzero_ps();
  const __m256 zq = _mm256_setzero_ps();
  const TileSegments& seg = *dest.segments;
  SHADOWSENSE_UNROLL(8)
  for (int r = 0; r < MR; ++r) {
    if (r >= dest.rows) break;
    if (dest.bias) {
      SHADOWSENSE_UNROLL(2)
      for (int v = 0; v < NV; ++v) c[r][v] = _mm512_add_ps(c[r][v], _mm512_set1_ps(dest.bias[r]));
      if constexpr (quarter) q[r] = _mm256_add_ps(q[r], _mm256_set1_ps(dest.bias[r]));
    }
    if (dest.relu) { // max(0, v) keeps a NaN (the second operand), as relu_reference does
      SHADOWSENSE_UNROLL(2)
      for (int v = 0; v < NV; ++v) c[r][v] = _mm512_maskz_max_ps(0xFFFF, z, c[r][v]);
      if constexpr (quarter) q[r] = _mm256_maskz_max_ps(0xFF, zq, q[r]);
    }
    float* row =
        dest.dst + static_cast<std::ptrdiff_t>(r) * static_cast<std::ptrdiff_t>(dest.row_stride);
    for (int s = 0; s < seg.count; ++s) {
      float* p = row + seg.offset[s];
      SHADOWSENSE_UNROLL(2)
      for (int v = 0; v < NV; ++v)
        _mm512_mask_storeu_ps(p + 16 * v, static_cast<__mmask16>(seg.mask[s] >> (16 * v)), c[r][v]);
      if constexpr (quarter)
        _mm256_mask_storeu_ps(p + 16 * NV, static_cast<__mmask8>(seg.mask[s] >> (16 * NV)), q[r]);
    }
  }
}

// The fused kernel of the least width and height that cover cols columns and dest.rows rows.
template <class RowB>
SHADOWSENSE_AVX512_GEMM_TARGET inline void
micro_kernel_avx512_fused_fit(int cols, int K, const float* a, RowB row_b, const TileDest& dest) {
  auto with_cols = [&]<int Cols>() {
    if (dest.rows <= 4)
      micro_kernel_avx512_fused<Cols, 4>(K, a, row_b, dest);
    else
      micro_kernel_avx512_fused<Cols>(K, a, row_b, dest);
  };
  if (cols <= 8)
    with_cols.template operator()<8>();
  else if (cols <= 16)
    with_cols.template operator()<16>();
  else if (cols <= 24)
    with_cols.template operator()<24>();
  else
    with_cols.template operator()<32>();
}

// The fused kernel writing a plain 8 x 32 tile (its first Cols columns and MR rows): one run,
// no bias.
template <int Cols, int MR = 8>
SHADOWSENSE_AVX512_GEMM_TARGET inline void micro_kernel_avx512_cols(int K, const float* a,
                                                                    const float* b, float* out) {
  static constexpr TileSegments whole{1, {Cols == 32 ? ~0u : (1u << Cols) - 1u}, {0}};
  micro_kernel_avx512_fused<Cols, MR>(K, a, PackedRows{b},
                                      TileDest{out, 32, nullptr, false, MR, &whole});
}
SHADOWSENSE_AVX512_GEMM_TARGET inline void micro_kernel_avx512(int K, const float* a,
                                                               const float* b, float* out) {
  micro_kernel_avx512_cols<32>(K, a, b, out);
}

// The AVX2 kernel over B rows row_b(k) (24 floats each): a packed panel (micro_kernel_avx2) or
// rows read in place (micro_kernel_avx2_in_place: conv0's taps, nothing packed); its first
// Cols (8, 16 or 24) columns only (micro_kernel_avx2_cols), the rest of out not written. The
// accumulators are an array the unrolled loops index with constants only: 12, 3 B vectors and
// a broadcast fill the 16 registers with no spill.
template <int Cols = 24, class RowB>
__attribute__((target("avx2,fma"))) inline void micro_kernel_avx2_rows(int K, const float* a,
                                                                       RowB row_b, float* out) {
  static_assert(Cols == 8 || Cols == 16 || Cols == 24, "8, 16 or 24 columns");
  constexpr int MR = 4, NV = Cols / 8;
  __m256 c[MR][NV];
  SHADOWSENSE_UNROLL(4)
  for (int r = 0; r < MR; ++r) {
    SHADOWSENSE_UNROLL(3)
    for (int v = 0; v < NV; ++v) c[r][v] = _mm256_setzero_ps();
  }
  for (int k = 0; k < K; ++k, a += MR) {
    const float* bk = row_b(k);
    __m256 b[NV];
    SHADOWSENSE_UNROLL(3)
    for (int v = 0; v < NV; ++v) b[v] = _mm256_loadu_ps(bk + 8 * v);
    SHADOWSENSE_UNROLL(4)
    for (int r = 0; r < MR; ++r) {
      const __m256 x = _mm256_broadcast_ss(a + r);
      SHADOWSENSE_UNROLL(3)
      for (int v = 0; v < NV; ++v) c[r][v] = _mm256_fmadd_ps(x, b[v], c[r][v]);
    }
  }
  SHADOWSENSE_UNROLL(4)
  for (int r = 0; r < MR; ++r) {
    SHADOWSENSE_UNROLL(3)
    for (int v = 0; v < NV; ++v) _mm256_storeu_ps(out + 24 * r + 8 * v, c[r][v]);
  }
}
template <int Cols>
__attribute__((target("avx2,fma"))) inline void micro_kernel_avx2_cols(int K, const float* a,
                                                                       const float* b, float* out) {
  micro_kernel_avx2_rows<Cols>(K, a, PackedRowsOf<24>{b}, out);
}
__attribute__((target("avx2,fma"))) inline void micro_kernel_avx2(int K, const float* a,
                                                                  const float* b, float* out) {
  micro_kernel_avx2_rows(K, a, PackedRowsOf<24>{b}, out);
}
__attribute__((target("avx2,fma"))) inline void
micro_kernel_avx2_in_place(int K, const float* a, const float* b, const int* offsets, float* out) {
  micro_kernel_avx2_rows(K, a, OffsetRows{b, offsets}, out);
}
#endif

#if SHADOWSENSE_X86_KERNELS
// AVX-512 element-wise loops written out with masked tails: the packers call them on rows of
// one panel width (32) or less, where the plain loops' vectorisation prologues, and the
// memcpy / memset calls the compiler turns pack3x3's copies into, cost more than the work.
// relu(NaN) stays NaN: max(0, v) returns its second operand when either is NaN.
__attribute__((target("avx512f"))) inline __mmask16 tail_mask_avx512(int n) {
  return n >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << (n > 0 ? n : 0)) - 1u);
}
__attribute__((target("avx512f"))) inline void
affine_relu_avx512(const float* __restrict s, float* __restrict d, int n, float sc, float sh) {
  const __m512 vs = _mm512_set1_ps(sc), vh = _mm512_set1_ps(sh), z = _mm512_setzero_ps();
  for (int i = 0; i < n; i += 16) {
    const __mmask16 m = tail_mask_avx512(n - i);
    const __m512 x = _mm512_maskz_loadu_ps(m, s + i);
    _mm512_mask_storeu_ps(d + i, m, _mm512_maskz_max_ps(m, z, _mm512_fmadd_ps(x, vs, vh)));
  }
}
// The 1x1 convolution's input panel in one call: the masks are made once, and each channel's
// row (usually 2 vectors) needs no call of its own.
__attribute__((target("avx512f"))) inline void
pack_affine_relu_avx512(const float* __restrict s, std::size_t stride, int channels,
                        const float* __restrict sc, const float* __restrict sh, float* __restrict d,
                        int cols, int nr) {
  const __m512 z = _mm512_setzero_ps();
  if (cols == 32 && nr == 32) { // a full panel of the 8 x 32 kernel
    for (int c = 0; c < channels; ++c, s += stride, d += 32) {
      const __m512 vs = _mm512_set1_ps(sc[c]), vh = _mm512_set1_ps(sh[c]);
      // (maskz_max with a full mask: GCC 12 warns maybe-uninitialized on _mm512_max_ps)
      _mm512_storeu_ps(d,
                       _mm512_maskz_max_ps(0xFFFF, z, _mm512_fmadd_ps(_mm512_loadu_ps(s), vs, vh)));
      _mm512_storeu_ps(
          d + 16, _mm512_maskz_max_ps(0xFFFF, z, _mm512_fmadd_ps(_mm512_loadu_ps(s + 16), vs, vh)));
    }
    return;
  }
  for (int c = 0; c < channels; ++c, s += stride, d += nr) {
    const __m512 vs = _mm512_set1_ps(sc[c]), vh = _mm512_set1_ps(sh[c]);
    for (int j = 0; j < nr; j += 16) { // columns >= cols: loaded as 0, stored as relu(sh)...
      const __mmask16 in = tail_mask_avx512(cols - j), all = tail_mask_avx512(nr - j);
      const __m512 x = _mm512_maskz_loadu_ps(in, s + j);
      // ...so they are zeroed with the load mask: 0 beyond cols, as the contract says.
      _mm512_mask_storeu_ps(d + j, all, _mm512_maskz_max_ps(in, z, _mm512_fmadd_ps(x, vs, vh)));
    }
  }
}

// The pixel-rows kernel (see the header comment): C transposed, 8 (or MR) pixels on the rows
// and Cols output channels on the columns. a: the pixels' input, a K x 32 panel of
// pack_affine_relu (its columns 0-7 from a's start, so a row of the kernel is one column of
// the panel: broadcasts 32 floats apart); b: K x 32 packed weights (PixelRowWeights). Each
// product is fma(input, weight, sum) in k order as in micro_kernel_avx512_fused (fma(weight,
// input, sum) there: the same value), then + bias, ReLU: the same bits as the channel-rows
// kernel for every output. The tile is transposed in 8 x 8 blocks on the way out, so channel
// j's pixels are one masked store per segment.
template <int Cols, int MR = 8>
SHADOWSENSE_AVX512_GEMM_TARGET inline void
micro_kernel_avx512_pixel_rows(int K, const float* a, const float* b, const TileDest& dest) {
  static_assert(Cols == 16 || Cols == 32, "16 or 32 output channels");
  static_assert(MR == 8 || MR == 4, "8 or the first 4 pixels of the sub-panel");
  constexpr int NV = Cols / 16;
  __m512 c[MR][NV];
  SHADOWSENSE_UNROLL(8)
  for (int r = 0; r < MR; ++r) {
    SHADOWSENSE_UNROLL(2)
    for (int v = 0; v < NV; ++v) c[r][v] = _mm512_setzero_ps();
  }
  for (int k = 0; k < K; ++k, a += 32, b += 32) {
    __m512 w[NV];
    SHADOWSENSE_UNROLL(2)
    for (int v = 0; v < NV; ++v) w[v] = _mm512_loadu_ps(b + 16 * v);
    SHADOWSENSE_UNROLL(8)
    for (int r = 0; r < MR; ++r) {
      const __m512 x = _mm512_set1_ps(a[r]);
      SHADOWSENSE_UNROLL(2)
      for (int v = 0; v < NV; ++v) c[r][v] = _mm512_fmadd_ps(x, w[v], c[r][v]);
    }
  }
  // Bias and ReLU per channel (a column here), then the tile to memory pixel-major.
  alignas(64) float t[8][32];
  const __m512 z = _mm512_setzero_ps();
  SHADOWSENSE_UNROLL(2)
  for (int v = 0; v < NV; ++v) {
    const __mmask16 in = tail_mask_avx512(dest.rows - 16 * v);
    const __m512 bias = dest.bias ? _mm512_maskz_loadu_ps(in, dest.bias + 16 * v) : z;
    SHADOWSENSE_UNROLL(8)
    for (int r = 0; r < MR; ++r) {
      __m512 y = dest.bias ? _mm512_add_ps(c[r][v], bias) : c[r][v];
      if (dest.relu) y = _mm512_maskz_max_ps(0xFFFF, z, y); // NaN kept, as relu_reference
      _mm512_store_ps(&t[r][16 * v], y);
    }
  }
  const TileSegments& seg = *dest.segments;
  for (int g = 0; g * 8 < dest.rows; ++g) { // channels 8g .. 8g + 7
    __m256 x[8];
    SHADOWSENSE_UNROLL(8)
    for (int r = 0; r < 8; ++r) x[r] = r < MR ? _mm256_load_ps(&t[r][8 * g]) : _mm256_setzero_ps();
    // 8 x 8 transpose: y[j] = pixels 0..7 of channel 8g + j.
    const __m256 u0 = _mm256_unpacklo_ps(x[0], x[1]), u1 = _mm256_unpackhi_ps(x[0], x[1]);
    const __m256 u2 = _mm256_unpacklo_ps(x[2], x[3]), u3 = _mm256_unpackhi_ps(x[2], x[3]);
    const __m256 u4 = _mm256_unpacklo_ps(x[4], x[5]), u5 = _mm256_unpackhi_ps(x[4], x[5]);
    const __m256 u6 = _mm256_unpacklo_ps(x[6], x[7]), u7 = _mm256_unpackhi_ps(x[6], x[7]);
    const __m256 s0 = _mm256_shuffle_ps(u0, u2, 0x44), s1 = _mm256_shuffle_ps(u0, u2, 0xEE);
    const __m256 s2 = _mm256_shuffle_ps(u1, u3, 0x44), s3 = _mm256_shuffle_ps(u1, u3, 0xEE);
    const __m256 s4 = _mm256_shuffle_ps(u4, u6, 0x44), s5 = _mm256_shuffle_ps(u4, u6, 0xEE);
    const __m256 s6 = _mm256_shuffle_ps(u5, u7, 0x44), s7 = _mm256_shuffle_ps(u5, u7, 0xEE);
    const __m256 y[8] = {
        _mm256_permute2f128_ps(s0, s4, 0x20), _mm256_permute2f128_ps(s1, s5, 0x20),
        _mm256_permute2f128_ps(s2, s6, 0x20), _mm256_permute2f128_ps(s3, s7, 0x20),
        _mm256_permute2f128_ps(s0, s4, 0x31), _mm256_permute2f128_ps(s1, s5, 0x31),
        _mm256_permute2f128_ps(s2, s6, 0x31), _mm256_permute2f128_ps(s3, s7, 0x31)};
    SHADOWSENSE_UNROLL(8)
    for (int j = 0; j < 8; ++j) {
      if (8 * g + j >= dest.rows) break;
      float* row = dest.dst + static_cast<std::ptrdiff_t>(8 * g + j) *
                                  static_cast<std::ptrdiff_t>(dest.row_stride);
      for (int s = 0; s < seg.count; ++s)
        _mm256_mask_storeu_ps(row + seg.offset[s], static_cast<__mmask8>(seg.mask[s]), y[j]);
    }
  }
}

// The pixel-rows kernel of the least width (16 or 32 channels) and height (4 or 8 pixels)
// covering dest.rows channels and `pixels` pixels.
SHADOWSENSE_AVX512_GEMM_TARGET inline void
micro_kernel_avx512_pixel_rows_fit(int pixels, int K, const float* a, const float* b,
                                   const TileDest& dest) {
  if (dest.rows <= 16) {
    if (pixels <= 4)
      micro_kernel_avx512_pixel_rows<16, 4>(K, a, b, dest);
    else
      micro_kernel_avx512_pixel_rows<16>(K, a, b, dest);
  } else if (pixels <= 4) {
    micro_kernel_avx512_pixel_rows<32, 4>(K, a, b, dest);
  } else {
    micro_kernel_avx512_pixel_rows<32>(K, a, b, dest);
  }
}
__attribute__((target("avx512f"))) inline void
bias_relu_avx512(const float* __restrict s, float* __restrict d, int n, float b) {
  const __m512 vb = _mm512_set1_ps(b), z = _mm512_setzero_ps();
  for (int i = 0; i < n; i += 16) {
    const __mmask16 m = tail_mask_avx512(n - i);
    const __m512 x = _mm512_maskz_loadu_ps(m, s + i);
    _mm512_mask_storeu_ps(d + i, m, _mm512_maskz_max_ps(m, z, _mm512_add_ps(x, vb)));
  }
}
__attribute__((target("avx512f"))) inline void
pack3x3_avx512(const float* __restrict s, float* __restrict d, int cols, int nr, int pw) {
  for (int ky = 0; ky < 3; ++ky)
    for (int kx = 0; kx < 3; ++kx, d += nr) {
      const float* __restrict r = s + ky * pw + kx;
      int j = 0;
      for (; j + 16 <= nr; j += 16) // whole vectors of the panel: zero beyond cols
        _mm512_storeu_ps(d + j, _mm512_maskz_loadu_ps(tail_mask_avx512(cols - j), r + j));
      for (; j < nr; ++j) d[j] = j < cols ? r[j] : 0.0f;
    }
}
// pool_affine_relu (gemm.hpp's contract), 16 windows a step, every value by one FMA, so a
// value does not depend on n or on where a row is cut into calls (the compiler's own
// vectorisation of the scalar loop fused in its vector loop and not in its remainder).
// max(0, v) keeps a NaN and a -0 as `v < 0 ? 0 : v` does (the second operand is returned).
__attribute__((target("avx512f"))) inline void pool_affine_relu_avx512(const float* __restrict r0,
                                                                       const float* __restrict r1,
                                                                       float* __restrict d, int n,
                                                                       float sc, float sh) {
  const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512i odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
  const __m512 vs = _mm512_set1_ps(sc), vh = _mm512_set1_ps(sh), z = _mm512_setzero_ps();
  const __m512 quarter = _mm512_set1_ps(0.25f);
  for (int j = 0; j < n; j += 16) {
    const int left = n - j; // windows left: 2 * left inputs a row
    const __mmask16 lo = tail_mask_avx512(2 * left), hi = tail_mask_avx512(2 * left - 16);
    const __m512 p0 = _mm512_maskz_loadu_ps(lo, r0 + 2 * j);
    const __m512 p1 = _mm512_maskz_loadu_ps(hi, r0 + 2 * j + 16);
    const __m512 q0 = _mm512_maskz_loadu_ps(lo, r1 + 2 * j);
    const __m512 q1 = _mm512_maskz_loadu_ps(hi, r1 + 2 * j + 16);
    const __m512 a = _mm512_maskz_max_ps(
        0xFFFF, z, _mm512_fmadd_ps(_mm512_permutex2var_ps(p0, even, p1), vs, vh));
    const __m512 b = _mm512_maskz_max_ps(
        0xFFFF, z, _mm512_fmadd_ps(_mm512_permutex2var_ps(p0, odd, p1), vs, vh));
    const __m512 c = _mm512_maskz_max_ps(
        0xFFFF, z, _mm512_fmadd_ps(_mm512_permutex2var_ps(q0, even, q1), vs, vh));
    const __m512 e = _mm512_maskz_max_ps(
        0xFFFF, z, _mm512_fmadd_ps(_mm512_permutex2var_ps(q0, odd, q1), vs, vh));
    const __m512 sum = _mm512_add_ps(_mm512_add_ps(a, b), _mm512_add_ps(c, e));
    _mm512_mask_storeu_ps(d + j, tail_mask_avx512(left), _mm512_mul_ps(sum, quarter));
  }
}
// max_pool3s2 (gemm.hpp's contract): the column pass 16 floats a step, the window pass 16
// windows a step; std::max(a, b) is a < b ? b : a, which is _mm512_max_ps(b, a) for every a, b
// (NaN and signed zeros alike), and the sums in the portable loop's order: the same bits. (The
// max is written as the all-lanes masked form: GCC 12 warns on _mm512_max_ps's undefined
// pass-through operand.)
__attribute__((target("avx512f"))) inline void max_pool3s2_avx512(const float* s, int h0, int w0,
                                                                  int bh, int bw, float* vm,
                                                                  float* vs, float* dst) {
  const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512i odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
  // Past each end of a row, a column that changes nothing: max(-inf, v) is v (a NaN is caught
  // by the sum) and -0 + v is v for every v, +0 included. So the first and last windows, which
  // have two columns, take the inner windows' formula and all run in the vector loop.
  vm[-1] = vm[w0] = -std::numeric_limits<float>::infinity();
  vs[-1] = vs[w0] = -0.0f;
  for (int y = 0; y < bh; ++y) {
    const int y0 = std::max(2 * y - 1, 0), y1 = std::min(2 * y + 1, h0 - 1);
    const float* r = s + static_cast<std::size_t>(y0) * w0;
    const float* r1 = y0 + 1 <= y1 ? s + static_cast<std::size_t>(y0 + 1) * w0 : nullptr;
    const float* r2 = y0 + 2 <= y1 ? s + static_cast<std::size_t>(y0 + 2) * w0 : nullptr;
    for (int x = 0; x < w0; x += 16) {
      const __mmask16 m = w0 - x >= 16 ? 0xFFFF : static_cast<__mmask16>((1u << (w0 - x)) - 1);
      __m512 mx = _mm512_maskz_loadu_ps(m, r + x), sum = mx;
      if (r1) {
        const __m512 v = _mm512_maskz_loadu_ps(m, r1 + x);
        mx = _mm512_maskz_max_ps(0xFFFF, v, mx);
        sum = _mm512_add_ps(sum, v);
      }
      if (r2) {
        const __m512 v = _mm512_maskz_loadu_ps(m, r2 + x);
        mx = _mm512_maskz_max_ps(0xFFFF, v, mx);
        sum = _mm512_add_ps(sum, v);
      }
      _mm512_mask_storeu_ps(vm + x, m, mx);
      _mm512_mask_storeu_ps(vs + x, m, sum);
    }
    float* d = dst + static_cast<std::size_t>(y) * bw;
    for (int x = 0; x < bw; x += 16) {
      const __mmask16 m = bw - x >= 16 ? 0xFFFF : static_cast<__mmask16>((1u << (bw - x)) - 1);
      // Windows x .. x + 15 read columns 2x - 1 .. 2x + 31: even and odd ones come from two
      // permutes of two loads. Nothing past vm[w0] is read (masked lanes are zeros and unused).
      const int avail = w0 + 1 - 2 * x; // floats from vm + 2x - 1 to vm + w0 inclusive
      const __mmask16 la = avail >= 16 ? 0xFFFF : static_cast<__mmask16>((1u << avail) - 1);
      const __mmask16 lb = avail >= 32   ? 0xFFFF
                           : avail <= 16 ? 0
                                         : static_cast<__mmask16>((1u << (avail - 16)) - 1);
      const __mmask16 ca =
          avail - 1 >= 16 ? 0xFFFF : static_cast<__mmask16>((1u << (avail - 1)) - 1);
      const __mmask16 cb = avail - 1 >= 32   ? 0xFFFF
                           : avail - 1 <= 16 ? 0
                                             : static_cast<__mmask16>((1u << (avail - 17)) - 1);
      const float* m0 = vm + 2 * x;
      const float* s0 = vs + 2 * x;
      const __m512 pa = _mm512_maskz_loadu_ps(la, m0 - 1), pb = _mm512_maskz_loadu_ps(lb, m0 + 15);
      const __m512 ma = _mm512_maskz_loadu_ps(ca, m0), mb = _mm512_maskz_loadu_ps(cb, m0 + 16);
      const __m512 qa = _mm512_maskz_loadu_ps(la, s0 - 1), qb = _mm512_maskz_loadu_ps(lb, s0 + 15);
      const __m512 sa = _mm512_maskz_loadu_ps(ca, s0), sb = _mm512_maskz_loadu_ps(cb, s0 + 16);
      const __m512 me = _mm512_permutex2var_ps(ma, even, mb),
                   mo = _mm512_permutex2var_ps(ma, odd, mb);
      const __m512 mp = _mm512_permutex2var_ps(pa, even, pb);
      const __m512 se = _mm512_permutex2var_ps(sa, even, sb),
                   so = _mm512_permutex2var_ps(sa, odd, sb);
      const __m512 sp = _mm512_permutex2var_ps(qa, even, qb);
      const __m512 mx = _mm512_maskz_max_ps(0xFFFF, mo, _mm512_maskz_max_ps(0xFFFF, me, mp));
      const __m512 probe = _mm512_add_ps(_mm512_add_ps(sp, se), so);
      const __mmask16 ok = _mm512_cmp_ps_mask(probe, probe, _CMP_EQ_OQ);
      _mm512_mask_storeu_ps(d + x, m, _mm512_mask_blend_ps(ok, probe, mx));
    }
  }
}
SHADOWSENSE_DEFINE_VECTOR_OPS(avx2, __attribute__((target("avx2,fma"))) SHADOWSENSE_VECTORISE)

// The 1x1 convolution's input panel on AVX2 in one call (as pack_affine_relu_avx512): one call
// of affine_relu per channel, each with its vectorisation prologue, took 3.6% of the shipped
// model's forward pass in a profile, this function 2.5%. The same values as affine_relu_avx2 (one
// FMA, then relu as max(0, v): NaN and -0 kept, as v < 0 ? 0 : v keeps them). Columns cols..nr-1
// are zeroed with the load mask; a vmaskmovps load costs little (its store form is the slow one on
// AMD cores).
__attribute__((target("avx2,fma"))) inline void
pack_affine_relu_avx2(const float* __restrict s, std::size_t stride, int channels,
                      const float* __restrict sc, const float* __restrict sh, float* __restrict d,
                      int cols, int nr) {
  const __m256 z = _mm256_setzero_ps();
  if (cols == 24 && nr == 24) { // a full panel of the 4 x 24 kernel
    for (int c = 0; c < channels; ++c, s += stride, d += 24) {
      const __m256 vs = _mm256_set1_ps(sc[c]), vh = _mm256_set1_ps(sh[c]);
      _mm256_storeu_ps(d, _mm256_max_ps(z, _mm256_fmadd_ps(_mm256_loadu_ps(s), vs, vh)));
      _mm256_storeu_ps(d + 8, _mm256_max_ps(z, _mm256_fmadd_ps(_mm256_loadu_ps(s + 8), vs, vh)));
      _mm256_storeu_ps(d + 16, _mm256_max_ps(z, _mm256_fmadd_ps(_mm256_loadu_ps(s + 16), vs, vh)));
    }
    return;
  }
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (int c = 0; c < channels; ++c, s += stride, d += nr) {
    const __m256 vs = _mm256_set1_ps(sc[c]), vh = _mm256_set1_ps(sh[c]);
    int j = 0;
    for (; j + 8 <= nr; j += 8) {
      const __m256i in = _mm256_cmpgt_epi32(_mm256_set1_epi32(cols - j), lane); // j + lane < cols
      const __m256 v = _mm256_max_ps(z, _mm256_fmadd_ps(_mm256_maskload_ps(s + j, in), vs, vh));
      _mm256_storeu_ps(d + j, _mm256_and_ps(v, _mm256_castsi256_ps(in)));
    }
    for (; j < nr; ++j) {
      if (j >= cols) {
        d[j] = 0.0f;
        continue;
      }
      const float v = s[j] * sc[c] + sh[c];
      d[j] = v < 0.0f ? 0.0f : v;
    }
  }
}
#endif

} // namespace detail
SHADOWSENSE_NAMESPACE_END
