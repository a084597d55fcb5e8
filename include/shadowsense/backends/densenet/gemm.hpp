// Packed single-precision GEMM for the DenseNet forward pass: C (M x N) = A (M x K) * B (K x N)
// with A (the weights) packed once at load time and B produced panel by panel by a caller's
// "packer" (fused im2col / BatchNorm+ReLU / average pooling), so no im2col matrix is ever
// materialised. This header is the dispatch and the driver; the kernels live apart:
//   gemm_reference.hpp  plain loops, the oracle every other kernel is tested against
//   gemm_portable.hpp   C++ the compiler vectorises for its target (any CPU)
//   gemm_x86.hpp        AVX-512 and AVX2+FMA intrinsics, picked at run time (no -march needed)
//   gemm_neon.hpp       aarch64 Advanced SIMD intrinsics, compiled in on aarch64
// Summation order differs from PyTorch's only by float rounding.
//
// GemmKernelKind: which micro-kernel (and matching element-wise loops) the forward pass uses.
//   automatic picks the fastest the CPU runs: avx512, avx2, then portable on x86; neon on
//   aarch64; portable elsewhere.
// cpu_has(kind): true when kind is compiled in and the CPU runs it (automatic: false).
// select_micro_kernel(kind) / select_vector_ops(kind)
//   requires: kind is automatic or cpu_has(kind); throws InvalidArgument otherwise.
//   ensures:  the kernel's tile (mr x nr), function and name; its element-wise loops.
// available_kernels(): every kind cpu_has() accepts, fastest first, reference last.
// PackedMatrix::pack(w, rows, cols, panel_rows): packs a row-major rows x cols matrix into
//   panel_rows-row panels (K x MR interleaved, zero-padded). Not thread-safe while packing;
//   read-only use afterwards may be shared between threads. unpack() returns that matrix again.
// ThreadPool: backends/densenet/thread_pool.hpp.
// gemm(kernel, a, n, pack, store, pool, scratch): see below; scratch holds pool.size() entries
//   sized for the largest K (K x nr panel, mr x nr tile, nr ints); scratch[0].shared grows on
//   the first multi-thread call with few column panels (every B panel packed once) and is reused.
// MicroKernel::narrow, half_rows (optional): kernels for the first multiples of step columns
//   and / or mr / 2 rows only; gemm() and the Winograd GEMMs run the narrowest that covers a
//   last panel (tile_kernel), doing only those multiply-adds.
// gemm_fused_avx512(a, n, pack, base, offsets, segments, dst, row_stride, bias, relu, pool,
//   scratch): gemm() on the AVX-512 kernel with no tile and no store calls (or, offsets set, with
//   B read in place at base + n0 + offsets[k], nothing packed: the direct 3x3 convolution):
//   the kernel adds the bias, applies ReLU and writes each row from its registers, laid out by
//   the caller's segments (image_row_segments: e.g. into a zero-padded grid, or dropping a
//   padded grid's pad columns). Requires has_fused_stores(kernel) for the kernel in use.
// gemm_in_place_avx2(a, n, base, offsets, store, pool, scratch): gemm() on the AVX2 kernel with
//   B read in place at base + n0 + offsets[k] (24 readable floats each), nothing packed.
//   Requires has_in_place_avx2(kernel) for the kernel in use.
#pragma once

#include <shadowsense/backends/densenet/gemm_neon.hpp>
#include <shadowsense/backends/densenet/gemm_portable.hpp>
#include <shadowsense/backends/densenet/gemm_reference.hpp>
#include <shadowsense/backends/densenet/gemm_x86.hpp>
#include <shadowsense/backends/densenet/thread_pool.hpp>
#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// Which GEMM micro-kernel the forward pass uses. automatic picks the best one the CPU runs.
enum class GemmKernelKind { automatic, avx512, avx2, portable, reference, neon };

namespace detail {

using MicroKernelFn = void (*)(int K, const float* a, const float* b, float* out);

struct MicroKernel {
  GemmKernelKind kind;
  int mr; // rows of C per tile (A panel height)
  int nr; // columns of C per tile (B panel width)
  MicroKernelFn fn;
  const char* name;
  // Optional narrower variants (out's other columns and rows untouched, the same values in
  // the rest), for a last column panel of few columns or a last row panel of at most mr / 2
  // rows: with step > 0, narrow[i] is fn for the first (i + 1) * step columns only (i + 1 <
  // nr / step); half_rows[i] is narrow[i] (half_rows[nr / step - 1]: fn) for the first mr / 2
  // rows only. Null entries fall back to the next wider variant, then to fn.
  int step = 0;
  MicroKernelFn narrow[3] = {};
  MicroKernelFn half_rows[4] = {};
};

// The kernel for a tile whose first `rows` rows and `cols` columns are used: the variant with
// the least work that covers them (each gives those rows and columns the same values).
inline MicroKernelFn tile_kernel(const MicroKernel& k, int rows, int cols) {
  if (k.step <= 0) return k.fn;
  const int widths = k.nr / k.step; // variants of 1 .. widths steps
  const bool few_rows = rows <= k.mr / 2;
  for (int i = std::clamp((cols + k.step - 1) / k.step, 1, widths) - 1; i < widths; ++i) {
    const MicroKernelFn f = few_rows ? k.half_rows[i] : i + 1 < widths ? k.narrow[i] : nullptr;
    if (f) return f;
  }
  return k.fn;
}

// The element-wise loops of the forward pass, one set per kernel kind:
//   affine_relu(s, d, n, sc, sh):  d[i] = relu(s[i] * sc + sh), i < n
//   bias_relu(s, d, n, b):         d[i] = relu(s[i] + b)
//   pool_affine_relu(r0, r1, d, n, sc, sh): d[j] = mean of relu(x * sc + sh) over the 2x2
//                                  window r0[2j], r0[2j+1], r1[2j], r1[2j+1]
//   pack3x3(s, d, cols, nr, pw):   9 rows of nr floats, row ky*3+kx = s[ky*pw + kx + j] for
//                                  j < cols, 0 beyond
//   pack_affine_relu(s, stride, channels, sc, sh, d, cols, nr): a 1x1 convolution's input
//                                  panel, d[c * nr + j] = relu(s[c * stride + j] * sc[c] +
//                                  sh[c]) for j < cols, 0 for cols <= j < nr, c < channels
//                                  (affine_relu per channel in one call; optional: when null,
//                                  the forward pass calls affine_relu per channel)
//   max_pool3s2(s, h0, w0, bh, bw, vm, vs, d): pool0, max 3x3, stride 2, padding 1, of the
//                                  h0 x w0 plane s into the bh x bw plane d (bh = (h0 - 1) / 2
//                                  + 1, likewise bw): d = the window's max (std::max in row
//                                  order, then columns 2x - 1, 2x, 2x + 1), unless the window's
//                                  sum (per column over its rows in order, then the three
//                                  column sums in order) is NaN, when d is that sum (a NaN in
//                                  the window wins; the inputs are >= 0 after ReLU, so the sum
//                                  is NaN exactly then). vm, vs: scratch rows of w0 + 2 floats
//                                  each, from vm[-1] and vs[-1]. Bit for bit the same in every
//                                  kernel (optional: when null, max_pool3s2_portable)
// Sources and destinations never overlap. relu(NaN) is NaN.
struct VectorOps {
  void (*affine_relu)(const float*, float*, int, float, float);
  void (*bias_relu)(const float*, float*, int, float);
  void (*pool_affine_relu)(const float*, const float*, float*, int, float, float);
  void (*pack3x3)(const float*, float*, int, int, int);
  void (*pack_affine_relu)(const float*, std::size_t, int, const float*, const float*, float*, int,
                           int) = nullptr;
  void (*max_pool3s2)(const float*, int, int, int, int, float*, float*, float*) = nullptr;
};

// pack_affine_relu from a kind's affine_relu (direct calls, no per-channel pointer call).
template <void (*AffineRelu)(const float*, float*, int, float, float)>
inline void pack_affine_relu_with(const float* s, std::size_t stride, int channels, const float* sc,
                                  const float* sh, float* d, int cols, int nr) {
  for (int c = 0; c < channels; ++c, s += stride, d += nr) {
    AffineRelu(s, d, cols, sc[c], sh[c]);
    for (int j = cols; j < nr; ++j) d[j] = 0.0f;
  }
}

inline bool cpu_has(GemmKernelKind kind) {
  switch (kind) {
  case GemmKernelKind::portable:
  case GemmKernelKind::reference:
    return true;
#if SHADOWSENSE_X86_KERNELS
  case GemmKernelKind::avx512:
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
           __builtin_cpu_supports("fma");
  case GemmKernelKind::avx2:
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#endif
#if SHADOWSENSE_NEON_KERNELS
  case GemmKernelKind::neon:
    return true;
#endif
  default:
    return false;
  }
}

inline std::vector<GemmKernelKind> available_kernels() {
  std::vector<GemmKernelKind> out;
  for (auto k : {GemmKernelKind::avx512, GemmKernelKind::avx2, GemmKernelKind::neon,
                 GemmKernelKind::portable, GemmKernelKind::reference})
    if (cpu_has(k)) out.push_back(k);
  return out;
}

inline GemmKernelKind resolve_kernel(GemmKernelKind wanted) {
  if (wanted != GemmKernelKind::automatic) {
    require(cpu_has(wanted), "GEMM kernel: the requested kernel is not supported by this CPU or "
                             "compiler, expected automatic or one the CPU runs");
    return wanted;
  }
  return available_kernels().front();
}

inline VectorOps select_vector_ops(GemmKernelKind kind) {
  switch (resolve_kernel(kind)) {
#if SHADOWSENSE_X86_KERNELS
  case GemmKernelKind::avx512:
    return {&affine_relu_avx512, &bias_relu_avx512,        &pool_affine_relu_avx512,
            &pack3x3_avx512,     &pack_affine_relu_avx512, &max_pool3s2_avx512};
  case GemmKernelKind::avx2:
    return {&affine_relu_avx2, &bias_relu_avx2, &pool_affine_relu_avx2, &pack3x3_avx2,
            &pack_affine_relu_avx2};
#endif
#if SHADOWSENSE_NEON_KERNELS
  case GemmKernelKind::neon:
    return {&affine_relu_neon, &bias_relu_neon, &pool_affine_relu_neon, &pack3x3_neon,
            &pack_affine_relu_with<&affine_relu_neon>};
#endif
  case GemmKernelKind::reference:
    return {&affine_relu_reference, &bias_relu_reference, &pool_affine_relu_reference,
            &pack3x3_reference};
  default:
    return {&affine_relu_portable, &bias_relu_portable, &pool_affine_relu_portable,
            &pack3x3_portable, &pack_affine_relu_with<&affine_relu_portable>};
  }
}

inline MicroKernel select_micro_kernel(GemmKernelKind wanted) {
  const GemmKernelKind kind = resolve_kernel(wanted);
  switch (kind) {
#if SHADOWSENSE_X86_KERNELS
  case GemmKernelKind::avx512:
    return {kind,
            8,
            32,
            &micro_kernel_avx512,
            "avx512",
            8,
            {&micro_kernel_avx512_cols<8>, &micro_kernel_avx512_cols<16>,
             &micro_kernel_avx512_cols<24>},
            {&micro_kernel_avx512_cols<8, 4>, &micro_kernel_avx512_cols<16, 4>,
             &micro_kernel_avx512_cols<24, 4>, &micro_kernel_avx512_cols<32, 4>}};
  case GemmKernelKind::avx2:
    return {kind,
            4,
            24,
            &micro_kernel_avx2,
            "avx2+fma",
            8,
            {&micro_kernel_avx2_cols<8>, &micro_kernel_avx2_cols<16>}};
#endif
#if SHADOWSENSE_NEON_KERNELS
  case GemmKernelKind::neon:
    return {kind,
            8,
            12,
            &micro_kernel_neon<12>,
            "neon",
            4,
            {&micro_kernel_neon<4>, &micro_kernel_neon<8>}};
#endif
  case GemmKernelKind::reference:
    return {kind, 4, 8, &micro_kernel_reference<4, 8>, "reference"};
  default:
    return {GemmKernelKind::portable, portable_mr, portable_nr,
            &micro_kernel_portable<portable_mr, portable_nr>, "portable"};
  }
}

// Weights (M x K, row-major) packed into MR-row panels, K x MR interleaved, zero-padded.
struct PackedMatrix {
  int m = 0, k = 0, mr = 0;
  std::vector<float> data;

  void pack(const float* w, int rows, int cols, int panel_rows) {
    m = rows;
    k = cols;
    mr = panel_rows;
    const int panels = (m + mr - 1) / mr;
    data.assign(static_cast<std::size_t>(panels) * mr * k, 0.0f);
    for (int p = 0; p < panels; ++p)
      for (int r = 0; r < mr && p * mr + r < m; ++r)
        for (int c = 0; c < k; ++c)
          data[(static_cast<std::size_t>(p) * k + c) * mr + r] =
              w[static_cast<std::size_t>(p * mr + r) * k + c];
  }
  const float* panel(int p) const { return data.data() + static_cast<std::size_t>(p) * k * mr; }
  // The m x k row-major matrix pack() was given.
  std::vector<float> unpack() const {
    std::vector<float> w(static_cast<std::size_t>(m) * k);
    for (int r = 0; r < m; ++r)
      for (int c = 0; c < k; ++c)
        w[static_cast<std::size_t>(r) * k + c] =
            data[(static_cast<std::size_t>(r / mr) * k + c) * mr + r % mr];
    return w;
  }
};

// A 1x1 convolution's m x k weights laid out for the pixel-rows GEMM (gemm_pixel_rows_avx512):
// panels of 32 output channels, each k x 32, channel p * 32 + j of input c at
// data[(p * k + c) * 32 + j] (0 for channels >= m).
struct PixelRowWeights {
  static constexpr int nr = 32;
  int m = 0, k = 0;
  std::vector<float> data;

  bool empty() const { return data.empty(); }
  // w: m x k row-major.
  void set(const float* w, int rows, int cols) {
    m = rows;
    k = cols;
    const int panels = (m + nr - 1) / nr;
    data.assign(static_cast<std::size_t>(panels) * k * nr, 0.0f);
    for (int o = 0; o < m; ++o)
      for (int c = 0; c < k; ++c)
        data[(static_cast<std::size_t>(o / nr) * k + c) * nr + o % nr] =
            w[static_cast<std::size_t>(o) * k + c];
  }
  const float* panel(int p) const { return data.data() + static_cast<std::size_t>(p) * k * nr; }
};

// FMA instructions per input channel of a 1x1 convolution's GEMM with m output channels over
// n pixels on the AVX-512 kernels: channel rows (gemm_fused_avx512: 8 channels a row panel,
// 4 for a last one of at most 4; 32 pixels a column panel, two 512-bit FMAs a row for more
// than 16 columns, one for 16 or fewer) or pixel rows (gemm_pixel_rows_avx512: 8 pixels a
// row, 4 for a last one of at most 4; 32 channels two FMAs a row, 16 or fewer one). On a core
// with full-width 512-bit units a 24-column panel costs as much as a 32-column one
// (docs/densenet.md), so this count is the multiply-add time.
inline long conv1x1_fmas(int m, int n, bool pixel_rows) {
  auto side = [](int count, int width, int half) { // rows of the kernel's 8-row side
    return long(count / width) * width + (count % width == 0      ? 0
                                          : count % width <= half ? half
                                                                  : width);
  };
  auto lanes = [](int count) { // FMAs a kernel row over count columns, 32 a panel
    return long(count / 32) * 2 + (count % 32 == 0 ? 0 : count % 32 <= 16 ? 1 : 2);
  };
  return pixel_rows ? side(n, 8, 4) * lanes(m) : side(m, 8, 4) * lanes(n);
}

// Whether pixel rows do at least 5% fewer FMAs than channel rows (DenseNet-121 at 3 x 150 x
// 220: blocks 3 (117 pixels, 0.94x) and 4 (24 pixels, 0.75x); the shipped model's block 3 (50
// pixels, 48 channels: 0.81x)); both give every output the same bits.
inline bool pixel_rows_pay(int m, int n) {
  return 20 * conv1x1_fmas(m, n, true) <= 19 * conv1x1_fmas(m, n, false);
}

// Splits the (column panel, row panel) units of a GEMM, column panel major, into equal
// contiguous shares over the pool's threads and calls fn(t, np, mp0, mp1) for each run of row
// panels mp0..mp1-1 of column panel np in thread t's share (5 column panels x 4 row panels
// split 10 / 10, where whole column panels would split 3 / 2).
template <class Fn>
inline void run_panel_units(ThreadPool& pool, int n_panels, int m_panels, Fn&& fn) {
  const long units = long(n_panels) * m_panels;
  const int tasks = static_cast<int>(std::min<long>(pool.size(), units));
  auto task = [&](int t) {
    const long u0 = units * t / tasks, u1 = units * (t + 1) / tasks;
    for (long u = u0; u < u1;) {
      const int np = static_cast<int>(u / m_panels), mp0 = static_cast<int>(u % m_panels);
      const int mp1 = static_cast<int>(std::min<long>(m_panels, mp0 + (u1 - u)));
      fn(t, np, mp0, mp1);
      u += mp1 - mp0;
    }
  };
  pool.run(tasks, task);
}

// Splits n columns into contiguous ranges over the pool's threads and calls fn(t, n0, cols) for
// each run of at most nr columns of thread t's range, in order: each thread prepares only its
// own columns (12 columns over 2 threads: 0-8 and 8-12, where run_panel_units would give both
// threads the one panel). The boundary between threads t - 1 and t is the multiple of step
// nearest to n * t / threads (step: the kernel's narrowest width, MicroKernel::step), so each
// thread's share of kernel steps is near half (two threads): 35 columns in steps of 8 are 0-16
// and 16-35 (two and three steps: 16- and 24-column kernels), where whole panels are 32 and 3
// (four steps and one).
inline int column_range_start(int n, int tasks, int t, int step) {
  const long s = std::max(step, 1);
  return static_cast<int>(std::min<long>(n, (long(n) * t * 2 + tasks * s) / (tasks * s * 2) * s));
}
template <class Fn>
inline void run_column_ranges(ThreadPool& pool, int n, int nr, int step, Fn&& fn) {
  const int tasks = std::min(pool.size(), n);
  auto task = [&](int t) {
    const int c0 = column_range_start(n, tasks, t, step);
    const int c1 = t + 1 == tasks ? n : column_range_start(n, tasks, t + 1, step);
    for (int n0 = c0; n0 < c1; n0 += nr) fn(t, n0, std::min(nr, c1 - n0));
  };
  pool.run(tasks, task);
}

// Per-thread scratch of the GEMM driver.
struct GemmScratch {
  std::vector<float> panel;  // K x NR
  std::vector<float> tile;   // MR x NR
  std::vector<int> index;    // NR ints for packers (pixel offsets)
  TileSegments segments;     // the fused kernels' column runs for the current column panel
  int cols = 0;              // columns of the current column panel
  std::vector<float> shared; // (thread 0's only) every B panel of a row-split gemm(), packed once
  bool a_cold = false;       // gemm_over_panels: no column panel of this call's A done yet
};

// Row panel mp of A towards the cache (prefetch_range_for_read), to be multiplied soon.
inline void prefetch_a_panel(const PackedMatrix& a, int mp) {
  prefetch_range_for_read(a.panel(mp), static_cast<std::size_t>(a.k) * a.mr * sizeof(float));
}

// The split shared by gemm() and gemm_fused_avx512(). For every column panel, prepare(s, n0, cols)
// readies B in the thread's scratch s, then multiply(mp, s, n0) writes the MR x NR tile of row
// panel mp to s.tile, and store(m, n0, cols, row) takes its rows.
// - B packed (prepare does work): column panels over the pool's threads when there are at least
//   8 per thread, so each panel is packed once; row panels otherwise (each thread packs every
//   panel and reads its share of A).
// - B read in place (free_prepare): the (column panel, row panel) tiles, column-major, in equal
//   contiguous shares: 5 column panels x 4 row panels split 10 / 10 where column panels alone
//   would split 2 / 3.
template <class Prepare, class Multiply, class Store>
inline void gemm_over_panels(const MicroKernel& kernel, const PackedMatrix& a, int n,
                             Prepare&& prepare, Multiply&& multiply, Store&& store,
                             ThreadPool& pool, std::vector<GemmScratch>& scratch,
                             bool free_prepare = false) {
  const int nr = kernel.nr, mr = kernel.mr;
  const int n_panels = (n + nr - 1) / nr;
  const int m_panels = (a.m + mr - 1) / mr;
  const int threads = pool.size();
  // A thread's first column panel reads its rows of A from beyond the L2: a large DenseNet's
  // weights (32 MB for DenseNet-121) do not stay in the caches from one pass to the next (its
  // stages take 2-25% longer in a pass than each repeated alone). So there, row panel mp0 is
  // asked for before B is packed and each next one while the one before it is multiplied
  // (docs/densenet.md, "A's row panels prefetched"). Later column panels find A in the L2.
  auto tile = [&](GemmScratch& s, int np, int mp0, int mp1) {
    const int n0 = np * nr;
    const int cols = std::min(nr, n - n0);
    const bool cold = s.a_cold;
    if (cold) prefetch_a_panel(a, mp0);
    prepare(s, n0, cols);
    for (int mp = mp0; mp < mp1; ++mp) {
      if (cold && mp + 1 < mp1) prefetch_a_panel(a, mp + 1);
      multiply(mp, s, n0);
      const int rows = std::min(mr, a.m - mp * mr);
      for (int r = 0; r < rows; ++r) store(mp * mr + r, n0, cols, s.tile.data() + r * nr);
    }
    s.a_cold = false;
  };
  // Set here, before the pool runs the tasks (which orders this write before their reads).
  for (int t = 0; t < threads; ++t) scratch[static_cast<std::size_t>(t)].a_cold = true;
  if (free_prepare) {
    run_panel_units(pool, n_panels, m_panels, [&](int t, int np, int mp0, int mp1) {
      tile(scratch[static_cast<std::size_t>(t)], np, mp0, mp1);
    });
    return;
  }
  // Split by column panels, each thread streaming all of A once per panel of its share, only
  // where there are many of them; otherwise by row panels, each thread packing every B panel
  // but reading its share of A. A 1x1 convolution of DenseNet-161's block 3 (4 column panels,
  // A up to 192 x 2112 floats) took 6.9 ms per pass at 2 threads split by columns and 6.1 ms by
  // rows (11.3 ms at 1 thread); block 2 (17 column panels) is the same either way.
  const bool split_n = n_panels >= 8 * threads || m_panels < threads;
  const int tasks = split_n ? std::min(threads, n_panels) : threads;
  auto task = [&](int t) {
    auto& s = scratch[static_cast<std::size_t>(t)];
    int np0 = 0, np1 = n_panels, mp0 = 0, mp1 = m_panels;
    if (split_n) {
      np0 = n_panels * t / tasks;
      np1 = n_panels * (t + 1) / tasks;
    } else {
      mp0 = m_panels * t / tasks;
      mp1 = m_panels * (t + 1) / tasks;
    }
    for (int np = np0; np < np1; ++np) tile(s, np, mp0, mp1);
  };
  pool.run(tasks, task);
}

// C = A * B where B is produced by pack(float* dst, int n0, int nr, int* index_scratch): it
// writes B[:, n0 : n0+nr] as a K x NR panel (columns >= nr zero). store(m, n0, nr, row) writes
// the nr results of row m. Work is split over threads by column panels, or by row panels when
// there are too few column panels (then every B panel is packed once, by one thread, before the
// rows are multiplied).
template <class Pack, class Store>
inline void gemm(const MicroKernel& kernel, const PackedMatrix& a, int n, Pack&& pack,
                 Store&& store, ThreadPool& pool, std::vector<GemmScratch>& scratch) {
  const int nr = kernel.nr, mr = kernel.mr, threads = pool.size();
  const int n_panels = (n + nr - 1) / nr, m_panels = (a.m + mr - 1) / mr;
  // Where gemm_over_panels would split by rows (few column panels), every thread would pack
  // every B panel. Pack each panel once instead, the panels spread over the threads, into one
  // shared buffer; then each thread multiplies its rows by all of them. Two pool calls instead
  // of one; the buffer grows on the first such call and is reused (no allocation after it).
  if (threads > 1 && n_panels >= 1 && n_panels < 8 * threads && m_panels >= threads) {
    const std::size_t stride = static_cast<std::size_t>(a.k) * nr;
    std::vector<float>& shared = scratch[0].shared;
    if (shared.size() < stride * n_panels) shared.resize(stride * n_panels);
    const int packers = std::min(threads, n_panels);
    auto pack_share = [&](int t) {
      for (int np = n_panels * t / packers; np < n_panels * (t + 1) / packers; ++np)
        pack(shared.data() + stride * np, np * nr, std::min(nr, n - np * nr),
             scratch[static_cast<std::size_t>(t)].index.data());
    };
    auto multiply_rows = [&](int t) {
      GemmScratch& s = scratch[static_cast<std::size_t>(t)];
      const int mp0 = m_panels * t / threads, mp1 = m_panels * (t + 1) / threads;
      if (mp0 < mp1) prefetch_a_panel(a, mp0); // A's rows as in gemm_over_panels
      for (int np = 0; np < n_panels; ++np) {
        const int n0 = np * nr, cols = std::min(nr, n - n0);
        for (int mp = mp0; mp < mp1; ++mp) {
          if (np == 0 && mp + 1 < mp1) prefetch_a_panel(a, mp + 1);
          const int rows = std::min(mr, a.m - mp * mr);
          tile_kernel(kernel, rows, cols)(a.k, a.panel(mp), shared.data() + stride * np,
                                          s.tile.data());
          for (int r = 0; r < rows; ++r) store(mp * mr + r, n0, cols, s.tile.data() + r * nr);
        }
      }
    };
    pool.run(packers, pack_share);
    pool.run(threads, multiply_rows);
    return;
  }
  gemm_over_panels(
      kernel, a, n,
      [&](GemmScratch& s, int n0, int cols) { pack(s.panel.data(), n0, cols, s.index.data()); },
      [&](int mp, GemmScratch& s, int n0) {
        tile_kernel(kernel, a.m - mp * kernel.mr, n - n0)(a.k, a.panel(mp), s.panel.data(),
                                                          s.tile.data());
      },
      store, pool, scratch);
}

// The column runs of a panel of cols <= 32 columns starting at column n0, where column q of
// C is pixel (y, x) = (q / src_width, q % src_width) of an image: pixels with x < kept go to
// y * dst_stride + x + lead, the others are dropped (a padded grid's pad columns).
inline void image_row_segments(int n0, int cols, int src_width, int kept, int dst_stride, int lead,
                               TileSegments& seg) {
  seg.count = 0;
  for (int y = n0 / src_width; y * src_width < n0 + cols; ++y) {
    const int j0 = std::max(0, y * src_width - n0);
    const int j1 = std::min(cols, y * src_width + kept - n0);
    if (j1 <= j0) continue;
    const std::uint32_t upto = j1 == 32 ? ~0u : (1u << j1) - 1u;
    seg.mask[seg.count] = upto & ~((1u << j0) - 1u);
    seg.offset[seg.count] = std::ptrdiff_t(y) * (dst_stride - src_width) + lead + n0;
    ++seg.count;
  }
}

// Whether k is the library's AVX-512 kernel, the one with fused stores (gemm_fused_avx512).
inline bool has_fused_stores(const MicroKernel& k) {
#if SHADOWSENSE_X86_KERNELS
  return k.fn == &micro_kernel_avx512;
#else
  (void)k;
  return false;
#endif
}

// Whether k is the library's AVX2 kernel, the one that can read B in place (gemm_in_place_avx2).
inline bool has_in_place_avx2(const MicroKernel& k) {
#if SHADOWSENSE_X86_KERNELS
  return k.fn == &micro_kernel_avx2;
#else
  (void)k;
  return false;
#endif
}

#if SHADOWSENSE_X86_KERNELS
// gemm() on the AVX2 kernel with B read in place at base + n0 + offsets[k] (the caller
// guarantees 24 readable floats there, past n included): nothing packed. store as gemm()'s.
// Same split over threads as the in-place tiles of gemm_over_panels.
template <class Store>
inline void gemm_in_place_avx2(const PackedMatrix& a, int n, const float* base, const int* offsets,
                               Store&& store, ThreadPool& pool, std::vector<GemmScratch>& scratch) {
  const MicroKernel kernel{GemmKernelKind::avx2, 4, 24, &micro_kernel_avx2, "avx2+fma"};
  gemm_over_panels(
      kernel, a, n, [](GemmScratch&, int, int) {},
      [&](int mp, GemmScratch& s, int n0) {
        micro_kernel_avx2_in_place(a.k, a.panel(mp), base + n0, offsets, s.tile.data());
      },
      store, pool, scratch, /*free_prepare=*/true);
}
#endif

#if SHADOWSENSE_X86_KERNELS
// gemm() on the AVX-512 kernel with the store fused into the kernel. B is packed by pack or,
// when offsets is set, read in place at base + n0 + offsets[k] (the caller guarantees 32
// readable floats there, past n included). Row m of C goes to dst + m * row_stride, plus bias[m]
// when bias is set, through ReLU when relu; its columns are laid out by segments(n0, cols,
// TileSegments&), called once per column panel and thread. A last panel of at most 8, 16 or 24
// columns runs the kernel of that width (micro_kernel_avx512_fused_fit). Split over threads by
// gemm_over_panels (packed with few column panels: by rows, every thread packing every panel,
// unlike gemm(); docs/densenet.md measured sharing them slower on a busy second core).
template <class Pack, class Segments>
inline void gemm_fused_avx512(const PackedMatrix& a, int n, Pack&& pack, const float* base,
                              const int* offsets, Segments&& segments, float* dst,
                              std::size_t row_stride, const float* bias, bool relu,
                              ThreadPool& pool, std::vector<GemmScratch>& scratch) {
  const MicroKernel kernel{GemmKernelKind::avx512, 8, 32, &micro_kernel_avx512, "avx512"};
  gemm_over_panels(
      kernel, a, n,
      [&](GemmScratch& s, int n0, int cols) {
        if (!offsets) pack(s.panel.data(), n0, cols, s.index.data());
        segments(n0, cols, s.segments);
        s.cols = cols;
      },
      [&](int mp, GemmScratch& s, int n0) {
        const int m0 = mp * kernel.mr;
        const TileDest d{dst + static_cast<std::size_t>(m0) * row_stride,
                         row_stride,
                         bias ? bias + m0 : nullptr,
                         relu,
                         std::min(kernel.mr, a.m - m0),
                         &s.segments};
        // The narrowest kernel that covers the panel's columns and rows.
        if (offsets)
          micro_kernel_avx512_fused_fit(s.cols, a.k, a.panel(mp), OffsetRows{base + n0, offsets},
                                        d);
        else
          micro_kernel_avx512_fused_fit(s.cols, a.k, a.panel(mp), PackedRows{s.panel.data()}, d);
      },
      [](int, int, int, const float*) {}, pool, scratch, /*free_prepare=*/offsets != nullptr);
}
#endif

#if SHADOWSENSE_X86_KERNELS
// The 1x1 convolution of gemm_fused_avx512 (B packed by pack, 32 columns a panel, the same
// bias, ReLU and destination) with pixels on the kernel's rows and output channels on its
// columns (micro_kernel_avx512_pixel_rows): for few pixels, where channel rows leave a last
// column panel part-filled (conv1x1_fmas). Each packed panel of 32 pixels is read as four
// sub-panels of 8; segments(p0, pixels, TileSegments&) lays out a sub-panel's pixels (at most
// 8) as gemm_fused_avx512's segments lay out columns. The same bits as gemm_fused_avx512 for
// every output. Split over threads as (pixel panel, channel panel) units (run_panel_units):
// a thread packs each pixel panel of its share once.
template <class Pack, class Segments>
inline void gemm_pixel_rows_avx512(const PixelRowWeights& w, int n, Pack&& pack,
                                   Segments&& segments, float* dst, std::size_t row_stride,
                                   const float* bias, bool relu, ThreadPool& pool,
                                   std::vector<GemmScratch>& scratch) {
  constexpr int nr = PixelRowWeights::nr;
  const int n_panels = (n + nr - 1) / nr, m_panels = (w.m + nr - 1) / nr;
  run_panel_units(pool, n_panels, m_panels, [&](int t, int np, int mp0, int mp1) {
    GemmScratch& s = scratch[static_cast<std::size_t>(t)];
    const int n0 = np * nr, cols = std::min(nr, n - n0);
    pack(s.panel.data(), n0, cols, s.index.data());
    TileSegments seg[nr / 8];
    const int subs = (cols + 7) / 8;
    for (int q = 0; q < subs; ++q) segments(n0 + 8 * q, std::min(8, cols - 8 * q), seg[q]);
    for (int mp = mp0; mp < mp1; ++mp) { // one weight panel over the sub-panels
      const int m0 = mp * nr;
      for (int q = 0; q < subs; ++q) {
        const TileDest d{dst + static_cast<std::size_t>(m0) * row_stride,
                         row_stride,
                         bias ? bias + m0 : nullptr,
                         relu,
                         std::min(nr, w.m - m0),
                         &seg[q]};
        micro_kernel_avx512_pixel_rows_fit(std::min(8, cols - 8 * q), w.k, s.panel.data() + 8 * q,
                                           w.panel(mp), d);
      }
    }
  });
}
#endif

} // namespace detail

SHADOWSENSE_NAMESPACE_END
