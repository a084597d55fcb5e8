// Winograd F(2x2, 3x3) and F(4x4, 3x3) for the dense layers' 3x3 convolutions (stride 1, pad 1):
// each T x T output tile (T = 2 or 4) is computed from its (T + 2) x (T + 2) input patch with
// (T + 2)^2 multiplications per (input, output) channel pair instead of 9 T^2, so the GEMM work
// of a 3x3 convolution drops 2.25x (T = 2) or 4x (T = 4); the input and output transforms cost
// additions and small constant multiplications only. Results equal the direct convolution up
// to float rounding: F(2x2)'s coefficients are 0, +-1 and +-1/2; F(4x4)'s reach 8 and 1/24,
// so its rounding error is larger (measured in tests/test_gemm.cpp and docs/densenet.md).
//
// Math (Lavin & Gray 2016): Y = A^T [ (G g G^T) . (B^T d B) ] A, with, for F(2x2, 3x3),
//   B^T = [1 0 -1 0; 0 1 1 0; 0 -1 1 0; 0 1 0 -1], G = [1 0 0; .5 .5 .5; .5 -.5 .5; 0 0 1],
//   A^T = [1 1 1 0; 0 1 -1 -1];
// and for F(4x4, 3x3) (interpolation points 0, +-1, +-2, infinity),
//   B^T = [4 0 -5 0 1 0; 0 -4 -4 1 1 0; 0 4 -4 -1 1 0; 0 -2 -1 2 1 0; 0 2 -1 -2 1 0;
//          0 4 0 -5 0 1],
//   G = [1/4 0 0; -1/6 -1/6 -1/6; -1/6 1/6 -1/6; 1/24 1/12 1/6; 1/24 -1/12 1/6; 0 0 1],
//   A^T = [1 1 1 1 1 0; 0 1 -1 2 -2 0; 0 1 1 4 4 0; 0 1 -1 8 -8 1];
// and F(3x3, 4x4) (tile 3: 4x4 kernels, conv0 over the input's stride-2 phases; the same points,
// so the same B^T and 6x6 patches, three columns apart),
//   G = [1/4 0 0 0; -1/6 -1/6 -1/6 -1/6; -1/6 1/6 -1/6 1/6; 1/24 1/12 1/6 1/3;
//        1/24 -1/12 1/6 -1/3; 0 0 0 1],
//   A^T = [1 1 1 1 1 0; 0 1 -1 2 -2 0; 0 1 1 4 4 1].
// The alpha^2 element-wise products over channels become as many GEMMs (xi = 0..(T + 2)^2 - 1):
// for a panel of nr tiles, M_xi (out x nr) = U_xi (out x in, the transformed weights, packed
// once) times V_xi (in x nr, the transformed patches), each run by the forward pass's
// micro-kernel, so every kernel (AVX-512, AVX2, NEON, portable, reference) gets it.
//
// WinogradWeights::set(w, m, c, mr, tile): tile is 2 or 4 (w is m x c x 3 x 3 row-major,
//   PyTorch's conv weight) or 3 (m x c x 4 x 4); ensures u[xi] is the m x c matrix
//   (G g G^T)[xi / alpha][xi % alpha] packed in mr-row panels (alpha = winograd_alpha(tile): 4
//   or 6). empty() until set.
// winograd_tile(h, w, m, nr, weights_stream = false): the method for an h x w image with m output
//   channels and a kernel of nr columns: 0 (direct), 2 or 4. Each method is costed in
//   micro-kernel panel passes times the multiply-adds per pass (direct 9, F(2x2) 16, F(4x4) 36
//   per tile column), the last, partly empty panel counted whole, plus one pass more where
//   weights_stream says the layer's weights come from memory (a model larger than
//   winograd_stream_bytes); Winograd is taken where it costs at most 3/4 of the direct
//   convolution (the transforms are not free) and F(4x4) where it costs at most
//   winograd4_share of F(2x2). Layers with fewer than 12 output channels stay direct: there the
//   transforms' additions per tile cost as much as the multiply-adds they save (measured on
//   compact DenseNets, blocks 4-4-4, 3x88x160, docs/densenet.md: growth 8 takes the same time
//   with F(4x4) and is 10% slower with F(2x2); growth 12, the shipped model, is 17% faster).
// winograd_conv0_pays(h, w, nr): whether conv0 with an h x w output costs at most 3/4 of the
//   direct convolution by F(3x3, 4x4) over the 12 phase planes, in the same panel-pass units.
// winograd_padded(n, tile): the padded extent (rows or columns) a tile size reads for an image
//   extent n: n + r - 1 (r the kernel's taps), or more where the last tile reaches past it.
// WinogradOps: the transforms for one instruction set (select_winograd_ops(kind)):
//   input(s, plane, channels, pw, run, room, d, dc, xs) [F(2x2)], input4 (same) [F(4x4)] and
//   input3 [F(3x3, 4x4)]:
//     run (1..winograd_max_run) consecutive tiles of one tile row, for each channel
//     ch < channels; s + ch * plane is the first tile's patch (top-left; row stride pw; the
//     patches of tile j start T j further). Writes B^T d B of tile j of channel ch to
//     d[xi * xs + ch * dc + j], xi = 0..(T + 2)^2 - 1; columns run..room-1 of those rows may be
//     overwritten (room >= run). Reads up to winograd_read_slack floats from the start of each
//     patch row of a step of 16 tiles.
//   input_panel(in, plane, channels, pw, tiles_x, t0, cols, d, dc, xs) [F(2x2)], input4_panel
//     [F(4x4)] and input3_panel [F(3x3, 4x4)], optional (the AVX-512 kernel only; when null,
//     input, input4 and input3 per run): tiles t0 .. t0 + cols - 1 of the image's tile grid
//     (tiles_x a row; tile (ty, tx)'s patch at in + T ty pw + T tx), the values the per-run
//     transform gives each of them, tile t0 + j's to
//     d[xi * xs + ch * dc + j]; require dc a multiple of 16 and >= cols (columns cols..dc-1 of
//     those rows may be overwritten).
//   output(m, xs, n, y) [F(2x2)], output4 [F(4x4)] and output3 [F(3x3, 4x4)]: m[xi * xs + j]
//     (j < n <= winograd_max_run) to the T x T outputs
//     y[(T i + k) * winograd_max_run + j] = A^T M A [i][k].
//   output4_image(a) [F(4x4)], optional (the AVX-512 kernel only; when null, output4 and
//     interleave4 per run and channel): for the tiles and channels of a (WinogradImageOutput),
//     A^T M A [i][k] of tile (ty, tx) of channel r to a.o[r * a.image + (4 ty + i) * a.w + 4 tx +
//     k] where that is inside the h x w image, nothing else written; reads m[r * mc + xi * xs +
//     j] for j up to the next multiple of 16 above cols - 1 (values there are not used).
//   interleave(a, b, d, n): d[2i] = a[i], d[2i + 1] = b[i] for 2i < n, 2i + 1 < n (n outputs).
//   interleave4(y, d, n): d[4i + k] = y[k * winograd_max_run + i] for 4i + k < n.
//   interleave3_bias_relu(y, d, n, b): d[3i + k] = relu(y[k * winograd_max_run + i] + b) for
//     3i + k < n (v < 0 ? 0 : v: a NaN stays).
//   same_bits_anywhere: the transforms give a tile the same bits at any column of a panel (the
//     x86 sets, tested); only then may winograd_conv3x3/4x4 start a thread's panels at any tile.
// winograd_conv3x3(kernel, ops, u, in, pw, plane, h, w, out, pool, scratch):
//   requires: in holds u.c channels of padded images, plane floats apart, each with the image at
//             row 1, column 1, row stride pw >= winograd_padded(w, u.tile), at least
//             winograd_padded(h, u.tile) rows, and zero everywhere else; in is readable for
//             winograd_read_slack floats past the last plane (their values only reach columns
//             that are dropped); out has room for u.m x h x w floats; scratch holds pool.size()
//             entries made by make_winograd_scratch(u.c, u.m, kernel).
//   ensures:  out[o][y][x] = sum over c, ky, kx of w[o][c][ky][kx] * in[c][y + ky][x + kx]
//             (padded coordinates), up to rounding. (tile panel, row panel) units are split
//             over the pool in equal shares; each output element is computed by one thread in
//             one order, so the result does not depend on the thread count.
// winograd_conv4x4(kernel, ops, u, in, pw, plane, h, w, bias, out, pool, scratch): as
//   winograd_conv3x3 for u.tile == 3 (4x4 kernels), with the image at row 0, column 0 of each
//   plane (the correlation reads in[c][y + ky][x + kx], ky, kx < 4) and bias[o] added and ReLU
//   applied to each output: out[o][y][x] = relu(b[o] + sum over c, ky, kx of
//   w[o][c][ky][kx] * in[c][y + ky][x + kx]), up to rounding.
// make_winograd_scratch(c, m, kernel): one thread's slabs and products for either tile size
//   (36 x (c x nr + 16) and 36 x (m rounded up to mr, x nr + 16) floats); requires
//   1 <= kernel.nr <= winograd_max_run.
// No state beyond the arguments; scratch entries are per thread (one per pool thread).
#pragma once

#include <shadowsense/backends/densenet/gemm.hpp>
#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

inline constexpr int winograd_max_run = 64; // >= every kernel's nr
// Floats a 16-tile step reads from the start of a patch row: F(2x2) 2 x 16 + 2, F(4x4) five
// whole vectors (4 x 16 + 2 rounded up), F(3x3, 4x4) four (3 x 16 + 3).
inline constexpr int winograd_read_slack = 80;
inline constexpr int winograd_max_products = 36; // (T + 2)^2 for the largest tile, T = 4

inline int winograd_padded(int n, int tile) {
  const int extra = tile == 3 ? 3 : 2; // the kernel's taps - 1
  return std::max(n + extra, (n + tile - 1) / tile * tile + extra);
}

// Tile size T -> the kernel's taps r (3, or 4 for F(3x3, 4x4)) and the transformed patch's
// side alpha = T + r - 1 (4 or 6).
constexpr int winograd_taps(int tile) {
  return tile == 3 ? 4 : 3;
}
constexpr int winograd_alpha(int tile) {
  return tile + winograd_taps(tile) - 1;
}

struct WinogradWeights {
  int m = 0, c = 0, tile = 0;
  std::vector<PackedMatrix> u; // alpha^2 matrices

  bool empty() const { return u.empty(); }

  void set(const float* w, int rows, int channels, int mr, int tile_size) {
    require(tile_size == 2 || tile_size == 3 || tile_size == 4,
            "Winograd: tile size " + std::to_string(tile_size) + ", expected 2, 3 or 4");
    m = rows;
    c = channels;
    tile = tile_size;
    static constexpr double G2[4][4] = {{1, 0, 0}, {.5, .5, .5}, {.5, -.5, .5}, {0, 0, 1}};
    static constexpr double G4[6][4] = {{1. / 4, 0, 0},
                                        {-1. / 6, -1. / 6, -1. / 6},
                                        {-1. / 6, 1. / 6, -1. / 6},
                                        {1. / 24, 1. / 12, 1. / 6},
                                        {1. / 24, -1. / 12, 1. / 6},
                                        {0, 0, 1}};
    // F(3x3, 4x4): the same interpolation points as F(4x4, 3x3), four taps.
    static constexpr double G3[6][4] = {{1. / 4, 0, 0, 0},
                                        {-1. / 6, -1. / 6, -1. / 6, -1. / 6},
                                        {-1. / 6, 1. / 6, -1. / 6, 1. / 6},
                                        {1. / 24, 1. / 12, 1. / 6, 1. / 3},
                                        {1. / 24, -1. / 12, 1. / 6, -1. / 3},
                                        {0, 0, 0, 1}};
    const int a = winograd_alpha(tile), r = winograd_taps(tile);
    const double(*G)[4] = tile == 2 ? G2 : tile == 4 ? G4 : G3;
    std::vector<std::vector<float>> plain(static_cast<std::size_t>(a * a));
    for (auto& p : plain) p.assign(static_cast<std::size_t>(m) * c, 0.0f);
    for (int o = 0; o < m; ++o)
      for (int i = 0; i < c; ++i) {
        const float* g = w + (static_cast<std::size_t>(o) * c + i) * r * r;
        double gg[6][4]; // G g
        for (int p = 0; p < a; ++p)
          for (int kx = 0; kx < r; ++kx) {
            double acc = 0;
            for (int ky = 0; ky < r; ++ky) acc += G[p][ky] * g[ky * r + kx];
            gg[p][kx] = acc;
          }
        for (int p = 0; p < a; ++p)
          for (int q = 0; q < a; ++q) {
            double acc = 0;
            for (int kx = 0; kx < r; ++kx) acc += G[q][kx] * gg[p][kx];
            plain[static_cast<std::size_t>(p * a + q)][static_cast<std::size_t>(o) * c + i] =
                static_cast<float>(acc);
          }
      }
    u.assign(plain.size(), PackedMatrix{});
    for (std::size_t xi = 0; xi < plain.size(); ++xi) u[xi].pack(plain[xi].data(), m, c, mr);
  }
};

// Whether conv0 (7x7, stride 2, an h x w output) costs less by F(3x3, 4x4) over the input's 12
// stride-2 phases than directly: panel passes times multiply-adds per column, as winograd_tile
// (direct: h (w + 3) grid columns, 147 each; Winograd: one 3 x 3 tile per column, 36 products
// of 12 channels), taken at most 3/4 of the direct cost (the transforms are not free).
inline bool winograd_conv0_pays(int h, int w, int nr) {
  const long grid = long(h) * (w + 3), tiles = long((h + 2) / 3) * ((w + 2) / 3);
  const double direct = double((grid + nr - 1) / nr * 147);
  const double winograd = double((tiles + nr - 1) / nr * 36 * 12);
  return 4 * winograd <= 3 * direct;
}

inline constexpr int winograd_min_outputs = 12; // output channels below which direct wins
// F(4x4) is taken where its GEMM panel cost is at most this multiple of F(2x2)'s. The GEMM cost
// leaves out the transforms, which are cheaper per output for F(4x4) (36 transformed values per
// 16 outputs against 16 per 4), so F(4x4) may cost a little more GEMM work and still win.
// Measured (docs/densenet.md, "F(4x4) where its GEMM costs up to 1.2x F(2x2)'s"), in turn with
// 0.85: the shipped model's block 2 (11 x 20: 1 panel of 4x4 tiles against 2 of 2x2 ones, 36 /
// 32) 0.756 -> 0.727 ms a pass with AVX-512, DenseNet-121's blocks 2 and 3 (72 / 80, 36 / 32)
// 27.0 -> 26.3 ms, DenseNet-161 74.2 -> 73.7 ms; with the AVX2 kernels no change either way.
inline constexpr double winograd4_share = 1.2;

// A model whose weights take more than this does not keep them in a core's caches from one pass
// to the next (DenseNet-121's 32 MB; the shipped model's 0.6 MB stay): each layer reads its
// weights from memory. Reading one row panel of them (mr x c floats, per Winograd product) then
// takes about as long as one micro-kernel pass over it (8 x 128 floats: 4 KB at about 20 GB/s,
// 0.2 us, against 0.25 us for the pass on a Zen 5 core), so winograd_tile counts one pass more
// per method: F(4x4) reads 36 of them, F(2x2) 16, direct 9. On DenseNet-121's block 3 (9 x 13,
// 12 tiles of 4x4 in one panel) that takes direct (6 x 9 = 54) over F(4x4) (2 x 36 = 72):
// docs/densenet.md, "Two threads on one tile panel; block 3 direct where the weights stream".
inline constexpr std::size_t winograd_stream_bytes = std::size_t(4) << 20;

inline int winograd_tile(int h, int w, int m, int nr, bool weights_stream = false) {
  if (m < winograd_min_outputs) return 0;
  const long read = weights_stream ? 1 : 0; // passes' worth of reading the weights
  auto cost = [&](int tile, int per_column) {
    const long tiles = long((h + tile - 1) / tile) * ((w + tile - 1) / tile);
    return double(((tiles + nr - 1) / nr + read) * per_column);
  };
  const double direct = double(((long(h) * (w + 2) + nr - 1) / nr + read) * 9);
  const double f2 = cost(2, 16), f4 = cost(4, 36);
  if (4 * std::min(f2, f4) > 3 * direct) return 0;
  return f4 <= winograd4_share * f2 ? 4 : 2;
}

// F(4x4, 3x3)'s 1-D transforms of six values (a row or column of a patch, or of products):
// y = B^T x and z = A^T x, in the factored form the vector versions use too.
inline void winograd4_bt(float x0, float x1, float x2, float x3, float x4, float x5,
                         float (&y)[6]) {
  const float a = x4 - 4.0f * x2, b = x3 - 4.0f * x1, c = x4 - x2, e = 2.0f * (x3 - x1);
  y[0] = 4.0f * x0 - 5.0f * x2 + x4;
  y[1] = a + b;
  y[2] = a - b;
  y[3] = c + e;
  y[4] = c - e;
  y[5] = 4.0f * x1 - 5.0f * x3 + x5;
}
inline void winograd4_at(float x0, float x1, float x2, float x3, float x4, float x5,
                         float (&z)[4]) {
  const float p = x1 + x2, m = x1 - x2, p2 = x3 + x4, m2 = x3 - x4;
  z[0] = x0 + p + p2;
  z[1] = m + 2.0f * m2;
  z[2] = p + 4.0f * p2;
  z[3] = m + 8.0f * m2 + x5;
}

// F(3x3, 4x4)'s A^T x of six values: [1 1 1 1 1 0; 0 1 -1 2 -2 0; 0 1 1 4 4 1] (its B^T is
// F(4x4, 3x3)'s, winograd4_bt).
inline void winograd3_at(float x0, float x1, float x2, float x3, float x4, float x5,
                         float (&z)[3]) {
  const float p = x1 + x2, m = x1 - x2, p2 = x3 + x4, m2 = x3 - x4;
  z[0] = x0 + p + p2;
  z[1] = m + 2.0f * m2;
  z[2] = p + 4.0f * p2 + x5;
}

// A^T x of six values for F(4x4, 3x3) (four outputs) or F(3x3, 4x4) (three), by z's size.
template <int N>
inline void winograd6_at(float x0, float x1, float x2, float x3, float x4, float x5,
                         float (&z)[N]) {
  static_assert(N == 3 || N == 4, "F(4x4, 3x3) or F(3x3, 4x4)");
  if constexpr (N == 4)
    winograd4_at(x0, x1, x2, x3, x4, x5, z);
  else
    winograd3_at(x0, x1, x2, x3, x4, x5, z);
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
  }                                                                                                \
  /* F(4x4) and F(3x3, 4x4) share B^T: a 6x6 patch every Step columns (4 and 3 outputs) */         \
  template <int Step>                                                                              \
  ATTR inline void winograd_input6_one_##SUFFIX(const float* __restrict s, int pw, int run,        \
                                                float* __restrict d, std::size_t xs) {             \
    float t[6][6][winograd_max_run]; /* t[row][q][j]: the patch rows times B */                    \
    for (int k = 0; k < 6; ++k) {                                                                  \
      const float* __restrict r = s + k * pw;                                                      \
      for (int j = 0; j < run; ++j) {                                                              \
        const float* __restrict x = r + Step * j;                                                  \
        float y[6];                                                                                \
        winograd4_bt(x[0], x[1], x[2], x[3], x[4], x[5], y);                                       \
        for (int q = 0; q < 6; ++q) t[k][q][j] = y[q];                                             \
      }                                                                                            \
    }                                                                                              \
    for (int q = 0; q < 6; ++q)                                                                    \
      for (int j = 0; j < run; ++j) {                                                              \
        float y[6];                                                                                \
        winograd4_bt(t[0][q][j], t[1][q][j], t[2][q][j], t[3][q][j], t[4][q][j], t[5][q][j], y);   \
        for (int p = 0; p < 6; ++p) d[static_cast<std::size_t>(6 * p + q) * xs + j] = y[p];        \
      }                                                                                            \
  }                                                                                                \
  template <int Step>                                                                              \
  ATTR inline void winograd_input6_##SUFFIX(const float* __restrict s, std::size_t plane,          \
                                            int channels, int pw, int run, int /*room*/,           \
                                            float* __restrict d, std::size_t dc, std::size_t xs) { \
    for (int ch = 0; ch < channels; ++ch)                                                          \
      winograd_input6_one_##SUFFIX<Step>(s + ch * plane, pw, run, d + ch * dc, xs);                \
  }                                                                                                \
  /* A^T M A of 6x6 products to Outputs x Outputs (4: F(4x4), 3: F(3x3, 4x4)) */                   \
  template <int Outputs>                                                                           \
  ATTR inline void winograd_output6_##SUFFIX(const float* __restrict m, std::size_t xs, int n,     \
                                             float* __restrict y) {                                \
    float s[Outputs][6][winograd_max_run]; /* A^T M */                                             \
    for (int q = 0; q < 6; ++q)                                                                    \
      for (int j = 0; j < n; ++j) {                                                                \
        float z[Outputs];                                                                          \
        winograd6_at(m[static_cast<std::size_t>(q) * xs + j],                                      \
                     m[static_cast<std::size_t>(6 + q) * xs + j],                                  \
                     m[static_cast<std::size_t>(12 + q) * xs + j],                                 \
                     m[static_cast<std::size_t>(18 + q) * xs + j],                                 \
                     m[static_cast<std::size_t>(24 + q) * xs + j],                                 \
                     m[static_cast<std::size_t>(30 + q) * xs + j], z);                             \
        for (int i = 0; i < Outputs; ++i) s[i][q][j] = z[i];                                       \
      }                                                                                            \
    for (int i = 0; i < Outputs; ++i)                                                              \
      for (int j = 0; j < n; ++j) {                                                                \
        float z[Outputs];                                                                          \
        winograd6_at(s[i][0][j], s[i][1][j], s[i][2][j], s[i][3][j], s[i][4][j], s[i][5][j], z);   \
        for (int k = 0; k < Outputs; ++k)                                                          \
          y[static_cast<std::size_t>(Outputs * i + k) * winograd_max_run + j] = z[k];              \
      }                                                                                            \
  }                                                                                                \
  ATTR inline void winograd_interleave4_##SUFFIX(const float* __restrict y, float* __restrict d,   \
                                                 int n) {                                          \
    const int quads = n / 4;                                                                       \
    for (int i = 0; i < quads; ++i)                                                                \
      for (int k = 0; k < 4; ++k) d[4 * i + k] = y[k * winograd_max_run + i];                      \
    for (int k = 0; k < n % 4; ++k) d[4 * quads + k] = y[k * winograd_max_run + quads];            \
  }                                                                                                \
  /* d[3 i + k] = relu(y[k][i] + b) for 3 i + k < n: bias_relu's arithmetic. One loop over         \
     outputs: a loop over tiles with three stores, as interleave4's, made the shipped model's      \
     portable pass 15% slower (2.09 -> 2.45 ms, SSE2) */                                           \
  ATTR inline void winograd_interleave3_bias_relu_##SUFFIX(const float* __restrict y,              \
                                                           float* __restrict d, int n, float b) {  \
    for (int x = 0; x < n; ++x) {                                                                  \
      const float v = y[(x % 3) * winograd_max_run + x / 3] + b;                                   \
      d[x] = v < 0.0f ? 0.0f : v;                                                                  \
    }                                                                                              \
  }

SHADOWSENSE_DEFINE_WINOGRAD_OPS(portable, SHADOWSENSE_VECTORISE)

// WinogradOps::output4_image's arguments: tiles t0 .. t0 + cols - 1 of an h x w image's tile grid
// (tiles_x a row), for `rows` output channels; channel r's products m[r * mc + xi * xs + j] for
// tile t0 + j, its image at o + r * image (row stride w).
struct WinogradImageOutput {
  const float* m = nullptr;
  std::size_t xs = 0, mc = 0;
  int rows = 0, tiles_x = 0, t0 = 0, cols = 0, h = 0, w = 0;
  float* o = nullptr;
  std::size_t image = 0;
};

#if SHADOWSENSE_X86_KERNELS
SHADOWSENSE_DEFINE_WINOGRAD_OPS(avx512_loops,
                                __attribute__((target("avx512f"))) SHADOWSENSE_VECTORISE)
SHADOWSENSE_DEFINE_WINOGRAD_OPS(avx2_loops,
                                __attribute__((target("avx2,fma"))) SHADOWSENSE_VECTORISE)

// F(4x4)'s y = B^T x on six vectors of 8 tiles (winograd4_bt_avx512 at AVX2's width).
__attribute__((target("avx2,fma"))) SHADOWSENSE_ALWAYS_INLINE void
winograd4_bt_avx2(const __m256 (&x)[6], __m256 (&y)[6]) {
  const __m256 four = _mm256_set1_ps(4.0f), five = _mm256_set1_ps(5.0f);
  const __m256 a = _mm256_fnmadd_ps(four, x[2], x[4]); // x4 - 4 x2
  const __m256 b = _mm256_fnmadd_ps(four, x[1], x[3]); // x3 - 4 x1
  const __m256 c = _mm256_sub_ps(x[4], x[2]);
  const __m256 e = _mm256_add_ps(_mm256_sub_ps(x[3], x[1]), _mm256_sub_ps(x[3], x[1]));
  y[0] = _mm256_fmadd_ps(four, x[0], _mm256_fnmadd_ps(five, x[2], x[4]));
  y[1] = _mm256_add_ps(a, b);
  y[2] = _mm256_sub_ps(a, b);
  y[3] = _mm256_add_ps(c, e);
  y[4] = _mm256_sub_ps(c, e);
  y[5] = _mm256_fmadd_ps(four, x[1], _mm256_fnmadd_ps(five, x[3], x[5]));
}

// Stores lanes 0..n-1 (n <= 8) of v at dst, in at most three plain stores. Not vmaskmovps: its
// store form is microcoded on AMD cores (Zen 3 here), and the masked steps' 36 of them per
// channel took about a quarter of winograd_input4_avx2's time in a profile of the shipped model.
__attribute__((target("avx2,fma"))) inline void store_first_lanes_avx2(float* dst, __m256 v,
                                                                       int n) {
  if (n >= 8) return _mm256_storeu_ps(dst, v);
  __m128 part = _mm256_castps256_ps128(v);
  if (n & 4) {
    _mm_storeu_ps(dst, part);
    part = _mm256_extractf128_ps(v, 1);
    dst += 4;
  }
  if (n & 2) {
    _mm_storel_pi(reinterpret_cast<__m64*>(dst), part);
    part = _mm_movehl_ps(part, part);
    dst += 2;
  }
  if (n & 1) _mm_store_ss(dst, part);
}

// One step of F(4x4)'s input transform on AVX2, up to 8 tiles, as winograd6_step_avx512<4>: B^T
// down the six patch rows on whole vectors of consecutive columns into t, then per transformed
// row the columns 4j + k of the tiles by a transpose (each 128-bit lane holds one tile's four
// columns: two lane permutes put tiles j and j + 4 in one register, then the 4 x 4 transpose
// within lanes) and a one-tile shift for k = 4, 5, and B across them. Only the nv <= 5 column
// vectors the step's tiles read are transformed; t (32-byte aligned) keeps the caller's values
// beyond nv. Partial: only the first `lanes` tiles are stored.
// The fixed loops over the six rows are unrolled by pragma and the step always inlined: GCC
// does both at -O3 only, and at -O2 the x and y arrays lived on the stack (the input
// transform took 1.35x its -O3 time).
template <bool Partial>
__attribute__((target("avx2,fma"))) SHADOWSENSE_ALWAYS_INLINE void
winograd4_step_avx2(const float* __restrict s, int pw, int nv, int lanes, float* __restrict d,
                    std::size_t xs, float (&t)[6][40]) {
  for (int v = 0; v < nv; ++v) {
    __m256 x[6], y[6];
    SHADOWSENSE_UNROLL(6)
    for (int k = 0; k < 6; ++k)
      x[k] = _mm256_loadu_ps(s + static_cast<std::ptrdiff_t>(k) * pw + 8 * v);
    winograd4_bt_avx2(x, y);
    SHADOWSENSE_UNROLL(6)
    for (int p = 0; p < 6; ++p) _mm256_store_ps(t[p] + 8 * v, y[p]);
  }
  const __m256i next = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 0); // lane j <- lane j + 1
  for (int p = 0; p < 6; ++p) {
    const float* r = t[p];
    const __m256 a = _mm256_load_ps(r), b = _mm256_load_ps(r + 8);       // tiles 0 | 1, 2 | 3
    const __m256 c = _mm256_load_ps(r + 16), e = _mm256_load_ps(r + 24); // 4 | 5, 6 | 7
    const __m256 v0 = _mm256_permute2f128_ps(a, c, 0x20), v1 = _mm256_permute2f128_ps(a, c, 0x31);
    const __m256 v2 = _mm256_permute2f128_ps(b, e, 0x20), v3 = _mm256_permute2f128_ps(b, e, 0x31);
    const __m256 t0 = _mm256_unpacklo_ps(v0, v1), t1 = _mm256_unpackhi_ps(v0, v1);
    const __m256 t2 = _mm256_unpacklo_ps(v2, v3), t3 = _mm256_unpackhi_ps(v2, v3);
    __m256 x[6], y[6];
    x[0] = _mm256_shuffle_ps(t0, t2, 0x44); // column 4j of tiles 0-3 | 4-7
    x[1] = _mm256_shuffle_ps(t0, t2, 0xEE);
    x[2] = _mm256_shuffle_ps(t1, t3, 0x44);
    x[3] = _mm256_shuffle_ps(t1, t3, 0xEE);
    // x4, x5: x0, x1 one tile on, r[32] and r[33] entering at the top
    x[4] = _mm256_blend_ps(_mm256_permutevar8x32_ps(x[0], next), _mm256_set1_ps(r[32]), 0x80);
    x[5] = _mm256_blend_ps(_mm256_permutevar8x32_ps(x[1], next), _mm256_set1_ps(r[33]), 0x80);
    winograd4_bt_avx2(x, y);
    SHADOWSENSE_UNROLL(6)
    for (int q = 0; q < 6; ++q) {
      float* dst = d + static_cast<std::size_t>(6 * p + q) * xs;
      if constexpr (Partial)
        store_first_lanes_avx2(dst, y[q], lanes);
      else
        _mm256_storeu_ps(dst, y[q]);
    }
  }
}

// F(4x4)'s input transform with AVX2 intrinsics, 8 tiles per step (winograd_input6_avx512<4> at
// half the width; the compiler's version of the loops, winograd_input4_avx2_loops, was a
// quarter of the shipped model's forward pass). A step of fewer tiles computes garbage lanes
// from the floats beyond its patches (within winograd_read_slack) and stores whole vectors where
// the row has room; only a step at the end of a row stores part of its vectors.
__attribute__((target("avx2,fma"))) inline void
winograd_input4_avx2(const float* __restrict s, std::size_t plane, int channels, int pw, int run,
                     int room, float* __restrict d, std::size_t dc, std::size_t xs) {
  alignas(32) float t[6][40] = {}; // beyond a step's vectors: zeros or an earlier step's values
  for (int j = 0; j < run; j += 8) {
    const int nv = (4 * std::min(8, run - j) + 2 + 7) / 8; // column vectors the tiles read
    if (room - j >= 8)
      for (int ch = 0; ch < channels; ++ch)
        winograd4_step_avx2<false>(s + ch * plane + 4 * j, pw, nv, 8, d + ch * dc + j, xs, t);
    else {
      const int lanes = std::min(8, run - j);
      for (int ch = 0; ch < channels; ++ch)
        winograd4_step_avx2<true>(s + ch * plane + 4 * j, pw, nv, lanes, d + ch * dc + j, xs, t);
    }
  }
}

// 16 tiles of one patch row k: t[q] = (row k of the patches) B, q = 0..3, from its 32 floats in
// a, b and the two after them, r32 and r33. Fixed: lanes in `fix` take their columns 2 and 3
// from f2 and f3 instead of the next lane's columns 0 and 1 (a step across tile rows).
template <bool Fixed = false>
__attribute__((target("avx512f"))) inline void
winograd_row_parts_avx512(__m512 a, __m512 b, float r32, float r33, __m512 (&t)[4],
                          __mmask16 fix = 0, __m512 f2 = _mm512_setzero_ps(),
                          __m512 f3 = _mm512_setzero_ps()) {
  const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512i odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
  const __m512 e0 = _mm512_permutex2var_ps(a, even, b), o0 = _mm512_permutex2var_ps(a, odd, b);
  // e1, o1: e0, o0 one lane on, r[32] and r[33] entering at the top (a lane shift instead of two
  // more loads and permutes; maskz with a full mask: GCC 12 warns maybe-uninitialized on alignr)
  __m512 e1 = _mm512_castsi512_ps(_mm512_maskz_alignr_epi32(
      0xFFFF, _mm512_castps_si512(_mm512_set1_ps(r32)), _mm512_castps_si512(e0), 1));
  __m512 o1 = _mm512_castsi512_ps(_mm512_maskz_alignr_epi32(
      0xFFFF, _mm512_castps_si512(_mm512_set1_ps(r33)), _mm512_castps_si512(o0), 1));
  if constexpr (Fixed) {
    e1 = _mm512_mask_mov_ps(e1, fix, f2);
    o1 = _mm512_mask_mov_ps(o1, fix, f3);
  }
  t[0] = _mm512_sub_ps(e0, e1);
  t[1] = _mm512_add_ps(o0, e1);
  t[2] = _mm512_sub_ps(e1, o0);
  t[3] = _mm512_sub_ps(o0, o1);
}
// From the 34 floats at r.
__attribute__((target("avx512f"))) inline void winograd_row_avx512(const float* r, __m512 (&t)[4]) {
  winograd_row_parts_avx512(_mm512_loadu_ps(r), _mm512_loadu_ps(r + 16), r[32], r[33], t);
}

// B^T across the four transformed patch rows, and the 16 products' stores; Masked: only the
// tiles in `out` are written.
template <bool Masked>
__attribute__((target("avx512f"))) inline void
winograd_columns_store_avx512(const __m512 (&t)[4][4], __mmask16 out, float* __restrict d,
                              std::size_t xs) {
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

// One 16-tile step of the input transform; Masked: only the tiles in `out` are written.
template <bool Masked>
__attribute__((target("avx512f"))) inline void
winograd_step_avx512(const float* __restrict s, int pw, __mmask16 out, float* __restrict d,
                     std::size_t xs) {
  __m512 t[4][4];
  for (int k = 0; k < 4; ++k) winograd_row_avx512(s + static_cast<std::ptrdiff_t>(k) * pw, t[k]);
  winograd_columns_store_avx512<Masked>(t, out, d, xs);
}

// A tile panel's tiles cut into 16-tile steps, and each step into segments within one tile row
// (WinogradOps' panel transforms): segment i covers lanes lane .. lane + tiles - 1, its first
// patch at `at` floats from the image.
struct WinogradSegment {
  std::ptrdiff_t at = 0;
  int lane = 0, tiles = 0;
};

template <int T>
inline int winograd_step_segments(int pw, int tiles_x, int t0, int cols, int j,
                                  std::array<WinogradSegment, 16>& seg) {
  int n = 0;
  for (int l = j; l < std::min(cols, j + 16);) {
    const int ty = (t0 + l) / tiles_x, tx = (t0 + l) % tiles_x;
    const int run = std::min({cols - l, tiles_x - tx, j + 16 - l});
    seg[static_cast<std::size_t>(n++)] = {static_cast<std::ptrdiff_t>(T * ty) * pw + T * tx, l - j,
                                          run};
    l += run;
  }
  return n;
}

// F(2x2)'s input transform of a tile panel (WinogradOps::input_panel), 16 tiles a step whatever
// tile row they are in (as winograd_input6_panel_avx512 for F(4x4)): each segment's patch row
// is loaded into the lanes of its tiles (masked loads from 2 x its first lane before its patch),
// and columns 2 and 3 of a segment's last tile (the overlap with the next tile, which is in
// another row or not loaded) are put in that lane after the shift, unless it is lane 15. Per lane
// the same operations on the same values as winograd_input_avx512.
__attribute__((target("avx512f"))) inline void
winograd_input_panel_avx512(const float* __restrict in, std::size_t plane, int channels, int pw,
                            int tiles_x, int t0, int cols, float* __restrict d, std::size_t dc,
                            std::size_t xs) {
  std::array<WinogradSegment, 16> seg{};
  for (int j = 0; j < cols; j += 16) {
    const int n = winograd_step_segments<2>(pw, tiles_x, t0, cols, j, seg);
    if (n == 1) { // one tile row: the plain step
      for (int ch = 0; ch < channels; ++ch)
        winograd_step_avx512<false>(in + static_cast<std::size_t>(ch) * plane + seg[0].at, pw, 0,
                                    d + static_cast<std::size_t>(ch) * dc + j, xs);
      continue;
    }
    // Lanes 2 x lane .. 2 x (lane + tiles) - 1 of the 32 floats (a: 0-15, b: 16-31) per segment.
    __mmask16 lo[16], hi[16], fix = 0;
    for (int i = 0; i < n; ++i) {
      const WinogradSegment& g = seg[static_cast<std::size_t>(i)];
      const std::uint64_t bits = ((std::uint64_t{1} << (2 * g.tiles)) - 1) << (2 * g.lane);
      lo[i] = static_cast<__mmask16>(bits & 0xFFFF);
      hi[i] = static_cast<__mmask16>(bits >> 16);
      if (g.lane + g.tiles < 16) fix = static_cast<__mmask16>(fix | (1u << (g.lane + g.tiles - 1)));
    }
    const WinogradSegment& last = seg[static_cast<std::size_t>(n - 1)];
    for (int ch = 0; ch < channels; ++ch) {
      const float* s = in + static_cast<std::size_t>(ch) * plane;
      __m512 t[4][4];
      for (int k = 0; k < 4; ++k) {
        const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(k) * pw;
        __m512 a = _mm512_setzero_ps(), b = _mm512_setzero_ps(), f2 = a, f3 = a;
        for (int i = 0; i < n; ++i) {
          const WinogradSegment& g = seg[static_cast<std::size_t>(i)];
          const float* p = s + g.at + row; // the segment's patch row
          // Float 2 x lane of the 32 is the patch row's first: loads from 2 x lane floats before
          // it, whose masks read none of those (an address only: it may precede the planes).
          const auto r = reinterpret_cast<const float*>(reinterpret_cast<std::uintptr_t>(p) -
                                                        sizeof(float) * 2 * g.lane);
          a = _mm512_mask_loadu_ps(a, lo[i], r);
          b = _mm512_mask_loadu_ps(b, hi[i], r + 16);
          if (g.lane + g.tiles < 16) { // the last tile's columns 2 and 3 are not the next lane's
            const __mmask16 m = static_cast<__mmask16>(1u << (g.lane + g.tiles - 1));
            f2 = _mm512_mask_mov_ps(f2, m, _mm512_set1_ps(p[2 * g.tiles]));
            f3 = _mm512_mask_mov_ps(f3, m, _mm512_set1_ps(p[2 * g.tiles + 1]));
          }
        }
        const float* p = s + last.at + row;
        winograd_row_parts_avx512<true>(a, b, p[32 - 2 * last.lane], p[33 - 2 * last.lane], t[k],
                                        fix, f2, f3);
      }
      winograd_columns_store_avx512<false>(t, 0, d + static_cast<std::size_t>(ch) * dc + j, xs);
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

// F(4x4)'s y = B^T x on six vectors of tiles (the factored form of winograd4_bt).
__attribute__((target("avx512f"))) inline void winograd4_bt_avx512(const __m512 (&x)[6],
                                                                   __m512 (&y)[6]) {
  const __m512 four = _mm512_set1_ps(4.0f), five = _mm512_set1_ps(5.0f);
  const __m512 a = _mm512_fnmadd_ps(four, x[2], x[4]); // x4 - 4 x2
  const __m512 b = _mm512_fnmadd_ps(four, x[1], x[3]); // x3 - 4 x1
  const __m512 c = _mm512_sub_ps(x[4], x[2]);
  const __m512 e = _mm512_add_ps(_mm512_sub_ps(x[3], x[1]), _mm512_sub_ps(x[3], x[1]));
  y[0] = _mm512_fmadd_ps(four, x[0], _mm512_fnmadd_ps(five, x[2], x[4]));
  y[1] = _mm512_add_ps(a, b);
  y[2] = _mm512_sub_ps(a, b);
  y[3] = _mm512_add_ps(c, e);
  y[4] = _mm512_sub_ps(c, e);
  y[5] = _mm512_fmadd_ps(four, x[1], _mm512_fnmadd_ps(five, x[3], x[5]));
}

// One step of F(4x4)'s input transform, up to 16 tiles: B^T down the six patch rows first, on
// whole vectors of consecutive columns (no shuffles), into a stack buffer (winograd4_columns);
// then, per transformed row, the columns 4j + k of the tiles by a 16 x 4 transpose of 64 floats
// (two permutes and two block shuffles per pair of k) and a one-lane shift for k = 4, 5, and B
// across them (winograd4_rows). Only the nv <= 5 column vectors the step's tiles read are
// transformed (a 14-tile row reads 58 floats, 4 vectors); t (64-byte aligned) keeps the caller's
// values in the vectors beyond nv.
__attribute__((target("avx512f"))) inline void
winograd4_columns_avx512(const float* __restrict s, int pw, int nv, float (&t)[6][80], int at) {
  for (int v = 0; v < nv; ++v) {
    __m512 x[6], y[6];
    for (int k = 0; k < 6; ++k)
      x[k] = _mm512_loadu_ps(s + static_cast<std::ptrdiff_t>(k) * pw + 16 * v);
    winograd4_bt_avx512(x, y);
    for (int p = 0; p < 6; ++p) _mm512_storeu_ps(t[p] + at + 16 * v, y[p]);
  }
}
// Fixed: lanes in `fix` take their columns 4 and 5 from fix4[p] and fix5[p] instead of the
// next lane's columns 0 and 1 (a step whose tiles come from more than one tile row).
template <bool Masked, bool Fixed = false>
__attribute__((target("avx512f"))) inline void
winograd4_rows_avx512(const float (&t)[6][80], __mmask16 out, float* __restrict d, std::size_t xs,
                      __mmask16 fix = 0, const float (*fix4)[16] = nullptr,
                      const float (*fix5)[16] = nullptr) {
  const __m512i k01 = _mm512_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28, 1, 5, 9, 13, 17, 21, 25, 29);
  const __m512i k23 = _mm512_setr_epi32(2, 6, 10, 14, 18, 22, 26, 30, 3, 7, 11, 15, 19, 23, 27, 31);
  for (int p = 0; p < 6; ++p) {
    const float* r = t[p];
    const __m512 a = _mm512_load_ps(r), b = _mm512_load_ps(r + 16);
    const __m512 c = _mm512_load_ps(r + 32), e = _mm512_load_ps(r + 48);
    const __m512 ab01 = _mm512_permutex2var_ps(a, k01, b), ab23 = _mm512_permutex2var_ps(a, k23, b);
    const __m512 ce01 = _mm512_permutex2var_ps(c, k01, e), ce23 = _mm512_permutex2var_ps(c, k23, e);
    __m512 x[6], y[6];
    x[0] = _mm512_maskz_shuffle_f32x4(0xFFFF, ab01, ce01, 0x44); // low halves: tiles 0-7, then 8-15
    x[1] = _mm512_maskz_shuffle_f32x4(0xFFFF, ab01, ce01, 0xEE); // high halves
    x[2] = _mm512_maskz_shuffle_f32x4(0xFFFF, ab23, ce23, 0x44);
    x[3] = _mm512_maskz_shuffle_f32x4(0xFFFF, ab23, ce23, 0xEE);
    // x4, x5: x0, x1 one tile on, r[64] and r[65] entering at the top
    x[4] = _mm512_castsi512_ps(_mm512_maskz_alignr_epi32(
        0xFFFF, _mm512_castps_si512(_mm512_set1_ps(r[64])), _mm512_castps_si512(x[0]), 1));
    x[5] = _mm512_castsi512_ps(_mm512_maskz_alignr_epi32(
        0xFFFF, _mm512_castps_si512(_mm512_set1_ps(r[65])), _mm512_castps_si512(x[1]), 1));
    if constexpr (Fixed) {
      x[4] = _mm512_mask_loadu_ps(x[4], fix, fix4[p]);
      x[5] = _mm512_mask_loadu_ps(x[5], fix, fix5[p]);
    }
    winograd4_bt_avx512(x, y);
    for (int q = 0; q < 6; ++q) {
      float* dst = d + static_cast<std::size_t>(6 * p + q) * xs;
      if constexpr (Masked)
        _mm512_mask_storeu_ps(dst, out, y[q]);
      else
        _mm512_storeu_ps(dst, y[q]);
    }
  }
}

// F(3x3, 4x4)'s lane sources: lane j of column set k (k < 3) is float 3 j + k of a transformed
// row's 48; the first permute takes those below 32 from two vectors, the second the rest (mask
// bit j set) from the third.
struct Winograd3Columns {
  std::array<std::array<int, 16>, 3> low{}, high{};
  std::array<std::uint16_t, 3> from_high{};
};
inline constexpr Winograd3Columns winograd3_columns = [] {
  Winograd3Columns c{};
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 16; ++j) {
      const int src = 3 * j + k;
      c.low[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)] = src & 31;
      c.high[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)] = src & 15;
      if (src >= 32)
        c.from_high[static_cast<std::size_t>(k)] =
            static_cast<std::uint16_t>(c.from_high[static_cast<std::size_t>(k)] | (1u << j));
    }
  return c;
}();

// One step of F(3x3, 4x4)'s input transform, up to 16 tiles three columns apart: B^T down the
// six patch rows on whole column vectors into t (as winograd6_step_avx512<4>), then per
// transformed row the columns 3 j + k (k < 3) of its first 48 floats by two permutes each,
// columns 3 j + 3 .. 3 j + 5 as those one tile on (a one-lane shift, floats 48..50 entering),
// and B across them. t keeps the caller's values beyond the nv vectors the step fills.
// Fixed: lanes in `fix` take their columns 3 .. 5 from fix3[k][p] (k = 0..2) instead of the next
// lane's columns 0 .. 2 (a step across tile rows).
template <bool Masked, bool Fixed = false>
__attribute__((target("avx512f"))) inline void
winograd3_rows_avx512(const float (&t)[6][80], __mmask16 out, float* __restrict d, std::size_t xs,
                      __mmask16 fix = 0, const float (*fix3)[6][16] = nullptr) {
  __m512i low[3], high[3];
  for (std::size_t k = 0; k < 3; ++k) {
    low[k] = _mm512_loadu_si512(winograd3_columns.low[k].data());
    high[k] = _mm512_loadu_si512(winograd3_columns.high[k].data());
  }
  for (int p = 0; p < 6; ++p) {
    const float* r = t[p];
    const __m512 a = _mm512_load_ps(r), b = _mm512_load_ps(r + 16), c = _mm512_load_ps(r + 32);
    __m512 x[6], y[6];
    for (std::size_t k = 0; k < 3; ++k) {
      x[k] = _mm512_mask_permutexvar_ps(_mm512_permutex2var_ps(a, low[k], b),
                                        winograd3_columns.from_high[k], high[k], c);
      x[k + 3] = _mm512_castsi512_ps(_mm512_maskz_alignr_epi32(
          0xFFFF, _mm512_castps_si512(_mm512_set1_ps(r[48 + k])), _mm512_castps_si512(x[k]), 1));
      if constexpr (Fixed) x[k + 3] = _mm512_mask_loadu_ps(x[k + 3], fix, fix3[k][p]);
    }
    winograd4_bt_avx512(x, y);
    for (int q = 0; q < 6; ++q) {
      float* dst = d + static_cast<std::size_t>(6 * p + q) * xs;
      if constexpr (Masked)
        _mm512_mask_storeu_ps(dst, out, y[q]);
      else
        _mm512_storeu_ps(dst, y[q]);
    }
  }
}

// Lane j of the three vectors that interleave three rows of 16 values (48 floats: value e of
// the result is row e % 3, column e / 3, e = 16 k + j) as an index into (row 0, row 1) for the
// first permute, and the row-2 lanes with their source lane for the second.
struct Winograd3Interleave {
  std::array<std::array<int, 16>, 3> first{}, second{};
  std::array<std::uint16_t, 3> from_row2{};
};
inline constexpr Winograd3Interleave winograd3_interleave = [] {
  Winograd3Interleave r{};
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 16; ++j) {
      const int e = 16 * k + j, col = e / 3, row = e % 3;
      r.first[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)] = row == 1 ? 16 + col : col;
      r.second[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)] = col;
      if (row == 2)
        r.from_row2[static_cast<std::size_t>(k)] =
            static_cast<std::uint16_t>(r.from_row2[static_cast<std::size_t>(k)] | (1u << j));
    }
  return r;
}();

// F(3x3, 4x4)'s z = A^T x on six vectors of tiles (winograd3_at's factored form).
__attribute__((target("avx512f"))) SHADOWSENSE_ALWAYS_INLINE void
winograd3_at_avx512(const __m512 (&x)[6], __m512 (&z)[3]) {
  const __m512 p = _mm512_add_ps(x[1], x[2]), m = _mm512_sub_ps(x[1], x[2]);
  const __m512 p2 = _mm512_add_ps(x[3], x[4]), m2 = _mm512_sub_ps(x[3], x[4]);
  z[0] = _mm512_add_ps(_mm512_add_ps(x[0], p), p2);
  z[1] = _mm512_add_ps(m, _mm512_mul_ps(_mm512_set1_ps(2.0f), m2));
  z[2] = _mm512_add_ps(_mm512_add_ps(p, _mm512_mul_ps(_mm512_set1_ps(4.0f), p2)), x[5]);
}

// F(3x3, 4x4)'s output transform (winograd_output6<3>) with AVX-512: 16 tiles a step, the 18 column
// results kept in registers between the two passes (the compiled loops go through a stack array).
// Each operation as winograd3_at's, rounded on its own (no fused multiply-add): the loops' floats.
// A last step of fewer than 16 tiles masks its loads and stores.
__attribute__((target("avx512f"))) SHADOWSENSE_STRICT_FP inline void
winograd_output3_avx512(const float* __restrict m, std::size_t xs, int n, float* __restrict y) {
  SHADOWSENSE_STRICT_FP_BODY
  for (int j = 0; j < n; j += 16) {
    const __mmask16 lanes = n - j >= 16 ? __mmask16(0xFFFF) : tail_mask_avx512(n - j);
    __m512 s[3][6];
    for (int q = 0; q < 6; ++q) {
      __m512 x[6], z[3];
      for (int p = 0; p < 6; ++p)
        x[p] = _mm512_maskz_loadu_ps(lanes, m + static_cast<std::size_t>(6 * p + q) * xs + j);
      winograd3_at_avx512(x, z);
      for (int i = 0; i < 3; ++i) s[i][q] = z[i];
    }
    for (int i = 0; i < 3; ++i) {
      __m512 z[3];
      winograd3_at_avx512(s[i], z);
      for (int k = 0; k < 3; ++k)
        _mm512_mask_storeu_ps(y + static_cast<std::size_t>(3 * i + k) * winograd_max_run + j, lanes,
                              z[k]);
    }
  }
}

// winograd_interleave3_bias_relu with AVX-512: 16 tiles (48 outputs) a step, bias and ReLU on
// the three rows (max(0, v): v < 0 ? 0 : v, NaN kept, as bias_relu), two permutes per output
// vector, the last step's stores masked. Reads whole vectors of y's rows (winograd_max_run
// floats each, so always inside them).
__attribute__((target("avx512f"))) inline void
winograd_interleave3_bias_relu_avx512(const float* __restrict y, float* __restrict d, int n,
                                      float b) {
  const __m512 vb = _mm512_set1_ps(b), zero = _mm512_setzero_ps();
  __m512i first[3], second[3];
  for (std::size_t k = 0; k < 3; ++k) {
    first[k] = _mm512_loadu_si512(winograd3_interleave.first[k].data());
    second[k] = _mm512_loadu_si512(winograd3_interleave.second[k].data());
  }
  for (int t = 0; 3 * t < n; t += 16) {
    __m512 v[3];
    for (int k = 0; k < 3; ++k)
      v[k] = _mm512_maskz_max_ps(0xFFFF, zero,
                                 _mm512_add_ps(_mm512_loadu_ps(y + k * winograd_max_run + t), vb));
    for (std::size_t k = 0; k < 3; ++k) {
      const __m512 out =
          _mm512_mask_permutexvar_ps(_mm512_permutex2var_ps(v[0], first[k], v[1]),
                                     winograd3_interleave.from_row2[k], second[k], v[2]);
      const int e0 = 3 * t + 16 * static_cast<int>(k), left = n - e0;
      if (left >= 16)
        _mm512_storeu_ps(d + e0, out);
      else if (left > 0)
        _mm512_mask_storeu_ps(d + e0, tail_mask_avx512(left), out);
    }
  }
}

// One step of the 6-wide patches' input transform, T = 4 (F(4x4)) or 3 (F(3x3, 4x4)), up to 16
// tiles T columns apart: winograd4_columns_avx512 (B^T down the patch rows), then the rows' lane
// gather and B across them (winograd4_rows_avx512 / winograd3_rows_avx512).
template <int T, bool Masked>
__attribute__((target("avx512f"))) inline void
winograd6_step_avx512(const float* __restrict s, int pw, int nv, __mmask16 out, float* __restrict d,
                      std::size_t xs, float (&t)[6][80]) {
  winograd4_columns_avx512(s, pw, nv, t, 0);
  if constexpr (T == 4)
    winograd4_rows_avx512<Masked>(t, out, d, xs);
  else
    winograd3_rows_avx512<Masked>(t, out, d, xs);
}

// input4 (T = 4) and input3 (T = 3) with AVX-512 intrinsics, 16 tiles per step, whole-vector
// loads and stores as winograd_input_avx512 (a step of fewer tiles computes garbage lanes from
// the floats beyond its patches; a step reads whole column vectors, at most 80 floats of each
// patch row: winograd_read_slack).
template <int T>
__attribute__((target("avx512f"))) inline void
winograd_input6_avx512(const float* __restrict s, std::size_t plane, int channels, int pw, int run,
                       int room, float* __restrict d, std::size_t dc, std::size_t xs) {
  alignas(64) float t[6][80] = {}; // beyond a step's vectors: zeros or an earlier step's values
  for (int j = 0; j < run; j += 16) {
    const int nv = (T * std::min(16, run - j) + (6 - T) + 15) / 16; // column vectors read
    if (room - j >= 16)
      for (int ch = 0; ch < channels; ++ch)
        winograd6_step_avx512<T, false>(s + ch * plane + T * j, pw, nv, 0, d + ch * dc + j, xs, t);
    else {
      const __mmask16 out = tail_mask_avx512(run - j);
      for (int ch = 0; ch < channels; ++ch)
        winograd6_step_avx512<T, true>(s + ch * plane + T * j, pw, nv, out, d + ch * dc + j, xs, t);
    }
  }
}

// The input transform of a tile panel for the 6-wide patches, T = 4 (F(4x4), WinogradOps::
// input4_panel) or T = 3 (F(3x3, 4x4), input3_panel), 16 tiles a step whatever tile row they are
// in. Per run, 16-tile steps left a tile row of 10 tiles (the shipped model's first block) with
// 6 of 16 lanes idle, and conv0's rows of 27 tiles made three steps of a 32-tile panel. A step's
// tiles are cut into segments within one tile row; each segment's columns are transformed into
// t from column T x its first lane, so that the lane gather finds lane j's columns at T j ..
// T j + 5 as in one run, except for a segment's last tile: its columns T .. 5 (its patch's
// overlap with the next tile, which belongs to the next segment's row) are kept aside before
// the next segment overwrites them, and put in that lane after the shift. Per lane the same
// operations on the same values as winograd_input6_avx512<T>.
template <int T>
__attribute__((target("avx512f"))) inline void
winograd_input6_panel_avx512(const float* __restrict in, std::size_t plane, int channels, int pw,
                             int tiles_x, int t0, int cols, float* __restrict d, std::size_t dc,
                             std::size_t xs) {
  static_assert(T == 4 || T == 3, "F(4x4) or F(3x3, 4x4)");
  constexpr int overlap = 6 - T;
  alignas(64) float t[6][80] = {}; // beyond a step's vectors: zeros or an earlier step's values
  alignas(64) float kept[overlap][6][16] = {};
  std::array<WinogradSegment, 16> seg{};
  for (int j = 0; j < cols; j += 16) {
    const int n = winograd_step_segments<T>(pw, tiles_x, t0, cols, j, seg);
    __mmask16 fix = 0;
    for (int i = 0; i + 1 < n; ++i) {
      const WinogradSegment& g = seg[static_cast<std::size_t>(i)];
      fix = static_cast<__mmask16>(fix | (1u << (g.lane + g.tiles - 1)));
    }
    for (int ch = 0; ch < channels; ++ch) {
      const float* s = in + static_cast<std::size_t>(ch) * plane;
      for (int i = 0; i < n; ++i) {
        const WinogradSegment& g = seg[static_cast<std::size_t>(i)];
        const int nv = (T * g.tiles + overlap + 15) / 16; // column vectors the tiles read
        winograd4_columns_avx512(s + g.at, pw, nv, t, T * g.lane);
        if (i + 1 < n) { // the last tile's overlap, before the next segment's overwrite
          const int last = g.lane + g.tiles - 1;
          for (int k = 0; k < overlap; ++k)
            for (int p = 0; p < 6; ++p) kept[k][p][last] = t[p][T * last + T + k];
        }
      }
      float* dst = d + static_cast<std::size_t>(ch) * dc + j;
      if constexpr (T == 4) {
        if (n > 1)
          winograd4_rows_avx512<false, true>(t, 0, dst, xs, fix, kept[0], kept[1]);
        else
          winograd4_rows_avx512<false>(t, 0, dst, xs);
      } else {
        if (n > 1)
          winograd3_rows_avx512<false, true>(t, 0, dst, xs, fix, kept);
        else
          winograd3_rows_avx512<false>(t, 0, dst, xs);
      }
    }
  }
}

// F(4x4)'s z = A^T x on six vectors of tiles (winograd4_at's factored form, its three
// multiply-adds fused as GCC fuses them in the compiled loops).
__attribute__((target("avx512f"))) SHADOWSENSE_ALWAYS_INLINE void
winograd4_at_avx512(const __m512 (&x)[6], __m512 (&z)[4]) {
  const __m512 p = _mm512_add_ps(x[1], x[2]), m = _mm512_sub_ps(x[1], x[2]);
  const __m512 p2 = _mm512_add_ps(x[3], x[4]), m2 = _mm512_sub_ps(x[3], x[4]);
  z[0] = _mm512_add_ps(_mm512_add_ps(x[0], p), p2);
  z[1] = _mm512_fmadd_ps(_mm512_set1_ps(2.0f), m2, m);
  z[2] = _mm512_fmadd_ps(_mm512_set1_ps(4.0f), p2, p);
  z[3] = _mm512_add_ps(_mm512_fmadd_ps(_mm512_set1_ps(8.0f), m2, m), x[5]);
}

// Four vectors of 16 tiles' outputs (z[k]: column k of each tile) to 64 consecutive floats
// (v[c]: tiles 4 c .. 4 c + 3, four columns each): a 4 x 16 transpose by in-lane unpacks and
// 128-bit block shuffles.
__attribute__((target("avx512f"))) SHADOWSENSE_ALWAYS_INLINE void
winograd4_interleave_avx512(const __m512 (&z)[4], __m512 (&v)[4]) {
  const __m512 t0 = _mm512_maskz_unpacklo_ps(0xFFFF, z[0], z[1]); // per 4 tiles: z0 z1 of 0, 1
  const __m512 t1 = _mm512_maskz_unpackhi_ps(0xFFFF, z[0], z[1]); // of 2, 3
  const __m512 t2 = _mm512_maskz_unpacklo_ps(0xFFFF, z[2], z[3]);
  const __m512 t3 = _mm512_maskz_unpackhi_ps(0xFFFF, z[2], z[3]);
  // u[r]: block L holds tile 4 L + r's four columns
  const __m512d a0 = _mm512_castps_pd(t0), a1 = _mm512_castps_pd(t1), a2 = _mm512_castps_pd(t2),
                a3 = _mm512_castps_pd(t3);
  const __m512 u0 = _mm512_castpd_ps(_mm512_maskz_unpacklo_pd(0xFF, a0, a2));
  const __m512 u1 = _mm512_castpd_ps(_mm512_maskz_unpackhi_pd(0xFF, a0, a2));
  const __m512 u2 = _mm512_castpd_ps(_mm512_maskz_unpacklo_pd(0xFF, a1, a3));
  const __m512 u3 = _mm512_castpd_ps(_mm512_maskz_unpackhi_pd(0xFF, a1, a3));
  const __m512 w0 = _mm512_maskz_shuffle_f32x4(0xFFFF, u0, u1, 0x44); // u0.0 u0.1 u1.0 u1.1
  const __m512 w1 = _mm512_maskz_shuffle_f32x4(0xFFFF, u2, u3, 0x44);
  const __m512 w2 = _mm512_maskz_shuffle_f32x4(0xFFFF, u0, u1, 0xEE); // u0.2 u0.3 u1.2 u1.3
  const __m512 w3 = _mm512_maskz_shuffle_f32x4(0xFFFF, u2, u3, 0xEE);
  v[0] = _mm512_maskz_shuffle_f32x4(0xFFFF, w0, w1, 0x88); // u0.0 u1.0 u2.0 u3.0
  v[1] = _mm512_maskz_shuffle_f32x4(0xFFFF, w0, w1, 0xDD); // u0.1 u1.1 u2.1 u3.1
  v[2] = _mm512_maskz_shuffle_f32x4(0xFFFF, w2, w3, 0x88);
  v[3] = _mm512_maskz_shuffle_f32x4(0xFFFF, w2, w3, 0xDD);
}

// A step's segments (winograd_step_segments with the image's row stride w as pw) as places in
// an image of T x T output tiles: where the segment's first output row starts (at, from the
// image's start), that row's index, and which of the step's T x 16 interleaved floats of an
// output row it takes (first, count: T lane .., clipped at the image's right edge, where the
// last tile may hold fewer than T columns).
struct WinogradImageSegment {
  std::ptrdiff_t at = 0;
  int row = 0, first = 0, count = 0;
};
template <int T>
inline int winograd_image_segments(int tiles_x, int t0, int cols, int j, int w,
                                   std::array<WinogradImageSegment, 16>& out) {
  std::array<WinogradSegment, 16> seg{};
  const int n = winograd_step_segments<T>(w, tiles_x, t0, cols, j, seg);
  for (std::size_t g = 0; g < static_cast<std::size_t>(n); ++g) {
    const int tile = t0 + j + seg[g].lane;
    out[g] = {seg[g].at, T * (tile / tiles_x), T * seg[g].lane,
              std::min(T * seg[g].tiles, w - T * (tile % tiles_x))};
  }
  return n;
}

// Output row i of a step (v: its V x 16 floats, the T outputs of each tile in turn, lane order)
// into the segments of image o, one masked store per vector a segment touches; nothing for a
// segment whose row is past the image's bottom (h).
template <int V>
__attribute__((target("avx512f"))) SHADOWSENSE_ALWAYS_INLINE void
winograd_store_image_row_avx512(const __m512 (&v)[V],
                                const std::array<WinogradImageSegment, 16>& seg, int n, int i,
                                int h, int w, float* o) {
  for (std::size_t g = 0; g < static_cast<std::size_t>(n); ++g) {
    const WinogradImageSegment& s = seg[g];
    if (s.row + i >= h) continue;
    const std::uintptr_t dst =
        reinterpret_cast<std::uintptr_t>(o + s.at + static_cast<std::ptrdiff_t>(i) * w);
    for (int c = 0; c < V; ++c) {
      const int lo = std::max(s.first, 16 * c), hi = std::min(s.first + s.count, 16 * c + 16);
      if (lo >= hi) continue;
      const auto mask = static_cast<__mmask16>(((1u << (hi - lo)) - 1) << (lo - 16 * c));
      // Float 16 c + e to dst + (16 c + e - first): an address only (the mask skips e < lo).
      const auto at = reinterpret_cast<float*>(
          dst + static_cast<std::uintptr_t>(static_cast<std::intptr_t>(16 * c - s.first) *
                                            static_cast<std::intptr_t>(sizeof(float))));
      _mm512_mask_storeu_ps(at, mask, v[c]);
    }
  }
}

// F(4x4)'s output transform and the interleave into the image in one (WinogradOps::
// output4_image): 16 tiles a step, A^T M A in registers (the compiled loops' output4 goes through
// a stack array, then interleave4 gathers its rows), each output row's 16 x 4 values transposed
// to 64 consecutive floats and stored with one mask per segment of tiles in one tile row; the
// step's segments found once for all the output channels.
__attribute__((target("avx512f"))) inline void
winograd_output4_image_avx512(const WinogradImageOutput& a) {
  std::array<WinogradImageSegment, 16> seg{};
  for (int j = 0; j < a.cols; j += 16) {
    const int n = winograd_image_segments<4>(a.tiles_x, a.t0, a.cols, j, a.w, seg);
    for (int r = 0; r < a.rows; ++r) {
      const float* m = a.m + static_cast<std::size_t>(r) * a.mc + j;
      __m512 s[4][6]; // A^T M: row i of the tiles' 4 x 6
      for (int q = 0; q < 6; ++q) {
        __m512 x[6], z[4];
        for (int p = 0; p < 6; ++p)
          x[p] = _mm512_loadu_ps(m + static_cast<std::size_t>(6 * p + q) * a.xs);
        winograd4_at_avx512(x, z);
        for (int i = 0; i < 4; ++i) s[i][q] = z[i];
      }
      float* o = a.o + static_cast<std::size_t>(r) * a.image;
      for (int i = 0; i < 4; ++i) {
        __m512 z[4], v[4];
        winograd4_at_avx512(s[i], z);
        winograd4_interleave_avx512(z, v);
        winograd_store_image_row_avx512(v, seg, n, i, a.h, a.w, o);
      }
    }
  }
}
#endif

struct WinogradOps {
  using Input = void (*)(const float*, std::size_t, int, int, int, int, float*, std::size_t,
                         std::size_t);
  using Output = void (*)(const float*, std::size_t, int, float*);
  Input input;                                                     // F(2x2)
  Output output;                                                   // F(2x2)
  void (*interleave)(const float*, const float*, float*, int);     // F(2x2)
  Input input4;                                                    // F(4x4)
  Output output4;                                                  // F(4x4)
  void (*interleave4)(const float*, float*, int);                  // F(4x4)
  Input input3;                                                    // F(3x3, 4x4)
  Output output3;                                                  // F(3x3, 4x4)
  void (*interleave3_bias_relu)(const float*, float*, int, float); // F(3x3, 4x4)
  // F(2x2) and F(4x4), optional: a whole tile panel's input transform (the header comment).
  using PanelInput = void (*)(const float*, std::size_t, int, int, int, int, int, float*,
                              std::size_t, std::size_t);
  PanelInput input_panel = nullptr;
  PanelInput input4_panel = nullptr;
  PanelInput input3_panel = nullptr;
  // F(4x4), optional (AVX-512 only; when null, output4 then interleave4 per run): the output
  // transform of a tile panel written straight into the image (the header comment).
  void (*output4_image)(const WinogradImageOutput&) = nullptr;
  // Whether a tile gets the same bits at any column of a panel: the x86 sets (tested bit for
  // bit). Not the portable loops: compiled for aarch64, the compiler fuses multiplies and adds
  // differently in a loop's vector body and in its tail, so there a tile's bits depend on where
  // in a run it falls (tile ranges at 2 and 3 threads differed from 1 thread under qemu).
  bool same_bits_anywhere = false;
};

inline WinogradOps select_winograd_ops(GemmKernelKind kind) {
#if SHADOWSENSE_X86_KERNELS
  if (kind == GemmKernelKind::avx512)
    return {&winograd_input_avx512,
            &winograd_output_avx512_loops,
            &winograd_interleave_avx512_loops,
            &winograd_input6_avx512<4>,
            &winograd_output6_avx512_loops<4>,
            &winograd_interleave4_avx512_loops,
            &winograd_input6_avx512<3>,
            &winograd_output3_avx512,
            &winograd_interleave3_bias_relu_avx512,
            &winograd_input_panel_avx512,
            &winograd_input6_panel_avx512<4>,
            &winograd_input6_panel_avx512<3>,
            &winograd_output4_image_avx512,
            true};
  if (kind == GemmKernelKind::avx2) {
    WinogradOps ops{&winograd_input_avx2_loops,
                    &winograd_output_avx2_loops,
                    &winograd_interleave_avx2_loops,
                    &winograd_input4_avx2,
                    &winograd_output6_avx2_loops<4>,
                    &winograd_interleave4_avx2_loops,
                    &winograd_input6_avx2_loops<3>,
                    &winograd_output6_avx2_loops<3>,
                    &winograd_interleave3_bias_relu_avx2_loops};
    ops.same_bits_anywhere = true; // (no panel transforms: those stay null)
    return ops;
  }
#endif
  (void)kind; // NEON is aarch64's baseline: the portable loops compile to it
  return {&winograd_input_portable,
          &winograd_output_portable,
          &winograd_interleave_portable,
          &winograd_input6_portable<4>,
          &winograd_output6_portable<4>,
          &winograd_interleave4_portable,
          &winograd_input6_portable<3>,
          &winograd_output6_portable<3>,
          &winograd_interleave3_bias_relu_portable};
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
  std::vector<float> v; // up to 36 slabs of c x nr transformed patches (winograd_slab apart)
  std::vector<float> m; // up to 36 blocks of m x nr products (winograd_products apart)
  std::vector<float> y; // 16 x winograd_max_run outputs of one channel
};

inline WinogradScratch make_winograd_scratch(int c, int m, const MicroKernel& kernel) {
  require(kernel.nr >= 1 && kernel.nr <= winograd_max_run,
          "Winograd: the micro-kernel's nr is " + std::to_string(kernel.nr) + ", expected 1.." +
              std::to_string(winograd_max_run));
  WinogradScratch s;
  s.v.assign(winograd_max_products * winograd_slab(c, kernel.nr), 0.0f);
  s.m.assign(winograd_max_products * winograd_products(m, kernel), 0.0f);
  s.y.assign(16 * static_cast<std::size_t>(winograd_max_run), 0.0f);
  return s;
}

// winograd_conv3x3 (T = 2, 4) and winograd_conv4x4 (T = 3, with bias and ReLU) for one tile
// size T.
template <int T>
void winograd_conv_tile(const MicroKernel& kernel, const WinogradOps& ops, const WinogradWeights& u,
                        const float* in, int pw, std::size_t plane, int h, int w, const float* bias,
                        float* out, ThreadPool& pool, std::vector<WinogradScratch>& scratch) {
  constexpr int products = winograd_alpha(T) * winograd_alpha(T);
  const int nr = kernel.nr, mr = kernel.mr, c = u.c;
  const int tiles_x = (w + T - 1) / T, tiles = (h + T - 1) / T * tiles_x;
  const int n_panels = (tiles + nr - 1) / nr, m_panels = (u.m + mr - 1) / mr;
  const std::size_t xs_v = winograd_slab(c, nr);           // V_xi slab: c x nr (+ a line)
  const std::size_t xs_m = winograd_products(u.m, kernel); // M_xi block: m x nr (+ a line)
  const std::size_t image = static_cast<std::size_t>(h) * w;
  const auto input = T == 2 ? ops.input : T == 4 ? ops.input4 : ops.input3;
  const auto output = T == 2 ? ops.output : T == 4 ? ops.output4 : ops.output3;
  // Tiles t0 .. t0 + cols - 1 (cols <= nr) times row panels mp0 .. mp1 - 1, on thread t.
  auto panel = [&](int t, int t0, int cols, int mp0, int mp1) {
    WinogradScratch& s = scratch[static_cast<std::size_t>(t)];
    // The transformed patches of every channel. Columns cols..nr-1 of the slabs keep older
    // values: the kernel's output columns are independent, and those columns are dropped.
    const auto panel_input = T == 2   ? ops.input_panel
                             : T == 4 ? ops.input4_panel
                                      : ops.input3_panel;
    if (panel_input && nr % 16 == 0)
      panel_input(in, plane, c, pw, tiles_x, t0, cols, s.v.data(), static_cast<std::size_t>(nr),
                  xs_v);
    else
      for (int j = 0; j < cols;) { // runs within one tile row
        const int ty = (t0 + j) / tiles_x, tx = (t0 + j) % tiles_x;
        const int run = std::min(cols - j, tiles_x - tx);
        input(in + static_cast<std::size_t>(T * ty) * pw + T * tx, plane, c, pw, run, nr - j,
              s.v.data() + j, static_cast<std::size_t>(nr), xs_v);
        j += run;
      }
    // xi outer: each V_xi slab stays in L1 while every row panel multiplies it.
    // (A last panel of few tiles, or a last row panel of at most mr / 2 output channels, runs
    // the narrowest kernel that covers it where there is one: tile_kernel.)
    for (std::size_t xi = 0; xi < products; ++xi)
      for (int mp = mp0; mp < mp1; ++mp)
        tile_kernel(kernel, u.m - mp * mr,
                    cols)(c, u.u[xi].panel(mp), s.v.data() + xi * xs_v,
                          s.m.data() + xi * xs_m + static_cast<std::size_t>(mp) * mr * nr);
    for (int mp = mp0; mp < mp1; ++mp) {
      const int rows = std::min(mr, u.m - mp * mr);
      if (T == 4 && ops.output4_image && nr % 16 == 0) {
        ops.output4_image({s.m.data() + static_cast<std::size_t>(mp * mr) * nr, xs_m,
                           static_cast<std::size_t>(nr), rows, tiles_x, t0, cols, h, w,
                           out + static_cast<std::size_t>(mp * mr) * image, image});
        continue;
      }
      for (int r = 0; r < rows; ++r) {
        output(s.m.data() + static_cast<std::size_t>(mp * mr + r) * nr, xs_m, cols, s.y.data());
        float* o = out + static_cast<std::size_t>(mp * mr + r) * image;
        const float* y = s.y.data();
        for (int j = 0; j < cols;) { // runs within one tile row: T output rows each
          const int ty = (t0 + j) / tiles_x, tx = (t0 + j) % tiles_x;
          const int run = std::min(cols - j, tiles_x - tx);
          const int n = std::min(T * run, w - T * tx); // output columns (the last tile: fewer)
          for (int i = 0; i < T && T * ty + i < h; ++i) {
            float* row = o + static_cast<std::size_t>(T * ty + i) * w + T * tx;
            const float* yi = y + static_cast<std::size_t>(T * i) * winograd_max_run + j;
            if constexpr (T == 2)
              ops.interleave(yi, yi + winograd_max_run, row, n);
            else if constexpr (T == 4)
              ops.interleave4(yi, row, n);
            else
              ops.interleave3_bias_relu(yi, row, n, bias[mp * mr + r]);
          }
          j += run;
        }
      }
    }
  };
  // Where a tile gets the same bits at any offset (the x86 transforms), each thread takes a
  // range of tiles with every row panel, the ranges' ends on multiples of the narrowest kernel
  // (run_column_ranges): (tile panel, row panel) units in equal shares gave DenseNet-121's
  // block 3 (12 tiles, one panel) to both threads, each transforming the whole panel (1.45 ms a
  // pass at 2 threads, 1.04 ms by tiles), and its block 2 (35 tiles: panels of 32 and 3) to one
  // thread nearly alone. The portable and NEON transforms keep the unit split.
  if (ops.same_bits_anywhere)
    run_column_ranges(pool, tiles, nr, kernel.step,
                      [&](int t, int t0, int cols) { panel(t, t0, cols, 0, m_panels); });
  else
    run_panel_units(pool, n_panels, m_panels, [&](int t, int np, int mp0, int mp1) {
      panel(t, np * nr, std::min(nr, tiles - np * nr), mp0, mp1);
    });
}

inline void winograd_conv3x3(const MicroKernel& kernel, const WinogradOps& ops,
                             const WinogradWeights& u, const float* in, int pw, std::size_t plane,
                             int h, int w, float* out, ThreadPool& pool,
                             std::vector<WinogradScratch>& scratch) {
  require(u.tile == 2 || u.tile == 4, "Winograd: the weights are not set for a 3x3 convolution");
  if (u.tile == 2)
    winograd_conv_tile<2>(kernel, ops, u, in, pw, plane, h, w, nullptr, out, pool, scratch);
  else
    winograd_conv_tile<4>(kernel, ops, u, in, pw, plane, h, w, nullptr, out, pool, scratch);
}

inline void winograd_conv4x4(const MicroKernel& kernel, const WinogradOps& ops,
                             const WinogradWeights& u, const float* in, int pw, std::size_t plane,
                             int h, int w, const float* bias, float* out, ThreadPool& pool,
                             std::vector<WinogradScratch>& scratch) {
  require(u.tile == 3, "Winograd: the weights are not set for F(3x3, 4x4)");
  winograd_conv_tile<3>(kernel, ops, u, in, pw, plane, h, w, bias, out, pool, scratch);
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
