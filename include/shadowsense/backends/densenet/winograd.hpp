// Winograd F(2x2, 3x3) for the dense layers' 3x3 convolutions (stride 1, pad 1): each 2x2
// output tile is computed from its 4x4 input patch with 16 multiplications per (input, output)
// channel pair instead of 36, so the GEMM work of a 3x3 convolution drops 2.25x; the input and
// output transforms cost additions only. Results equal the direct convolution up to float
// rounding (the transforms' coefficients are 0, +-1 and +-1/2).
//
// Math (Lavin & Gray 2016): Y = A^T [ (G g G^T) . (B^T d B) ] A, with
//   B^T = [1 0 -1 0; 0 1 1 0; 0 -1 1 0; 0 1 0 -1], G = [1 0 0; .5 .5 .5; .5 -.5 .5; 0 0 1],
//   A^T = [1 1 1 0; 0 1 -1 -1].
// The 16 element-wise products over channels become 16 GEMMs (xi = 0..15): for a panel of nr
// tiles, M_xi (out x nr) = U_xi (out x in, the transformed weights, packed once at load) times
// V_xi (in x nr, the transformed patches), each run by the forward pass's micro-kernel, so every
// kernel (AVX-512, AVX2, NEON, portable, reference) gets it.
//
// WinogradWeights::set(w, m, c, mr): w is m x c x 3 x 3 row-major (PyTorch's conv weight);
//   ensures u[xi] is the m x c matrix (G g G^T)[xi / 4][xi % 4] packed in mr-row panels.
// winograd_pays(h, w, m, nr): true when the layer has m >= 16 output channels and the tiles'
//   GEMM columns (16 per nr tiles) are at most 3/4 of the direct padded-grid convolution's (9 per
//   nr outputs of h x (w + 2)). Small late-block images, whose few tiles leave most of a panel
//   empty, stay direct; so do layers with few output channels, where the transforms' additions
//   per tile cost more than the 20 multiply-adds per output channel they save (measured: the
//   shipped model, growth 8, is 6% slower with Winograd).
// WinogradOps: the transforms for one instruction set (select_winograd_ops(kind)):
//   input(s, plane, channels, pw, run, room, d, dc, xs): run (1..winograd_max_run) consecutive
//     tiles of one tile row, for each channel ch < channels; s + ch * plane is the first tile's
//     4x4 patch (top-left; row stride pw; the patches of tile j start 2j further). Writes
//     B^T d B of tile j of channel ch to d[xi * xs + ch * dc + j], xi = 0..15; columns
//     run..room-1 of those rows may be overwritten (room >= run). Reads up to
//     winograd_read_slack floats from the start of each step of 16 tiles.
//   output(m, xs, n, y): m[xi * xs + j] (xi = 0..15, j < n <= winograd_max_run) to the 2x2
//     outputs y[(2i + k) * winograd_max_run + j] = A^T M A [i][k].
//   interleave(a, b, d, n): d[2i] = a[i], d[2i + 1] = b[i] for 2i < n, 2i + 1 < n (n outputs).
// winograd_conv3x3(kernel, ops, u, in, pw, plane, h, w, out, pool, scratch):
//   requires: in holds u.c channels of (h + 2) x pw padded images (pw >= w + 2, zero border),
//             plane floats apart, readable for pw + winograd_read_slack floats past the last
//             one, the first pw + 1 of them zero (the tiles of odd h or w read one row / column
//             beyond the border; the rest is read into columns that are dropped); out has room
//             for u.m x h x w floats; scratch holds pool.size() entries made by
//             make_winograd_scratch(u.c, u.m, kernel).
//   ensures:  out[o][y][x] = sum over c, ky, kx of w[o][c][ky][kx] * in[c][y + ky][x + kx]
//             (padded coordinates), up to rounding. (tile panel, row panel) units are split
//             over the pool in equal shares; each output element is computed by one thread in
//             one order, so the result does not depend on the thread count.
// make_winograd_scratch(c, m, kernel): one thread's slabs and products (16 x (c x nr + 16) and
//   16 x (m rounded up to mr, x nr + 16) floats); requires 1 <= kernel.nr <= winograd_max_run.
// No state beyond the arguments; scratch entries are per thread (one per pool thread).
#pragma once

#include <shadowsense/backends/densenet/gemm.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <array>
#include <cstddef>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

inline constexpr int winograd_max_run = 64;    // >= every kernel's nr
inline constexpr int winograd_read_slack = 34; // floats a 16-tile step reads: 2 * 16 + 2

struct WinogradWeights {
  int m = 0, c = 0;
  std::array<PackedMatrix, 16> u;

  void set(const float* w, int rows, int channels, int mr) {
    m = rows;
    c = channels;
    std::array<std::vector<float>, 16> plain;
    for (auto& p : plain) p.assign(static_cast<std::size_t>(m) * c, 0.0f);
    static constexpr double G[4][3] = {{1, 0, 0}, {.5, .5, .5}, {.5, -.5, .5}, {0, 0, 1}};
    for (int o = 0; o < m; ++o)
      for (int i = 0; i < c; ++i) {
        const float* g = w + (static_cast<std::size_t>(o) * c + i) * 9;
        double gg[4][3]; // G g
        for (int p = 0; p < 4; ++p)
          for (int kx = 0; kx < 3; ++kx)
            gg[p][kx] = G[p][0] * g[kx] + G[p][1] * g[3 + kx] + G[p][2] * g[6 + kx];
        for (int p = 0; p < 4; ++p)
          for (int q = 0; q < 4; ++q)
            plain[static_cast<std::size_t>(p * 4 + q)][static_cast<std::size_t>(o) * c + i] =
                static_cast<float>(G[q][0] * gg[p][0] + G[q][1] * gg[p][1] + G[q][2] * gg[p][2]);
      }
    for (std::size_t xi = 0; xi < 16; ++xi) u[xi].pack(plain[xi].data(), m, c, mr);
  }
};

inline constexpr int winograd_min_outputs = 16; // output channels below which direct wins

inline bool winograd_pays(int h, int w, int m, int nr) {
  if (m < winograd_min_outputs) return false;
  const long tiles = long((h + 1) / 2) * ((w + 1) / 2);
  const long wino = (tiles + nr - 1) / nr * 16;
  const long direct = (long(h) * (w + 2) + nr - 1) / nr * 9;
  return 4 * wino <= 3 * direct;
}

// The transforms, written as unit-stride loops over tiles (the input's stride-2 reads become
// lane permutes): one definition per instruction set, like the vector ops of gemm_portable.hpp.
#define SHADOWSENSE_DEFINE_WINOGRAD_OPS(SUFFIX, ATTR)                                              \
  ATTR inline void winograd_input_one_##SUFFIX(const float* __restrict s, int pw, int run,         \
                                               float* __restrict d, std::size_t xs) {              \
    float t[4][4][winograd_max_run]; /* t[row][q][j]: the patch rows times B */                    \
    for (int k = 0; k < 4; ++k) {                                                                  \
      const float* __restrict r = s + k * pw;                                                      \
      for (int j = 0; j < run; ++j) {                                                              \
        const float e0 = r[2 * j], o0 = r[2 * j + 1], e1 = r[2 * j + 2], o1 = r[2 * j + 3];        \
        t[k][0][j] = e0 - e1;                                                                      \
        t[k][1][j] = o0 + e1;                                                                      \
        t[k][2][j] = e1 - o0;                                                                      \
        t[k][3][j] = o0 - o1;                                                                      \
      }                                                                                            \
    }                                                                                              \
    for (int q = 0; q < 4; ++q) {                                                                  \
      float* __restrict d0 = d + static_cast<std::size_t>(q) * xs;                                 \
      float* __restrict d1 = d + static_cast<std::size_t>(4 + q) * xs;                             \
      float* __restrict d2 = d + static_cast<std::size_t>(8 + q) * xs;                             \
      float* __restrict d3 = d + static_cast<std::size_t>(12 + q) * xs;                            \
      for (int j = 0; j < run; ++j) {                                                              \
        d0[j] = t[0][q][j] - t[2][q][j];                                                           \
        d1[j] = t[1][q][j] + t[2][q][j];                                                           \
        d2[j] = t[2][q][j] - t[1][q][j];                                                           \
        d3[j] = t[1][q][j] - t[3][q][j];                                                           \
      }                                                                                            \
    }                                                                                              \
  }                                                                                                \
  ATTR inline void winograd_input_##SUFFIX(const float* __restrict s, std::size_t plane,           \
                                           int channels, int pw, int run, int /*room*/,            \
                                           float* __restrict d, std::size_t dc, std::size_t xs) {  \
    for (int ch = 0; ch < channels; ++ch)                                                          \
      winograd_input_one_##SUFFIX(s + ch * plane, pw, run, d + ch * dc, xs);                       \
  }                                                                                                \
  ATTR inline void winograd_output_##SUFFIX(const float* __restrict m, std::size_t xs, int n,      \
                                            float* __restrict y) {                                 \
    float s[2][4][winograd_max_run]; /* A^T M */                                                   \
    for (int q = 0; q < 4; ++q) {                                                                  \
      const float* __restrict m0 = m + static_cast<std::size_t>(q) * xs;                           \
      const float* __restrict m1 = m + static_cast<std::size_t>(4 + q) * xs;                       \
      const float* __restrict m2 = m + static_cast<std::size_t>(8 + q) * xs;                       \
      const float* __restrict m3 = m + static_cast<std::size_t>(12 + q) * xs;                      \
      for (int j = 0; j < n; ++j) {                                                                \
        s[0][q][j] = m0[j] + m1[j] + m2[j];                                                        \
        s[1][q][j] = m1[j] - m2[j] - m3[j];                                                        \
      }                                                                                            \
    }                                                                                              \
    for (int i = 0; i < 2; ++i) {                                                                  \
      float* __restrict y0 = y + static_cast<std::size_t>(2 * i) * winograd_max_run;               \
      float* __restrict y1 = y0 + winograd_max_run;                                                \
      for (int j = 0; j < n; ++j) {                                                                \
        y0[j] = s[i][0][j] + s[i][1][j] + s[i][2][j];                                              \
        y1[j] = s[i][1][j] - s[i][2][j] - s[i][3][j];                                              \
      }                                                                                            \
    }                                                                                              \
  }                                                                                                \
  ATTR inline void winograd_interleave_##SUFFIX(                                                   \
      const float* __restrict a, const float* __restrict b, float* __restrict d, int n) {          \
    const int pairs = n / 2;                                                                       \
    for (int i = 0; i < pairs; ++i) {                                                              \
      d[2 * i] = a[i];                                                                             \
      d[2 * i + 1] = b[i];                                                                         \
    }                                                                                              \
    if (n % 2) d[n - 1] = a[pairs];                                                                \
  }

SHADOWSENSE_DEFINE_WINOGRAD_OPS(portable, )
#if SHADOWSENSE_X86_KERNELS
SHADOWSENSE_DEFINE_WINOGRAD_OPS(avx512_loops, __attribute__((target("avx512f"))))
SHADOWSENSE_DEFINE_WINOGRAD_OPS(avx2, __attribute__((target("avx2,fma"))))

// 16 tiles of one patch row k: t[q] = (row k of the patches) B, q = 0..3, from the 34 floats
// at r.
__attribute__((target("avx512f"))) inline void winograd_row_avx512(const float* r, __m512 (&t)[4]) {
  const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512i odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
  const __m512 a = _mm512_loadu_ps(r), b = _mm512_loadu_ps(r + 16);
  const __m512 e0 = _mm512_permutex2var_ps(a, even, b), o0 = _mm512_permutex2var_ps(a, odd, b);
  // e1, o1: e0, o0 one lane on, r[32] and r[33] entering at the top (a lane shift instead of two
  // more loads and permutes; maskz with a full mask: GCC 12 warns maybe-uninitialized on alignr)
  const __m512 e1 = _mm512_castsi512_ps(_mm512_maskz_alignr_epi32(
      0xFFFF, _mm512_castps_si512(_mm512_set1_ps(r[32])), _mm512_castps_si512(e0), 1));
  const __m512 o1 = _mm512_castsi512_ps(_mm512_maskz_alignr_epi32(
      0xFFFF, _mm512_castps_si512(_mm512_set1_ps(r[33])), _mm512_castps_si512(o0), 1));
  t[0] = _mm512_sub_ps(e0, e1);
  t[1] = _mm512_add_ps(o0, e1);
  t[2] = _mm512_sub_ps(e1, o0);
  t[3] = _mm512_sub_ps(o0, o1);
}

// One 16-tile step of the input transform; Masked: only the tiles in `out` are written.
template <bool Masked>
__attribute__((target("avx512f"))) inline void
winograd_step_avx512(const float* __restrict s, int pw, __mmask16 out, float* __restrict d,
                     std::size_t xs) {
  __m512 t[4][4];
  for (int k = 0; k < 4; ++k) winograd_row_avx512(s + static_cast<std::ptrdiff_t>(k) * pw, t[k]);
  for (int q = 0; q < 4; ++q) {
    const __m512 v[4] = {_mm512_sub_ps(t[0][q], t[2][q]), _mm512_add_ps(t[1][q], t[2][q]),
                         _mm512_sub_ps(t[2][q], t[1][q]), _mm512_sub_ps(t[1][q], t[3][q])};
    for (int p = 0; p < 4; ++p) {
      float* dst = d + static_cast<std::size_t>(4 * p + q) * xs;
      if constexpr (Masked)
        _mm512_mask_storeu_ps(dst, out, v[p]);
      else
        _mm512_storeu_ps(dst, v[p]);
    }
  }
}

// The input transform with AVX-512 intrinsics, 16 tiles per step: the compiler's version of the
// loops above spends most of its time in scalar tails and stack round trips. The even and odd
// columns of a patch row come from two lane permutes of 32 consecutive floats. Every step
// loads whole vectors (a step of fewer tiles computes garbage lanes from the floats beyond its
// patches: winograd_read_slack) and stores whole vectors where the row has room for them (the
// garbage columns belong to later runs of the panel, which overwrite them, or are dropped);
// only a step at the end of a row masks its stores. Masked loads and stores made the short
// steps (runs split at tile-row ends) 5x the cost of whole ones. Channels are the inner loop.
__attribute__((target("avx512f"))) inline void
winograd_input_avx512(const float* __restrict s, std::size_t plane, int channels, int pw, int run,
                      int room, float* __restrict d, std::size_t dc, std::size_t xs) {
  for (int j = 0; j < run; j += 16) {
    if (room - j >= 16)
      for (int ch = 0; ch < channels; ++ch)
        winograd_step_avx512<false>(s + ch * plane + 2 * j, pw, 0, d + ch * dc + j, xs);
    else {
      const __mmask16 out = tail_mask_avx512(run - j);
      for (int ch = 0; ch < channels; ++ch)
        winograd_step_avx512<true>(s + ch * plane + 2 * j, pw, out, d + ch * dc + j, xs);
    }
  }
}
#endif

struct WinogradOps {
  void (*input)(const float*, std::size_t, int, int, int, int, float*, std::size_t, std::size_t);
  void (*output)(const float*, std::size_t, int, float*);
  void (*interleave)(const float*, const float*, float*, int);
};

inline WinogradOps select_winograd_ops(GemmKernelKind kind) {
#if SHADOWSENSE_X86_KERNELS
  if (kind == GemmKernelKind::avx512)
    return {&winograd_input_avx512, &winograd_output_avx512_loops,
            &winograd_interleave_avx512_loops};
  if (kind == GemmKernelKind::avx2)
    return {&winograd_input_avx2, &winograd_output_avx2, &winograd_interleave_avx2};
#endif
  (void)kind; // NEON is aarch64's baseline: the portable loops compile to it
  return {&winograd_input_portable, &winograd_output_portable, &winograd_interleave_portable};
}

// Floats from one V_xi slab to the next: c x nr plus one cache line, so the 16 stores of a
// transformed patch (one per slab) do not all fall in one L1 set, as they do when the slab is a
// power-of-two size (c x nr = 128 x 32 floats = 16 KiB).
inline std::size_t winograd_slab(int c, int nr) {
  return static_cast<std::size_t>(c) * nr + 16;
}

// Floats from one M_xi block (all m rows of a tile panel, in mr-row panels) to the next, padded
// by a cache line like the slabs.
inline std::size_t winograd_products(int m, const MicroKernel& kernel) {
  return static_cast<std::size_t>((m + kernel.mr - 1) / kernel.mr) * kernel.mr * kernel.nr + 16;
}

struct WinogradScratch {
  std::vector<float> v; // 16 slabs of c x nr transformed patches (winograd_slab apart)
  std::vector<float> m; // 16 blocks of m x nr products (winograd_products apart)
  std::vector<float> y; // 4 x winograd_max_run outputs of one channel
};

inline WinogradScratch make_winograd_scratch(int c, int m, const MicroKernel& kernel) {
  require(kernel.nr >= 1 && kernel.nr <= winograd_max_run,
          "Winograd: the micro-kernel's nr is " + std::to_string(kernel.nr) + ", expected 1.." +
              std::to_string(winograd_max_run));
  WinogradScratch s;
  s.v.assign(16 * winograd_slab(c, kernel.nr), 0.0f);
  s.m.assign(16 * winograd_products(m, kernel), 0.0f);
  s.y.assign(4 * static_cast<std::size_t>(winograd_max_run), 0.0f);
  return s;
}

inline void winograd_conv3x3(const MicroKernel& kernel, const WinogradOps& ops,
                             const WinogradWeights& u, const float* in, int pw, std::size_t plane,
                             int h, int w, float* out, ThreadPool& pool,
                             std::vector<WinogradScratch>& scratch) {
  const int nr = kernel.nr, mr = kernel.mr, c = u.c;
  const int tiles_x = (w + 1) / 2, tiles = (h + 1) / 2 * tiles_x;
  const int n_panels = (tiles + nr - 1) / nr, m_panels = (u.m + mr - 1) / mr;
  const std::size_t xs_v = winograd_slab(c, nr);           // V_xi slab: c x nr (+ a line)
  const std::size_t xs_m = winograd_products(u.m, kernel); // M_xi block: m x nr (+ a line)
  const std::size_t image = static_cast<std::size_t>(h) * w;
  // Work units (tile panel, row panel) in equal shares (run_panel_units); a tile panel shared
  // by two threads is transformed by both.
  run_panel_units(pool, n_panels, m_panels, [&](int t, int np, int mp0, int mp1) {
    WinogradScratch& s = scratch[static_cast<std::size_t>(t)];
    const int t0 = np * nr, cols = std::min(nr, tiles - t0);
    // The transformed patches of every channel. Columns cols..nr-1 of the slabs keep older
    // values: the kernel's output columns are independent, and those columns are dropped.
    for (int j = 0; j < cols;) { // runs within one tile row
      const int ty = (t0 + j) / tiles_x, tx = (t0 + j) % tiles_x;
      const int run = std::min(cols - j, tiles_x - tx);
      ops.input(in + static_cast<std::size_t>(2 * ty) * pw + 2 * tx, plane, c, pw, run, nr - j,
                s.v.data() + j, static_cast<std::size_t>(nr), xs_v);
      j += run;
    }
    // xi outer: each V_xi slab stays in L1 while every row panel multiplies it.
    // (A last panel of at most nr / 2 tiles runs the half-width kernel where there is one.)
    const MicroKernelFn fn = kernel.half && cols <= nr / 2 ? kernel.half : kernel.fn;
    for (std::size_t xi = 0; xi < 16; ++xi)
      for (int mp = mp0; mp < mp1; ++mp)
        fn(c, u.u[xi].panel(mp), s.v.data() + xi * xs_v,
           s.m.data() + xi * xs_m + static_cast<std::size_t>(mp) * mr * nr);
    for (int mp = mp0; mp < mp1; ++mp) {
      const int rows = std::min(mr, u.m - mp * mr);
      for (int r = 0; r < rows; ++r) {
        ops.output(s.m.data() + static_cast<std::size_t>(mp * mr + r) * nr, xs_m, cols, s.y.data());
        float* o = out + static_cast<std::size_t>(mp * mr + r) * image;
        const float* y = s.y.data();
        for (int j = 0; j < cols;) { // runs within one tile row: 2 output rows each
          const int ty = (t0 + j) / tiles_x, tx = (t0 + j) % tiles_x;
          const int run = std::min(cols - j, tiles_x - tx);
          const int n = std::min(2 * run, w - 2 * tx); // output columns (odd w: one less)
          float* row = o + static_cast<std::size_t>(2 * ty) * w + 2 * tx;
          ops.interleave(y + j, y + winograd_max_run + j, row, n);
          if (2 * ty + 1 < h)
            ops.interleave(y + 2 * winograd_max_run + j, y + 3 * winograd_max_run + j, row + w, n);
          j += run;
        }
      }
    }
  });
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
