// Every GEMM micro-kernel and element-wise loop set this CPU runs (AVX-512, AVX2+FMA, NEON,
// portable) against the reference kernel (plain loops, double accumulation), and the DenseNet
// forward pass per kernel on the committed fixtures against torchvision's logits embedded in
// them. Needs only the DenseNet headers and doctest (no OpenCV, no Python), so it also runs
// cross-compiled for aarch64 under qemu-user (.ci/steps/50_aarch64.sh).
#include <shadowsense/backends/densenet/densenet.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

using namespace shadowsense;

namespace {

std::vector<detail::MicroKernel> kernels_under_test() {
  std::vector<detail::MicroKernel> out;
  for (auto k : detail::available_kernels())
    if (k != GemmKernelKind::reference) out.push_back(detail::select_micro_kernel(k));
  return out;
}

// The reference kernel at any tile size (it is a template; the dispatch uses 4 x 8).
void reference_tile(int mr, int nr, int K, const float* a, const float* b, float* out) {
  for (int r = 0; r < mr; ++r)
    for (int j = 0; j < nr; ++j) {
      double acc = 0;
      for (int k = 0; k < K; ++k) acc += double(a[k * mr + r]) * double(b[k * nr + j]);
      out[r * nr + j] = static_cast<float>(acc);
    }
}

} // namespace

TEST_CASE("the automatic kernel is the CPU's SIMD kernel: NEON on aarch64") {
  const auto k = detail::select_micro_kernel(GemmKernelKind::automatic);
  MESSAGE("automatic kernel: ", std::string(k.name));
#if defined(__aarch64__)
  CHECK(k.kind == GemmKernelKind::neon);
  CHECK(std::string(k.name) == "neon");
#elif SHADOWSENSE_X86_KERNELS
  CHECK_FALSE(detail::cpu_has(GemmKernelKind::neon));
  CHECK_THROWS_WITH_AS(detail::select_micro_kernel(GemmKernelKind::neon),
                       doctest::Contains("not supported"), InvalidArgument);
#endif
  CHECK(detail::available_kernels().back() == GemmKernelKind::reference);
  CHECK(detail::cpu_has(GemmKernelKind::portable));
}

TEST_CASE("micro-kernels equal the reference within the float dot-product error bound") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> ud(-2.0f, 2.0f);
  for (const auto& mk : kernels_under_test()) {
    const std::string name = mk.name;
    CAPTURE(name);
    for (int K : {1, 2, 7, 147, 1152}) {
      CAPTURE(K);
      std::vector<float> a(static_cast<std::size_t>(K) * mk.mr),
          b(static_cast<std::size_t>(K) * mk.nr);
      for (auto& v : a) v = ud(rng);
      for (auto& v : b) v = ud(rng);
      std::vector<float> got(static_cast<std::size_t>(mk.mr) * mk.nr, -1.0f), ref(got.size());
      mk.fn(K, a.data(), b.data(), got.data());
      reference_tile(mk.mr, mk.nr, K, a.data(), b.data(), ref.data());
      for (int r = 0; r < mk.mr; ++r)
        for (int j = 0; j < mk.nr; ++j) {
          double abs_sum = 0; // sum |a b|: the float error of a K-term sum is below K eps times it
          for (int k = 0; k < K; ++k)
            abs_sum += std::abs(double(a[k * mk.mr + r]) * double(b[k * mk.nr + j]));
          const std::size_t i = static_cast<std::size_t>(r) * mk.nr + j;
          CAPTURE(r);
          CAPTURE(j);
          CHECK(std::abs(double(got[i]) - double(ref[i])) <=
                (K + 1) * double(FLT_EPSILON) * abs_sum);
        }
    }
  }
}

TEST_CASE("micro-kernels: K = 0 gives zeros, NaN and Inf propagate") {
  for (const auto& mk : kernels_under_test()) {
    const std::string name = mk.name;
    CAPTURE(name);
    std::vector<float> out(static_cast<std::size_t>(mk.mr) * mk.nr, 5.0f);
    mk.fn(0, nullptr, nullptr, out.data());
    for (float v : out) CHECK(v == 0.0f);
    const int K = 3;
    std::vector<float> a(static_cast<std::size_t>(K) * mk.mr, 1.0f),
        b(static_cast<std::size_t>(K) * mk.nr, 1.0f);
    a[1] = std::numeric_limits<float>::quiet_NaN(); // row 1, k = 0
    b[static_cast<std::size_t>(mk.nr) + 2] =
        std::numeric_limits<float>::infinity(); // column 2, k = 1
    mk.fn(K, a.data(), b.data(), out.data());
    for (int r = 0; r < mk.mr; ++r)
      for (int j = 0; j < mk.nr; ++j) {
        const float v = out[static_cast<std::size_t>(r) * mk.nr + j];
        CAPTURE(r);
        CAPTURE(j);
        if (r == 1)
          CHECK(std::isnan(v));
        else if (j == 2)
          CHECK(std::isinf(v));
        else
          CHECK(v == 3.0f);
      }
  }
}

namespace {
// A packed A panel (K x mr) and B panel (K x nr), one float past each, uniform in [-2, 2).
std::pair<std::vector<float>, std::vector<float>> random_panels(const detail::MicroKernel& mk,
                                                                int K, std::mt19937& rng) {
  std::uniform_real_distribution<float> ud(-2.0f, 2.0f);
  std::vector<float> a(static_cast<std::size_t>(K) * mk.mr + 1),
      b(static_cast<std::size_t>(K) * mk.nr + 1);
  for (auto& v : a) v = ud(rng);
  for (auto& v : b) v = ud(rng);
  return {std::move(a), std::move(b)};
}
} // namespace

TEST_CASE("narrow kernels: the first steps of nr columns and / or mr / 2 rows bit for bit, the "
          "others untouched") {
  std::mt19937 rng(12);
  int tested = 0;
  for (const auto& mk : kernels_under_test()) {
    if (mk.step <= 0) continue;
    const std::string name = mk.name;
    CAPTURE(name);
    ++tested;
    REQUIRE(mk.nr % mk.step == 0);
    const int widths = mk.nr / mk.step;
    for (int K : {0, 1, 9, 300}) {
      CAPTURE(K);
      const auto [a, b] = random_panels(mk, K, rng);
      std::vector<float> full(static_cast<std::size_t>(mk.mr) * mk.nr);
      mk.fn(K, a.data(), b.data(), full.data());
      for (int few_rows = 0; few_rows < 2; ++few_rows)
        for (int steps = 1; steps <= widths; ++steps) {
          CAPTURE(few_rows);
          CAPTURE(steps);
          const detail::MicroKernelFn own = few_rows         ? mk.half_rows[steps - 1]
                                            : steps < widths ? mk.narrow[steps - 1]
                                                             : mk.fn;
          // The choice: the least work that covers the rows and columns in use.
          const int rows = few_rows ? mk.mr / 2 : mk.mr / 2 + 1, cols = steps * mk.step;
          const detail::MicroKernelFn f = detail::tile_kernel(mk, rows, cols);
          CHECK_UNARY(detail::tile_kernel(mk, few_rows ? 1 : mk.mr, cols - mk.step + 1) == f);
          if (own) CHECK_UNARY(f == own);
          std::vector<float> got(full.size(), 7.0f);
          f(K, a.data(), b.data(), got.data());
          // What the chosen kernel writes: at least the rows and columns asked for, the same
          // values as fn there, nothing beyond what its own width and height cover.
          int bad = 0;
          for (int r = 0; r < mk.mr; ++r)
            for (int j = 0; j < mk.nr; ++j) {
              const std::size_t i = static_cast<std::size_t>(r) * mk.nr + j;
              const bool in = (!few_rows || r < mk.mr / 2) && j < cols;
              if (in) bad += got[i] != full[i];
              if (own) bad += got[i] != (in ? full[i] : 7.0f);
            }
          CHECK(bad == 0);
        }
    }
  }
#if SHADOWSENSE_X86_KERNELS
  if (detail::cpu_has(GemmKernelKind::avx512)) CHECK(tested == 2); // AVX-512 and AVX2
#endif
#if SHADOWSENSE_NEON_KERNELS
  CHECK(tested == 1);
#endif
}

TEST_CASE("tile_kernel: kernels without narrow variants run fn everywhere") {
  for (const auto& mk : kernels_under_test()) {
    if (mk.step > 0) continue;
    const std::string name = mk.name;
    CAPTURE(name);
    CHECK_UNARY(detail::tile_kernel(mk, 1, 1) == mk.fn);
    CHECK_UNARY(detail::tile_kernel(mk, mk.mr, mk.nr) == mk.fn);
  }
}

TEST_CASE("image_row_segments: the runs of a panel over image rows, exactly") {
  detail::TileSegments seg;
  // The bottleneck store: 55-wide rows into a grid padded by 1 (row stride 57, lead 57 + 1).
  detail::image_row_segments(50, 32, 55, 55, 57, 58, seg);
  REQUIRE(seg.count == 2);
  CHECK(seg.mask[0] == 0x1Fu); // pixels 50..54 of row 0
  CHECK(seg.offset[0] == 58 + 50);
  CHECK(seg.mask[1] == 0xFFFFFFE0u); // pixels 0..26 of row 1 at (2, 1): 2 * 57 + 1 = 5 + 110
  CHECK(seg.offset[1] == 2 + 58 + 50);
  // A padded grid (8 wide) whose last 2 columns are dropped, into 6-wide rows.
  detail::image_row_segments(0, 32, 8, 6, 6, 0, seg);
  REQUIRE(seg.count == 4);
  for (int y = 0; y < 4; ++y) {
    CHECK(seg.mask[y] == 0x3Fu << (8 * y));
    CHECK(seg.offset[y] == -2 * y);
  }
  // A short last panel that starts in a dropped column: columns 46, 47 dropped, 48.. row 6.
  detail::image_row_segments(46, 5, 8, 6, 6, 0, seg);
  REQUIRE(seg.count == 1);
  CHECK(seg.mask[0] == 0x1Cu);
  CHECK(seg.offset[0] == 6 * (6 - 8) + 46);
  // One pixel per row: a run per column, the most a panel has.
  detail::image_row_segments(3, 32, 1, 1, 4, 0, seg);
  REQUIRE(seg.count == 32);
  for (int j = 0; j < 32; ++j) {
    CHECK(seg.mask[j] == 1u << j);
    CHECK(seg.offset[j] == (3 + j) * 3 + 3);
  }
  // Contiguous: one run.
  detail::image_row_segments(64, 17, 81, 81, 81, 0, seg);
  REQUIRE(seg.count == 1);
  CHECK(seg.mask[0] == 0x1FFFFu);
  CHECK(seg.offset[0] == 64);
}

#if SHADOWSENSE_X86_KERNELS
TEST_CASE("fused AVX-512 kernel: micro_kernel_avx512 + bias + ReLU, laid out by the segments") {
  if (!detail::cpu_has(GemmKernelKind::avx512)) return;
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> ud(-2.0f, 2.0f);
  const float sentinel = 1234.5f;
  for (int K : {0, 1, 64, 333})
    for (int width : {1, 5, 13, 40})
      for (int cols : {32, 24, 17, 16, 9, 8, 1})
        for (int rows : {8, 3})
          for (bool bias_relu : {true, false})
            for (bool in_place : {false, true}) {
              CAPTURE(K);
              CAPTURE(width);
              CAPTURE(cols);
              CAPTURE(rows);
              CAPTURE(bias_relu);
              CAPTURE(in_place);
              std::vector<float> a(static_cast<std::size_t>(K) * 8 + 1),
                  b(static_cast<std::size_t>(K) * 32 + 1), bias(8);
              for (auto& v : a) v = ud(rng);
              for (auto& v : b) v = ud(rng);
              for (auto& v : bias) v = ud(rng);
              bias[2] = std::numeric_limits<float>::quiet_NaN(); // relu(NaN) stays NaN
              std::vector<float> tile(8 * 32);
              detail::micro_kernel_avx512(K, a.data(), b.data(), tile.data());
              // Columns are pixels n0.. of width-wide rows, stored into rows 2 wider with a
              // lead of 3; destination rows of C are 600 floats apart.
              const int n0 = 7, stride = width + 2, lead = 3;
              detail::TileSegments seg;
              detail::image_row_segments(n0, cols, width, width, stride, lead, seg);
              std::vector<float> got(8 * 600, sentinel), want(got.size(), sentinel);
              for (int r = 0; r < rows; ++r)
                for (int j = 0; j < cols; ++j) {
                  const int q = n0 + j, y = q / width, x = q % width;
                  float v = tile[static_cast<std::size_t>(r) * 32 + j];
                  if (bias_relu) v = detail::relu_reference(v + bias[static_cast<std::size_t>(r)]);
                  want[static_cast<std::size_t>(r) * 600 + y * stride + x + lead] = v;
                }
              const detail::TileDest dest{got.data(), 600,  bias_relu ? bias.data() : nullptr,
                                          bias_relu,  rows, &seg};
              std::vector<int> offsets(static_cast<std::size_t>(K) + 1);
              for (int k = 0; k < K; ++k) offsets[static_cast<std::size_t>(k)] = k * 32;
              // The narrowest kernel that covers the rows and columns, as gemm_fused_avx512
              // runs it.
              auto run = [&](const auto& rb) {
                detail::micro_kernel_avx512_fused_fit(cols, K, a.data(), rb, dest);
              };
              if (in_place)
                run(detail::OffsetRows{b.data(), offsets.data()});
              else
                run(detail::PackedRows{b.data()});
              int mismatches = 0;
              for (std::size_t i = 0; i < got.size(); ++i) {
                const bool same = std::isnan(want[i]) ? std::isnan(got[i]) : got[i] == want[i];
                mismatches += same ? 0 : 1;
              }
              CHECK(mismatches == 0);
            }
}
#endif

TEST_CASE("pool0's max pool (VectorOps::max_pool3s2): every kernel's bits are the portable "
          "loop's, and the values are the 3x3 stride-2 windows' maxima, NaN winning") {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> ud(0.0f, 4.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  int compared = 0;
  for (const int h0 : {1, 2, 3, 4, 7, 44})
    for (const int w0 : {1, 2, 3, 4, 5, 16, 31, 32, 33, 34, 35, 64, 65, 80, 81}) {
      CAPTURE(h0);
      CAPTURE(w0);
      const int bh = (h0 - 1) / 2 + 1, bw = (w0 - 1) / 2 + 1;
      // ReLU's outputs: >= 0, zeros of both signs, +inf, and a NaN in some planes.
      std::vector<float> s(static_cast<std::size_t>(h0 * w0));
      for (auto& v : s) {
        const int pick = static_cast<int>(rng() % 16);
        v = pick == 0 ? 0.0f : pick == 1 ? -0.0f : pick == 2 ? inf : ud(rng);
      }
      const bool with_nan = (h0 + w0) % 3 == 0;
      const int nan_at = static_cast<int>(rng() % s.size());
      if (with_nan) s[static_cast<std::size_t>(nan_at)] = nan;
      // The definition: each window's max, or NaN when the window holds one.
      std::vector<float> want(static_cast<std::size_t>(bh * bw));
      for (int y = 0; y < bh; ++y)
        for (int x = 0; x < bw; ++x) {
          float mx = -inf;
          bool has_nan = false;
          for (int iy = std::max(2 * y - 1, 0); iy <= std::min(2 * y + 1, h0 - 1); ++iy)
            for (int ix = std::max(2 * x - 1, 0); ix <= std::min(2 * x + 1, w0 - 1); ++ix) {
              const float v = s[static_cast<std::size_t>(iy * w0 + ix)];
              has_nan = has_nan || std::isnan(v);
              mx = std::max(mx, v);
            }
          want[static_cast<std::size_t>(y * bw + x)] = has_nan ? nan : mx;
        }
      std::vector<float> vm(static_cast<std::size_t>(w0) + 2), vs(vm.size());
      std::vector<float> portable(want.size() + 4, 9.0f);
      detail::max_pool3s2_portable(s.data(), h0, w0, bh, bw, vm.data() + 1, vs.data() + 1,
                                   portable.data());
      for (std::size_t i = 0; i < want.size(); ++i)
        REQUIRE((std::isnan(want[i]) ? std::isnan(portable[i]) : portable[i] == want[i]));
      CHECK(portable[want.size()] == 9.0f); // nothing written past the plane
      for (auto kind : detail::available_kernels()) {
        const auto ops = detail::select_vector_ops(kind);
        if (!ops.max_pool3s2) continue;
        CAPTURE(detail::select_micro_kernel(kind).name);
        std::vector<float> got(portable.size(), 9.0f);
        std::fill(vm.begin(), vm.end(), 5.0f); // scratch left by an earlier call
        std::fill(vs.begin(), vs.end(), 5.0f);
        ops.max_pool3s2(s.data(), h0, w0, bh, bw, vm.data() + 1, vs.data() + 1, got.data());
        REQUIRE(std::memcmp(got.data(), portable.data(), got.size() * sizeof(float)) == 0);
        ++compared;
      }
    }
  MESSAGE("vector kernels compared: " << compared);
}

TEST_CASE("element-wise loops equal the reference loops (pack exactly, arithmetic to 1 ulp)") {
  const auto ref = detail::select_vector_ops(GemmKernelKind::reference);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> ud(-3.0f, 3.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (auto kind : detail::available_kernels()) {
    const auto ops = detail::select_vector_ops(kind);
    const std::string name = detail::select_micro_kernel(kind).name;
    CAPTURE(name);
    // detail::portable_nr (24): the full-panel paths of the portable loops.
    for (int n : {0, 1, 3, 4, 5, 8, 15, 16, 17, detail::portable_nr, 33, 64}) {
      CAPTURE(n);
      std::vector<float> s(static_cast<std::size_t>(4 * n + 200));
      for (auto& v : s) v = ud(rng);
      if (n > 2) s[2] = nan;
      const float sc = 0.7f, sh = -0.3f;
      // Each value is x * sc + sh (one product and one sum, fused or not) then ReLU: within 1
      // ulp of the scale of its terms.
      auto close = [](float got, float want, float scale) {
        if (std::isnan(want)) return std::isnan(got);
        return std::abs(double(got) - double(want)) <= 2.0 * FLT_EPSILON * scale;
      };
      std::vector<float> d(static_cast<std::size_t>(n) + 8, 9.0f), e(d);
      ops.affine_relu(s.data(), d.data(), n, sc, sh);
      ref.affine_relu(s.data(), e.data(), n, sc, sh);
      for (int i = 0; i < n; ++i) CHECK(close(d[i], e[i], std::abs(s[i] * sc) + std::abs(sh)));
      CHECK(d[n] == 9.0f); // nothing written past n
      ops.bias_relu(s.data(), d.data(), n, sh);
      ref.bias_relu(s.data(), e.data(), n, sh);
      for (int i = 0; i < n; ++i) CHECK((d[i] == e[i] || (std::isnan(d[i]) && std::isnan(e[i]))));
      if (n > 2) CHECK(std::isnan(d[2])); // ReLU propagates NaN
      ops.pool_affine_relu(s.data(), s.data() + 2 * n + 7, d.data(), n, sc, sh);
      ref.pool_affine_relu(s.data(), s.data() + 2 * n + 7, e.data(), n, sc, sh);
      for (int i = 0; i < n; ++i) {
        float scale = 0;
        for (int q : {2 * i, 2 * i + 1, 2 * n + 7 + 2 * i, 2 * n + 8 + 2 * i})
          scale += std::abs(s[static_cast<std::size_t>(q)] * sc) + std::abs(sh);
        CHECK(close(d[i], e[i], scale));
      }
      CHECK(d[static_cast<std::size_t>(n)] == 9.0f); // nothing written past n
      if (n > 2) CHECK(std::isnan(d[1]));            // the window holding s[2]
      // A row cut into two calls anywhere gives the same bits as one call.
      for (int cut = 1; cut < n; ++cut) {
        CAPTURE(cut);
        std::vector<float> f(d.size(), 9.0f);
        const float* r1 = s.data() + 2 * n + 7;
        ops.pool_affine_relu(s.data(), r1, f.data(), cut, sc, sh);
        ops.pool_affine_relu(s.data() + 2 * cut, r1 + 2 * cut, f.data() + cut, n - cut, sc, sh);
        CHECK(std::memcmp(f.data(), d.data(), f.size() * sizeof(float)) == 0);
      }
      // The 1x1 input panel: every channel as affine_relu, zeros to nr (32: the AVX-512 full
      // panel when n == 32; 24 and 40 the masked paths).
      for (int nr : {24, 32, 40})
        if (ops.pack_affine_relu && n <= nr) {
          CAPTURE(nr);
          const int channels = 3, stride = n + 5;
          const float scs[3] = {0.7f, -1.3f, 0.0f}, shs[3] = {-0.3f, 0.4f, 2.0f};
          std::vector<float> p(static_cast<std::size_t>(channels * nr) + 8, 9.0f);
          ops.pack_affine_relu(s.data(), static_cast<std::size_t>(stride), channels, scs, shs,
                               p.data(), n, nr);
          for (int c = 0; c < channels; ++c) {
            std::vector<float> want(static_cast<std::size_t>(n) + 1);
            ref.affine_relu(s.data() + c * stride, want.data(), n, scs[c], shs[c]);
            for (int j = 0; j < nr; ++j) {
              const float got = p[static_cast<std::size_t>(c * nr + j)];
              if (j < n)
                CHECK(close(got, want[static_cast<std::size_t>(j)],
                            std::abs(s[static_cast<std::size_t>(c * stride + j)] * scs[c]) +
                                std::abs(shs[c])));
              else
                CHECK(got == 0.0f);
            }
          }
          CHECK(p[static_cast<std::size_t>(channels * nr)] == 9.0f); // nothing past the panel
        }
      const int nr = 24, pw = n + 2;
      if (n <= nr) {
        std::vector<float> p(9 * nr, 9.0f), q(9 * nr, 8.0f);
        std::vector<float> grid(static_cast<std::size_t>(3 * pw + nr + 2));
        for (auto& v : grid) v = ud(rng);
        ops.pack3x3(grid.data(), p.data(), n, nr, pw);
        ref.pack3x3(grid.data(), q.data(), n, nr, pw);
        CHECK(p == q);
      }
    }
  }
}

TEST_CASE("DenseNet per kernel on the committed fixtures: equal to torchvision and the reference") {
  for (const std::string file : {"densenet_tiny.ssdn", "densenet_tiny_extreme_bn.ssdn"}) {
    CAPTURE(file);
    const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/" + file);
    REQUIRE(m.self_test.has_value());
    const auto& st = *m.self_test;
    DenseNet reference(m, {.kernel = GemmKernelKind::reference,
                           .conv3x3 = DenseNet::Conv3x3::direct,
                           .run_self_test = false});
    const std::vector<float> ref(reference.logits(st.input).begin(),
                                 reference.logits(st.input).end());
    for (auto kind : detail::available_kernels())
      for (auto conv :
           {DenseNet::Conv3x3::direct, DenseNet::Conv3x3::winograd, DenseNet::Conv3x3::winograd4x4})
        for (auto conv0 : {DenseNet::Conv0::direct, DenseNet::Conv0::winograd})
          for (int threads : {1, 2}) {
            DenseNet net(m, {.threads = threads,
                             .kernel = kind,
                             .conv3x3 = conv,
                             .conv0 = conv0,
                             .run_self_test = false});
            const std::string name = net.kernel_name();
            const std::string method = conv == DenseNet::Conv3x3::direct     ? " direct"
                                       : conv == DenseNet::Conv3x3::winograd ? " winograd"
                                                                             : " winograd4x4";
            const std::string method0 =
                conv0 == DenseNet::Conv0::direct ? " conv0 direct" : " conv0 F(3x3, 4x4)";
            CAPTURE(name);
            CAPTURE(method);
            CAPTURE(method0);
            CAPTURE(threads);
            const auto got = net.logits(st.input);
            REQUIRE(got.size() == st.logits.size());
            double vs_torch = 0, vs_ref = 0;
            for (std::size_t i = 0; i < got.size(); ++i) {
              const double t = st.logits[i], d = std::abs(double(got[i]) - t);
              vs_torch = std::max(vs_torch, d);
              vs_ref = std::max(vs_ref, std::abs(double(got[i]) - double(ref[i])));
              CAPTURE(i);
              CHECK(d <= 1e-4 * std::max(1.0, std::abs(t))); // the x86 golden-test tolerance
              CHECK(std::abs(double(got[i]) - double(ref[i])) <= 1e-4 * std::max(1.0, std::abs(t)));
            }
            MESSAGE(file, " ", name, method, method0, " threads=", threads,
                    ": max abs diff vs torchvision ", vs_torch, ", vs reference kernel ", vs_ref);
          }
  }
}

namespace {

// The r x r correlation (r = 3: pad 1) of c channels of a zero-bordered grid of row stride pw,
// in double: out[o][y][x] and the error scale sum |w| |x| of each output.
void reference_conv(int r, const std::vector<float>& w, const std::vector<float>& in, int m, int c,
                    int h, int wd, int pw, std::size_t plane, std::vector<double>& out,
                    std::vector<double>& scale) {
  out.assign(static_cast<std::size_t>(m) * h * wd, 0.0);
  scale.assign(out.size(), 0.0);
  for (int o = 0; o < m; ++o)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < wd; ++x) {
        double acc = 0, abs_acc = 0;
        for (int i = 0; i < c; ++i)
          for (int t = 0; t < r * r; ++t) {
            const double a = w[(static_cast<std::size_t>(o) * c + i) * r * r + t];
            const double b = in[i * plane + static_cast<std::size_t>(y + t / r) * pw + x + t % r];
            acc += a * b;
            abs_acc += std::abs(a * b);
          }
        const std::size_t k = (static_cast<std::size_t>(o) * h + y) * wd + x;
        out[k] = acc;
        scale[k] = abs_acc;
      }
}

// The error scale of Winograd F(T x T, 3x3) for each output: the algorithm run on absolute
// values, |A^T| ( (|G| |g| |G^T|) . (|B^T| |d| |B|) ) |A| summed over channels, in double. Every
// float rounding in the transforms and the channel sum is at most eps times a term of this sum,
// so |winograd - exact| <= (c + terms) eps times it, with terms the few roundings per path
// (3 per 1-D transform of at most 6 values, 2 dimensions, 3 transforms, G's inexact 1/6, 1/12,
// 1/24): 32 covers them.
void winograd_abs_scale(int tile, const std::vector<float>& w, const std::vector<float>& in, int m,
                        int c, int h, int wd, int pw, std::size_t plane,
                        std::vector<double>& scale) {
  static const double bt2[4][4] = {{1, 0, 1, 0}, {0, 1, 1, 0}, {0, 1, 1, 0}, {0, 1, 0, 1}};
  static const double g2[4][3] = {{1, 0, 0}, {.5, .5, .5}, {.5, .5, .5}, {0, 0, 1}};
  static const double at2[2][4] = {{1, 1, 1, 0}, {0, 1, 1, 1}};
  static const double bt4[6][6] = {{4, 0, 5, 0, 1, 0}, {0, 4, 4, 1, 1, 0}, {0, 4, 4, 1, 1, 0},
                                   {0, 2, 1, 2, 1, 0}, {0, 2, 1, 2, 1, 0}, {0, 4, 0, 5, 0, 1}};
  static const double g4[6][3] = {{1. / 4, 0, 0},
                                  {1. / 6, 1. / 6, 1. / 6},
                                  {1. / 6, 1. / 6, 1. / 6},
                                  {1. / 24, 1. / 12, 1. / 6},
                                  {1. / 24, 1. / 12, 1. / 6},
                                  {0, 0, 1}};
  static const double at4[4][6] = {
      {1, 1, 1, 1, 1, 0}, {0, 1, 1, 2, 2, 0}, {0, 1, 1, 4, 4, 0}, {0, 1, 1, 8, 8, 1}};
  // F(3x3, 4x4): bt4, and
  static const double g3[6][4] = {{1. / 4, 0, 0, 0},
                                  {1. / 6, 1. / 6, 1. / 6, 1. / 6},
                                  {1. / 6, 1. / 6, 1. / 6, 1. / 6},
                                  {1. / 24, 1. / 12, 1. / 6, 1. / 3},
                                  {1. / 24, 1. / 12, 1. / 6, 1. / 3},
                                  {0, 0, 0, 1}};
  static const double at3[3][6] = {{1, 1, 1, 1, 1, 0}, {0, 1, 1, 2, 2, 0}, {0, 1, 1, 4, 4, 1}};
  const int a = tile == 2 ? 4 : 6, taps = tile == 3 ? 4 : 3;
  auto bt = [&](int p, int r) { return tile == 2 ? bt2[p][r] : bt4[p][r]; };
  auto g = [&](int p, int k) { return tile == 2 ? g2[p][k] : tile == 4 ? g4[p][k] : g3[p][k]; };
  auto at = [&](int i, int p) { return tile == 2 ? at2[i][p] : tile == 4 ? at4[i][p] : at3[i][p]; };
  scale.assign(static_cast<std::size_t>(m) * h * wd, 0.0);
  // |G| |g| |G^T| for every (o, i)
  std::vector<double> u(static_cast<std::size_t>(m) * c * a * a);
  for (int o = 0; o < m; ++o)
    for (int i = 0; i < c; ++i)
      for (int p = 0; p < a; ++p)
        for (int q = 0; q < a; ++q) {
          double acc = 0;
          for (int ky = 0; ky < taps; ++ky)
            for (int kx = 0; kx < taps; ++kx)
              acc += g(p, ky) *
                     std::abs(
                         w[(static_cast<std::size_t>(o) * c + i) * taps * taps + ky * taps + kx]) *
                     g(q, kx);
          u[((static_cast<std::size_t>(o) * c + i) * a + p) * a + q] = acc;
        }
  std::vector<double> v(static_cast<std::size_t>(c) * a * a);
  for (int ty = 0; ty * tile < h; ++ty)
    for (int tx = 0; tx * tile < wd; ++tx) {
      for (int i = 0; i < c; ++i) // |B^T| |d| |B| of this tile's patch
        for (int p = 0; p < a; ++p)
          for (int q = 0; q < a; ++q) {
            double acc = 0;
            for (int r = 0; r < a; ++r)
              for (int k = 0; k < a; ++k)
                acc += bt(p, r) *
                       std::abs(in[i * plane + static_cast<std::size_t>(ty * tile + r) * pw +
                                   tx * tile + k]) *
                       bt(q, k);
            v[(static_cast<std::size_t>(i) * a + p) * a + q] = acc;
          }
      for (int o = 0; o < m; ++o) {
        std::vector<double> mm(static_cast<std::size_t>(a) * a, 0.0);
        for (int i = 0; i < c; ++i)
          for (int x = 0; x < a * a; ++x)
            mm[static_cast<std::size_t>(x)] +=
                u[(static_cast<std::size_t>(o) * c + i) * a * a + x] *
                v[static_cast<std::size_t>(i) * a * a + x];
        for (int yi = 0; yi < tile && ty * tile + yi < h; ++yi)
          for (int xi = 0; xi < tile && tx * tile + xi < wd; ++xi) {
            double acc = 0;
            for (int p = 0; p < a; ++p)
              for (int q = 0; q < a; ++q)
                acc += at(yi, p) * mm[static_cast<std::size_t>(p * a + q)] * at(xi, q);
            scale[(static_cast<std::size_t>(o) * h + ty * tile + yi) * wd + tx * tile + xi] = acc;
          }
      }
    }
}

// c planes of `plane` floats, pw a row, values uniform in [-1, 1] over rows x cols from
// (origin, origin) and zero elsewhere, then NaN past the last plane: the readable slack of the
// Winograd contract (winograd_read_slack) and beyond. A NaN read into a column that is not
// dropped shows up in the results.
std::vector<float> winograd_input_planes(int c, std::size_t plane, int pw, int origin, int rows,
                                         int cols, std::mt19937& rng) {
  std::uniform_real_distribution<float> ud(-1.0f, 1.0f);
  const std::size_t zeros = c * plane;
  std::vector<float> in(zeros + detail::winograd_read_slack + 64, 0.0f);
  std::fill(in.begin() + static_cast<std::ptrdiff_t>(zeros), in.end(),
            std::numeric_limits<float>::quiet_NaN());
  for (int i = 0; i < c; ++i)
    for (int y = 0; y < rows; ++y)
      for (int x = 0; x < cols; ++x)
        in[i * plane + static_cast<std::size_t>(y + origin) * pw + x + origin] = ud(rng);
  return in;
}

} // namespace

TEST_CASE("Winograd F(2x2, 3x3) and F(4x4, 3x3) equal the direct 3x3 convolution for every "
          "kernel") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> ud(-1.0f, 1.0f);
  struct Shape {
    int m, c, h, w;
  };
  // Odd and even sizes, sizes 1-3 past a multiple of 4, one tile, one row or column of tiles,
  // several panels, a tile row longer than one 16-tile step, rows of the weights that do not
  // fill a panel (m % mr != 0).
  const Shape shapes[] = {{3, 5, 1, 1},     {8, 4, 1, 2},     {5, 7, 2, 1},     {32, 16, 3, 3},
                          {32, 128, 9, 13}, {12, 32, 19, 27}, {16, 32, 38, 55}, {7, 3, 4, 6},
                          {8, 32, 22, 40},  {9, 6, 5, 70},    {4, 3, 7, 66}};
  for (int tile : {2, 4}) {
    CAPTURE(tile);
    double worst = 0, worst_bound = 0; // largest |diff| / (sum |w| |x|), and / the bound
    for (const auto& sh : shapes) {
      CAPTURE(sh.m);
      CAPTURE(sh.c);
      CAPTURE(sh.h);
      CAPTURE(sh.w);
      const int pw = detail::winograd_padded(sh.w, tile);
      const std::size_t plane = static_cast<std::size_t>(detail::winograd_padded(sh.h, tile)) * pw;
      // The image inside a zero border of one.
      const std::vector<float> in = winograd_input_planes(sh.c, plane, pw, 1, sh.h, sh.w, rng);
      std::vector<float> w(static_cast<std::size_t>(sh.m) * sh.c * 9);
      for (auto& v : w) v = ud(rng);
      std::vector<double> ref, scale, wscale;
      reference_conv(3, w, in, sh.m, sh.c, sh.h, sh.w, pw, plane, ref, scale);
      winograd_abs_scale(tile, w, in, sh.m, sh.c, sh.h, sh.w, pw, plane, wscale);
      const double eps = std::numeric_limits<float>::epsilon();
      const std::size_t n_out = static_cast<std::size_t>(sh.m) * sh.h * sh.w;
      for (const auto& mk : kernels_under_test()) {
        std::vector<float> one_thread;
        // 2 and 3 threads split by (tile panel, row panel) units (the portable and NEON
        // transforms) or by tile ranges (run_column_ranges, the x86 ones): every output the
        // same bit for bit as on 1 thread.
        for (int threads : {1, 2, 3}) {
          const std::string name = mk.name;
          CAPTURE(name);
          CAPTURE(threads);
          detail::WinogradWeights u;
          u.set(w.data(), sh.m, sh.c, mk.mr, tile);
          detail::ThreadPool pool(threads);
          std::vector<detail::WinogradScratch> scratch(
              static_cast<std::size_t>(threads), detail::make_winograd_scratch(sh.c, sh.m, mk));
          // Guard values after the output: nothing may be written there.
          std::vector<float> out(n_out + 64, -7.0f);
          detail::winograd_conv3x3(mk, detail::select_winograd_ops(mk.kind), u, in.data(), pw,
                                   plane, sh.h, sh.w, out.data(), pool, scratch);
          int bad = 0;
          for (std::size_t k = 0; k < n_out; ++k) {
            const double diff = std::abs(double(out[k]) - ref[k]);
            const double bound = (sh.c + 32) * eps * wscale[k];
            worst = std::max(worst, diff / std::max(scale[k], 1e-30));
            worst_bound = std::max(worst_bound, diff / std::max(bound, 1e-30));
            if (!(diff <= bound)) ++bad; // (NaN counts as bad)
          }
          CHECK(bad == 0);
          CHECK(std::all_of(out.begin() + static_cast<std::ptrdiff_t>(n_out), out.end(),
                            [](float v) { return v == -7.0f; }));
          if (threads == 1)
            one_thread = out;
          else
            CHECK(out == one_thread);
        }
      }
    }
    MESSAGE("Winograd F(", tile, "x", tile,
            ", 3x3) vs direct (double): max |diff| / sum |w x| = ", worst,
            ", max |diff| / bound = ", worst_bound);
    CHECK(worst > 0); // the comparison ran on float results
  }
}

#if SHADOWSENSE_X86_KERNELS
TEST_CASE("Winograd's panel input transforms (AVX-512: F(2x2), F(4x4), F(3x3, 4x4)) give every "
          "tile the per-run transform's bits, for steps across one, two and more tile rows") {
  if (!detail::cpu_has(GemmKernelKind::avx512)) return;
  const detail::WinogradOps ops = detail::select_winograd_ops(GemmKernelKind::avx512);
  REQUIRE(static_cast<bool>(ops.input_panel));
  REQUIRE(static_cast<bool>(ops.input4_panel));
  REQUIRE(static_cast<bool>(ops.input3_panel));
  std::mt19937 rng(17);
  constexpr int nr = 32;
  int compared = 0;
  for (const int tile : {2, 4, 3}) { // 3: F(3x3, 4x4), conv0's
    const int products = tile == 2 ? 16 : 36;
    const auto per_run = tile == 2 ? ops.input : tile == 4 ? ops.input4 : ops.input3;
    const auto panel = tile == 2   ? ops.input_panel
                       : tile == 4 ? ops.input4_panel
                                   : ops.input3_panel;
    // Tile rows of 1 to 17 tiles, panels starting anywhere in a row.
    for (const int tiles_x : {1, 3, 5, 7, 10, 16, 17})
      for (const int channels : {1, 3}) {
        const int h = tile * 5, w = tile * tiles_x, tiles = 5 * tiles_x;
        const int pw = detail::winograd_padded(w, tile);
        const std::size_t plane = static_cast<std::size_t>(detail::winograd_padded(h, tile)) * pw;
        const std::vector<float> in = winograd_input_planes(channels, plane, pw, 1, h, w, rng);
        const std::size_t xs = static_cast<std::size_t>(channels) * nr + 16;
        for (int t0 = 0; t0 < tiles; t0 += 7) {
          const int cols = std::min(nr, tiles - t0);
          CAPTURE(tile);
          CAPTURE(tiles_x);
          CAPTURE(channels);
          CAPTURE(t0);
          std::vector<float> want(static_cast<std::size_t>(products) * xs, 0.0f),
              got(want.size(), 0.0f);
          for (int j = 0; j < cols;) { // per run, as winograd_conv_tile calls it
            const int ty = (t0 + j) / tiles_x, tx = (t0 + j) % tiles_x;
            const int run = std::min(cols - j, tiles_x - tx);
            per_run(in.data() + static_cast<std::size_t>(tile * ty) * pw + tile * tx, plane,
                    channels, pw, run, nr - j, want.data() + j, nr, xs);
            j += run;
          }
          panel(in.data(), plane, channels, pw, tiles_x, t0, cols, got.data(), nr, xs);
          int differ = 0;
          for (int xi = 0; xi < products; ++xi)
            for (int ch = 0; ch < channels; ++ch)
              for (int j = 0; j < cols; ++j) {
                const std::size_t at = static_cast<std::size_t>(xi) * xs +
                                       static_cast<std::size_t>(ch) * nr +
                                       static_cast<std::size_t>(j);
                differ += std::memcmp(&want[at], &got[at], sizeof(float)) != 0;
              }
          CHECK(differ == 0);
          ++compared;
        }
      }
  }
  MESSAGE("panels compared: " << compared);
}

TEST_CASE("Winograd's image output (AVX-512: output4_image) gives the per-run output and "
          "interleave's bits, and writes nothing else") {
  if (!detail::cpu_has(GemmKernelKind::avx512)) return;
  const detail::MicroKernel mk = detail::select_micro_kernel(GemmKernelKind::avx512);
  const detail::WinogradOps with = detail::select_winograd_ops(GemmKernelKind::avx512);
  REQUIRE(static_cast<bool>(with.output4_image));
  detail::WinogradOps without = with;
  without.output4_image = nullptr;
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> ud(-1.0f, 1.0f);
  struct Shape {
    int m, c, h, w;
  };
  // One tile, tile rows of 1 to 21 tiles (steps and panels across rows), partial tiles at the
  // right and bottom edges, the shipped model's blocks 1 (22 x 40) and 2 (11 x 20), several
  // row panels of output channels (m > mr) and a last one that does not fill its rows.
  const Shape shapes[] = {{3, 2, 1, 1},     {5, 3, 4, 4},   {8, 4, 7, 66},  {12, 5, 22, 40},
                          {12, 48, 11, 20}, {9, 3, 13, 50}, {20, 2, 30, 5}, {4, 3, 9, 81}};
  int compared = 0;
  for (const auto& sh : shapes) {
    CAPTURE(sh.m);
    CAPTURE(sh.h);
    CAPTURE(sh.w);
    const int pw = detail::winograd_padded(sh.w, 4);
    const std::size_t plane = static_cast<std::size_t>(detail::winograd_padded(sh.h, 4)) * pw;
    const std::vector<float> in = winograd_input_planes(sh.c, plane, pw, 1, sh.h, sh.w, rng);
    std::vector<float> w(static_cast<std::size_t>(sh.m) * sh.c * 9);
    for (auto& v : w) v = ud(rng);
    detail::WinogradWeights u;
    u.set(w.data(), sh.m, sh.c, mk.mr, 4);
    detail::ThreadPool pool(1);
    std::vector<detail::WinogradScratch> scratch(1, detail::make_winograd_scratch(sh.c, sh.m, mk));
    const std::size_t n_out = static_cast<std::size_t>(sh.m) * sh.h * sh.w;
    std::vector<float> want(n_out + 64, -7.0f), got(n_out + 64, -7.0f);
    detail::winograd_conv3x3(mk, without, u, in.data(), pw, plane, sh.h, sh.w, want.data(), pool,
                             scratch);
    detail::winograd_conv3x3(mk, with, u, in.data(), pw, plane, sh.h, sh.w, got.data(), pool,
                             scratch);
    CHECK(std::memcmp(want.data(), got.data(), want.size() * sizeof(float)) == 0);
    CHECK(std::all_of(got.begin() + static_cast<std::ptrdiff_t>(n_out), got.end(),
                      [](float v) { return v == -7.0f; }));
    ++compared;
  }
  MESSAGE("convolutions compared: " << compared);
}
#endif

TEST_CASE("Winograd F(3x3, 4x4) equals the direct 4x4 correlation, bias and ReLU after, for "
          "every kernel") {
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> ud(-1.0f, 1.0f);
  struct Shape {
    int m, c, h, w;
  };
  // conv0's own (24 output channels over the 12 stride-2 phases of a 3-channel image, the
  // shipped model's 44 x 80 and DenseNet-121's 75 x 110), one tile, sizes 1-2 past a multiple
  // of 3, a tile row longer than one 16-tile step, rows that do not fill a panel.
  const Shape shapes[] = {{24, 12, 44, 80}, {64, 12, 75, 110}, {3, 5, 1, 1},  {8, 4, 2, 5},
                          {7, 3, 4, 7},     {12, 12, 9, 52},   {5, 2, 3, 50}, {9, 12, 10, 3}};
  double worst = 0, worst_bound = 0;
  for (const auto& sh : shapes) {
    CAPTURE(sh.m);
    CAPTURE(sh.c);
    CAPTURE(sh.h);
    CAPTURE(sh.w);
    // The input as conv0's phases hold it: the (h + 3) x (w + 3) region read by the direct
    // correlation, zero beyond it up to the padded extent the tiles read.
    const int pw = detail::winograd_padded(sh.w, 3);
    const std::size_t plane = static_cast<std::size_t>(detail::winograd_padded(sh.h, 3)) * pw;
    const std::vector<float> in =
        winograd_input_planes(sh.c, plane, pw, 0, sh.h + 3, sh.w + 3, rng);
    std::vector<float> w(static_cast<std::size_t>(sh.m) * sh.c * 16), bias(sh.m);
    for (auto& v : w) v = ud(rng);
    for (auto& v : bias) v = 0.5f * ud(rng);
    std::vector<double> ref, scale, wscale;
    reference_conv(4, w, in, sh.m, sh.c, sh.h, sh.w, pw, plane, ref, scale);
    winograd_abs_scale(3, w, in, sh.m, sh.c, sh.h, sh.w, pw, plane, wscale);
    const double eps = std::numeric_limits<float>::epsilon();
    const std::size_t n_out = static_cast<std::size_t>(sh.m) * sh.h * sh.w;
    for (const auto& mk : kernels_under_test()) {
      std::vector<float> one_thread;
      for (int threads : {1, 2, 3}) { // 2 and 3: the 1-thread outputs bit for bit
        const std::string name = mk.name;
        CAPTURE(name);
        CAPTURE(threads);
        detail::WinogradWeights u;
        u.set(w.data(), sh.m, sh.c, mk.mr, 3);
        detail::ThreadPool pool(threads);
        std::vector<detail::WinogradScratch> scratch(static_cast<std::size_t>(threads),
                                                     detail::make_winograd_scratch(sh.c, sh.m, mk));
        std::vector<float> out(n_out + 64, -7.0f);
        detail::winograd_conv4x4(mk, detail::select_winograd_ops(mk.kind), u, in.data(), pw, plane,
                                 sh.h, sh.w, bias.data(), out.data(), pool, scratch);
        int bad = 0;
        const std::size_t image = static_cast<std::size_t>(sh.h) * sh.w;
        for (std::size_t k = 0; k < n_out; ++k) {
          // relu(conv + b): the bias adds one rounding of the sum's size
          const double b = bias[k / image], want = std::max(ref[k] + b, 0.0);
          const double diff = std::abs(double(out[k]) - want);
          const double bound = (sh.c + 32) * eps * wscale[k] + eps * std::abs(ref[k] + b);
          if (ref[k] + b > 0) {
            worst =
                std::max(worst, std::abs(double(out[k]) - b - ref[k]) / std::max(scale[k], 1e-30));
            worst_bound = std::max(worst_bound, diff / std::max(bound, 1e-30));
          }
          if (!(diff <= bound)) ++bad; // (NaN counts as bad)
        }
        CHECK(bad == 0);
        CHECK(std::all_of(out.begin() + static_cast<std::ptrdiff_t>(n_out), out.end(),
                          [](float v) { return v == -7.0f; }));
        if (threads == 1)
          one_thread = out;
        else
          CHECK(out == one_thread);
      }
    }
  }
  MESSAGE("Winograd F(3x3, 4x4) vs direct (double): max |diff| / sum |w x| = ", worst,
          ", max |diff| / bound = ", worst_bound);
  CHECK(worst > 0);
}

TEST_CASE("winograd_tile: F(4x4) on large images and where its GEMM costs at most 1.2x F(2x2)'s, "
          "F(2x2) or direct where tiles leave panels empty") {
  // DenseNet-121/-161 at 3x150x220 (growth 32 / 48, nr = 32): blocks 1-4
  CHECK(detail::winograd_tile(38, 55, 32, 32) == 4);
  CHECK(detail::winograd_tile(19, 27, 48, 32) == 4); // F(4x4): 2 panels x 36 <= 1.2 x 5 x 16
  CHECK(detail::winograd_tile(9, 13, 32, 32) == 4);  // 12 tiles of 4x4: 36 <= 1.2 x 2 x 16
  CHECK(detail::winograd_tile(4, 6, 32, 32) == 0);   // block 4: 6 tiles in one 32-column panel
  CHECK(detail::winograd_tile(1, 1, 32, 32) == 0);
  CHECK(detail::winograd_tile(38, 55, 16, 32) == 4); // 16 output channels: still pays
  CHECK(detail::winograd_tile(38, 55, 8, 32) == 0);  // growth 8: direct
  // The shipped model (growth 12, 3x88x160): blocks 40x22, 20x11, 10x5
  CHECK(detail::winograd_tile(40, 22, 12, 32) == 4);
  CHECK(detail::winograd_tile(20, 11, 12, 32) == 4); // 15 tiles of 4x4: 36 <= 1.2 x 2 x 16
  CHECK(detail::winograd_tile(10, 5, 12, 32) == 2);  // 6 tiles of 4x4: 36 > 1.2 x 16
  CHECK(detail::winograd_tile(40, 22, 11, 32) == 0);
  CHECK(detail::winograd_tile(38, 55, 32, 16) == 4); // AVX2's 16 columns
  // Weights read from memory: one more panel pass per method. Block 3 goes direct (6 x 9 = 54
  // against F(2x2) 3 x 16 = 48 > 3/4 of it, F(4x4) 2 x 36 = 72); blocks 1 and 2 stay F(4x4)
  // (6 x 36 = 216 against 18 x 16, 3 x 36 = 108 <= 1.2 x 6 x 16).
  CHECK(detail::winograd_tile(9, 13, 32, 32, true) == 0);
  CHECK(detail::winograd_tile(9, 13, 48, 32, true) == 0);
  CHECK(detail::winograd_tile(19, 27, 32, 32, true) == 4);
  CHECK(detail::winograd_tile(19, 27, 48, 32, true) == 4);
  CHECK(detail::winograd_tile(38, 55, 32, 32, true) == 4);
  CHECK(detail::winograd_tile(4, 6, 32, 32, true) == 0);
  CHECK(detail::winograd_tile(20, 11, 12, 32, true) == 2); // 2 x 36 > 1.2 x 3 x 16
  CHECK(detail::winograd_tile(20, 11, 12, 32, false) == 4);
}

TEST_CASE("run_column_ranges: the ranges exactly, their ends on multiples of the step") {
  // (task, first column, columns) of every call, sorted.
  auto calls = [](int threads, int n, int nr, int step) {
    detail::ThreadPool pool(threads);
    std::mutex mutex;
    std::vector<std::array<int, 3>> seen;
    detail::run_column_ranges(pool, n, nr, step, [&](int t, int n0, int cols) {
      std::lock_guard<std::mutex> lock(mutex);
      seen.push_back({t, n0, cols});
    });
    std::sort(seen.begin(), seen.end());
    return seen;
  };
  using Calls = std::vector<std::array<int, 3>>;
  // DenseNet-121 at 3x150x220, 2 threads, steps of 8 (the AVX-512 kernels' widths): block 2's
  // 35 tiles 16 / 19 (not the whole panels 32 / 3), block 3's 12 tiles 8 / 4, block 1's 140
  // tiles 72 / 68.
  CHECK(calls(2, 35, 32, 8) == Calls{{0, 0, 16}, {1, 16, 19}});
  CHECK(calls(2, 12, 32, 8) == Calls{{0, 0, 8}, {1, 8, 4}});
  CHECK(calls(2, 140, 32, 8) ==
        Calls{{0, 0, 32}, {0, 32, 32}, {0, 64, 8}, {1, 72, 32}, {1, 104, 32}, {1, 136, 4}});
  CHECK(calls(2, 925, 32, 8).size() == 30); // conv0's tiles: 464 / 461
  CHECK(calls(2, 925, 32, 8)[14] == std::array<int, 3>{0, 448, 16});
  CHECK(calls(2, 925, 32, 8)[15] == std::array<int, 3>{1, 464, 32});
  // Step 1: equal ranges.
  CHECK(calls(2, 12, 32, 1) == Calls{{0, 0, 6}, {1, 6, 6}});
  CHECK(calls(3, 35, 16, 1) == Calls{{0, 0, 12}, {1, 12, 11}, {2, 23, 12}});
  CHECK(calls(3, 35, 32, 8) == Calls{{0, 0, 8}, {1, 8, 16}, {2, 24, 11}});
  CHECK(calls(1, 40, 32, 8) == Calls{{0, 0, 32}, {0, 32, 8}});
  CHECK(calls(3, 2, 32, 1) == Calls{{0, 0, 1}, {1, 1, 1}}); // fewer columns than threads
  CHECK(calls(2, 2, 32, 8) == Calls{{1, 0, 2}});            // the nearest multiple of 8 to 1 is 0
  CHECK(calls(2, 0, 32, 8).empty());
  // The boundaries themselves: nearest multiple of the step, never past n.
  CHECK(detail::column_range_start(35, 2, 1, 8) == 16);
  CHECK(detail::column_range_start(36, 2, 1, 8) == 16); // 18 / 8 = 2.25
  CHECK(detail::column_range_start(40, 2, 1, 8) == 24); // 20 / 8 = 2.5 rounds up
  CHECK(detail::column_range_start(5, 2, 2, 8) == 5);
  CHECK(detail::column_range_start(7, 2, 1, 8) == 0); // 3.5 / 8 rounds to 0
}

TEST_CASE("PackedMatrix::unpack returns the packed matrix") {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> ud(-1.0f, 1.0f);
  for (int mr : {1, 6, 8}) {
    std::vector<float> w(13 * 7);
    for (auto& v : w) v = ud(rng);
    detail::PackedMatrix p;
    p.pack(w.data(), 13, 7, mr);
    CHECK(p.unpack() == w);
  }
}

// gemm() at several thread counts against its 1-thread result, bit for bit (each C entry is the
// same micro-kernel call on the same packed panels whoever runs it), and against a double
// reference. The shapes cover both splits: by column panels (many panels) and by row panels with
// every B panel packed once into the shared buffer (few panels), a last panel of at most nr / 2
// columns (the half kernel), and fewer row panels than threads.
TEST_CASE("gemm(): every thread split gives the 1-thread result bit for bit") {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> ud(-1.0f, 1.0f);
  for (const auto& mk : kernels_under_test()) {
    const std::string name = mk.name;
    CAPTURE(name);
    for (const auto& [m, k, n_cols_in_panels] : {std::tuple{48, 37, 1.0},
                                                 {48, 37, 2.5},
                                                 {12, 200, 3.4},
                                                 {5, 9, 4.0},
                                                 {96, 64, 5.2},
                                                 {3, 16, 1.5},
                                                 {40, 11, 20.6}}) {
      const int n = std::max(1, static_cast<int>(n_cols_in_panels * mk.nr));
      CAPTURE(m);
      CAPTURE(k);
      CAPTURE(n);
      std::vector<float> w(static_cast<std::size_t>(m) * k), b(static_cast<std::size_t>(k) * n);
      for (auto& v : w) v = ud(rng);
      for (auto& v : b) v = ud(rng);
      detail::PackedMatrix a;
      a.pack(w.data(), m, k, mk.mr);
      // B row-major K x N; a panel is columns n0 .. n0 + cols of it, zero beyond.
      auto pack = [&](float* dst, int n0, int cols, int*) {
        for (int r = 0; r < k; ++r)
          for (int j = 0; j < mk.nr; ++j)
            dst[static_cast<std::size_t>(r) * mk.nr + j] =
                j < cols ? b[static_cast<std::size_t>(r) * n + n0 + j] : 0.0f;
      };
      auto run = [&](int threads) {
        std::vector<float> c(static_cast<std::size_t>(m) * n, -7.0f);
        detail::ThreadPool pool(threads);
        std::vector<detail::GemmScratch> scratch(static_cast<std::size_t>(threads));
        for (auto& s : scratch) {
          s.panel.assign(static_cast<std::size_t>(k) * mk.nr, 0.0f);
          s.tile.assign(static_cast<std::size_t>(mk.mr) * mk.nr, 0.0f);
          s.index.assign(static_cast<std::size_t>(mk.nr), 0);
        }
        for (int rep = 0; rep < 2; ++rep) // the second call reuses the shared buffer
          detail::gemm(
              mk, a, n, pack,
              [&](int row, int n0, int cols, const float* v) {
                std::copy(v, v + cols, c.begin() + static_cast<std::ptrdiff_t>(row) * n + n0);
              },
              pool, scratch);
        return c;
      };
      const std::vector<float> one = run(1);
      double worst = 0;
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < n; ++j) {
          double ref = 0, mag = 0;
          for (int r = 0; r < k; ++r) {
            const double t = double(w[static_cast<std::size_t>(i) * k + r]) *
                             b[static_cast<std::size_t>(r) * n + j];
            ref += t;
            mag += std::abs(t);
          }
          worst = std::max(worst, std::abs(one[static_cast<std::size_t>(i) * n + j] - ref) /
                                      std::max(mag, 1e-30));
        }
      CHECK(worst <= (k + 2) * double(FLT_EPSILON)); // every entry written, to float accuracy
      for (int threads : {2, 3}) {
        CAPTURE(threads);
        CHECK(run(threads) == one);
      }
    }
  }
}

TEST_CASE("conv1x1_fmas and pixel_rows_pay: the FMA counts of both layouts, and which pays") {
  // DenseNet-121 at 3 x 150 x 220 (128 channels; blocks of 2090, 513, 117 and 24 pixels).
  CHECK(detail::conv1x1_fmas(128, 117, false) == 128 * 8);         // 3 x 32 + 21 pixels
  CHECK(detail::conv1x1_fmas(128, 117, true) == (14 * 8 + 8) * 8); // 5 pixels: a full row panel
  CHECK(detail::conv1x1_fmas(128, 24, false) == 128 * 2);
  CHECK(detail::conv1x1_fmas(128, 24, true) == 24 * 8);
  CHECK(detail::conv1x1_fmas(128, 513, true) == (64 * 8 + 4) * 8); // 1 pixel: 4 rows
  CHECK(detail::conv1x1_fmas(48, 50, false) == 48 * 4);
  CHECK(detail::conv1x1_fmas(48, 50, true) == (6 * 8 + 4) * 3);  // 32 + 16 channels
  CHECK(detail::conv1x1_fmas(44, 32, false) == (5 * 8 + 4) * 2); // 4 channels: 4 rows
  CHECK(detail::pixel_rows_pay(128, 117));                       // 0.94
  CHECK(detail::pixel_rows_pay(128, 24));                        // 0.75
  CHECK(!detail::pixel_rows_pay(128, 513));                      // 0.98
  CHECK(!detail::pixel_rows_pay(128, 2090));                     // 1.00
  CHECK(detail::pixel_rows_pay(48, 50));   // the shipped model's block 3: 0.81
  CHECK(!detail::pixel_rows_pay(48, 220)); // its block 2: 0.98
  CHECK(!detail::pixel_rows_pay(48, 880)); // its block 1: 1.00
  // The transitions (output channels, pooled pixels): DenseNet-121's 1 to 3, the shipped
  // model's 1 and 2.
  CHECK(detail::conv1x1_fmas(256, 117, false) == 256 * 8);
  CHECK(detail::conv1x1_fmas(256, 117, true) == 120 * 16);
  CHECK(!detail::pixel_rows_pay(128, 513));
  CHECK(detail::pixel_rows_pay(256, 117)); // 0.94
  CHECK(detail::pixel_rows_pay(512, 24));  // 0.75
  CHECK(detail::conv1x1_fmas(42, 50, false) == 44 * 4);
  CHECK(detail::conv1x1_fmas(42, 50, true) == 52 * 3);
  CHECK(!detail::pixel_rows_pay(36, 220)); // 1.31
  CHECK(detail::pixel_rows_pay(42, 50));   // 0.89
}

#if SHADOWSENSE_X86_KERNELS
TEST_CASE("gemm_pixel_rows_avx512: the bits of gemm_fused_avx512 for every output, at 1-3 "
          "threads, laid out by the segments") {
  if (!detail::cpu_has(GemmKernelKind::avx512)) return;
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> ud(-1.0f, 1.0f);
  const float sentinel = -7.0f;
  for (const auto& [m, k, n, width] : {std::tuple{128, 300, 117, 13},
                                       {128, 64, 24, 6},
                                       {48, 37, 50, 10},
                                       {44, 9, 5, 5},
                                       {12, 200, 33, 11},
                                       {200, 17, 70, 7},
                                       {16, 1, 8, 8}}) {
    CAPTURE(m);
    CAPTURE(k);
    CAPTURE(n);
    std::vector<float> w(static_cast<std::size_t>(m) * k), x(static_cast<std::size_t>(k) * n),
        bias(static_cast<std::size_t>(m));
    for (auto& v : w) v = ud(rng);
    for (auto& v : x) v = ud(rng);
    for (auto& v : bias) v = ud(rng);
    x[5] = std::numeric_limits<float>::quiet_NaN(); // a NaN input pixel reaches every channel
    detail::PackedMatrix a;
    a.pack(w.data(), m, k, 8);
    detail::PixelRowWeights wp;
    wp.set(w.data(), m, k);
    // x: k x n, the pixels of width-wide image rows; C goes to rows 2 wider with a lead of 3,
    // one plane per output channel.
    const int stride = width + 2, lead = 3, rows = (n + width - 1) / width;
    const std::size_t plane = static_cast<std::size_t>(rows) * stride + lead + 8;
    auto pack = [&](float* dst, int n0, int cols, int*) {
      for (int r = 0; r < k; ++r)
        for (int j = 0; j < 32; ++j)
          dst[static_cast<std::size_t>(r) * 32 + j] =
              j < cols ? x[static_cast<std::size_t>(r) * n + n0 + j] : 0.0f;
    };
    auto segments = [&](int n0, int cols, detail::TileSegments& seg) {
      detail::image_row_segments(n0, cols, width, width, stride, lead, seg);
    };
    auto run = [&](int threads, bool pixel_rows) {
      std::vector<float> c(static_cast<std::size_t>(m) * plane, sentinel);
      detail::ThreadPool pool(threads);
      std::vector<detail::GemmScratch> scratch(static_cast<std::size_t>(threads));
      for (auto& s : scratch) {
        s.panel.assign(static_cast<std::size_t>(k) * 32, 0.0f);
        s.tile.assign(8 * 32, 0.0f);
        s.index.assign(32, 0);
      }
      if (pixel_rows)
        detail::gemm_pixel_rows_avx512(wp, n, pack, segments, c.data(), plane, bias.data(), true,
                                       pool, scratch);
      else
        detail::gemm_fused_avx512(a, n, pack, nullptr, nullptr, segments, c.data(), plane,
                                  bias.data(), true, pool, scratch);
      return c;
    };
    auto same_bits = [](const std::vector<float>& p, const std::vector<float>& q) {
      return p.size() == q.size() && std::memcmp(p.data(), q.data(), p.size() * 4) == 0;
    };
    const std::vector<float> want = run(1, false);
    int written = 0;
    for (float v : want) written += v == sentinel ? 0 : 1;
    CHECK(written == m * n); // every output once, nothing beyond the segments
    for (int threads : {1, 2, 3}) {
      CAPTURE(threads);
      CHECK(same_bits(run(threads, true), want));
    }
  }
}
#endif
