// The segmenter's per-row kernels (sense/segment_kernels*.hpp) against each other and against
// their definitions, without OpenCV (so the aarch64 build under emulation runs it too,
// .ci/steps/50_aarch64.sh): every kernel the CPU runs must give the portable kernel's floats
// and bytes exactly, on random rows of every width up to 70 (all the vector tails), with
// thresholds hit exactly, skin values 0, 255 and others, and extreme pixel and model values;
// the smoothing rows must equal their sums written out. detail::run_end (the contour scan's run
// walk, SSE2 / NEON / 64-bit words) against the byte loop.
#include <shadowsense/sense/byte_runs.hpp>
#include <shadowsense/sense/segment_kernels.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

using namespace shadowsense;

namespace {

constexpr int kGuard = 40; // values past a row that a kernel must leave alone

struct Row {
  std::vector<std::uint8_t> bgr, skin;
  std::vector<std::uint16_t> ipb, ipg, ipr; // the inverse model as binary16 bits
};

// A random positive binary16 value with its exponent field in [lo, hi] (15 is [1, 2)).
std::uint16_t random_half(std::mt19937& rng, int lo, int hi) {
  std::uniform_int_distribution<int> exponent(lo, hi), fraction(0, 1023);
  return static_cast<std::uint16_t>((exponent(rng) << 10) | fraction(rng));
}

Row random_row(std::mt19937& rng, int w) {
  Row r;
  const auto n = static_cast<std::size_t>(w);
  r.bgr.resize(3 * n);
  r.skin.resize(n);
  r.ipb.resize(n);
  r.ipg.resize(n);
  r.ipr.resize(n);
  std::uniform_int_distribution<int> byte(0, 255), pick(0, 9);
  for (auto& b : r.bgr)
    b = static_cast<std::uint8_t>(pick(rng) == 0 ? 255 * (byte(rng) & 1) : byte(rng));
  for (std::size_t x = 0; x < n; ++x) {
    const int s = pick(rng);
    r.skin[x] = s < 2 ? 0 : s == 2 ? static_cast<std::uint8_t>(byte(rng)) : 255;
    // 0.5 to 2 mostly, else 1/16 to 32 (the model's inverse lies in 0.05 to 20)
    for (std::vector<std::uint16_t>* p : {&r.ipb, &r.ipg, &r.ipr})
      (*p)[x] = r.skin[x] == 0 && s == 0 ? std::uint16_t{0} // off the skin the model is 0
                : pick(rng) == 0         ? random_half(rng, 11, 19)
                                         : random_half(rng, 14, 15);
  }
  return r;
}

struct Out {
  std::vector<float> d, w;
  std::vector<std::uint8_t> s, c;
  explicit Out(int n)
      : d(static_cast<std::size_t>(n)), w(d), s(static_cast<std::size_t>(n), 7), c(s) {}
  bool operator==(const Out&) const = default;
};

Out run(const detail::SegmentKernels& k, const detail::RelativeRowParams& p, const Row& r, int w) {
  Out o(w);
  k.relative_row(p, r.bgr.data(), r.ipb.data(), r.ipg.data(), r.ipr.data(), r.skin.data(), w,
                 o.d.data(), o.w.data(), o.s.data(), o.c.data());
  return o;
}

std::vector<SegmentKernelKind> vector_kinds() {
  std::vector<SegmentKernelKind> kinds;
  for (SegmentKernelKind k :
       {SegmentKernelKind::avx512, SegmentKernelKind::avx2, SegmentKernelKind::neon})
    if (segment_cpu_has(k)) kinds.push_back(k);
  return kinds;
}

// The rule's darkness of one pixel, each operation rounded (no fused multiply-add, which the
// compiler may otherwise use here on aarch64).
SHADOWSENSE_STRICT_FP float darkness_of(float b, float g, float r, bool skin) {
  SHADOWSENSE_STRICT_FP_BODY
  const float sum = b + g;
  const float mean = (sum + r) * (1.f / 3.f);
  return (skin ? 1.f : 0.f) - mean;
}
SHADOWSENSE_STRICT_FP float product(float v, float inv, float gain) {
  SHADOWSENSE_STRICT_FP_BODY
  return v * inv * gain;
}

// A binary16 value by its definition, (-1)^s 2^(e - 15) (1 + f / 1024), or 2^-14 (f / 1024) for
// e = 0, in double (exact) and then float (exact: every binary16 value is a float).
float half_value(std::uint16_t h) {
  const int e = (h >> 10) & 0x1F, f = h & 0x3FF;
  const double magnitude = e == 0 ? std::ldexp(f, -24) : std::ldexp(1024 + f, e - 25);
  return static_cast<float>((h & 0x8000) ? -magnitude : magnitude);
}

} // namespace

TEST_CASE("half_to_float: every binary16 bit pattern, exactly") {
  int checked = 0;
  for (std::uint32_t h = 0; h <= 0xFFFF; ++h) {
    CAPTURE(h);
    const auto bits = static_cast<std::uint16_t>(h);
    const float got = detail::half_to_float(bits);
    const int e = (h >> 10) & 0x1F, f = h & 0x3FF;
    if (e == 0x1F) { // infinities and NaNs
      CHECK((f == 0 ? std::isinf(got) : std::isnan(got)));
      CHECK(std::signbit(got) == ((h & 0x8000) != 0));
      continue;
    }
    const float want = half_value(bits);
    CHECK(std::memcmp(&got, &want, sizeof got) == 0); // the bits: -0 stays -0
    ++checked;
  }
  CHECK(checked == 2 * 31 * 1024);
}

TEST_CASE("relative_row: the portable kernel is the rule's definition") {
  std::mt19937 rng(5);
  const detail::SegmentKernels& k = segment_kernels(SegmentKernelKind::portable);
  const detail::RelativeRowParams p{1.f / 230, 1.f / 220, 1.f / 210, 0.2f, 0.45f, 0.08f};
  const Row r = random_row(rng, 64);
  const Out o = run(k, p, r, 64);
  int shadow = 0, contact = 0;
  for (std::size_t x = 0; x < 64; ++x) {
    const float qb = product(r.bgr[3 * x], half_value(r.ipb[x]), p.gb);
    const float qg = product(r.bgr[3 * x + 1], half_value(r.ipg[x]), p.gg);
    const float qr = product(r.bgr[3 * x + 2], half_value(r.ipr[x]), p.gr);
    const float d = darkness_of(qb, qg, qr, r.skin[x] != 0);
    CHECK(o.d[x] == d);
    CHECK(o.w[x] == qr - qb);
    const bool c = d >= p.contact && qr - qb >= p.warmth;
    CHECK(o.c[x] == (c ? r.skin[x] : 0));
    CHECK(o.s[x] == ((d >= p.shadow ? r.skin[x] : 0) | (c ? r.skin[x] : 0)));
    shadow += o.s[x] != 0;
    contact += o.c[x] != 0;
  }
  CHECK(shadow > 0);
  CHECK(contact > 0);
}

// Rows of every width 0-70, 8 random rows each (the last with thresholds equal to computed
// values: >= must hold exactly) through fn; returns how many differ from the portable kernel.
static int relative_row_mismatches(detail::RelativeRowFn fn, std::mt19937& rng) {
  const detail::SegmentKernels& portable = segment_kernels(SegmentKernelKind::portable);
  detail::SegmentKernels k = portable;
  k.relative_row = fn;
  int mismatched_rows = 0, rows = 0;
  for (int w = 0; w <= 70; ++w)
    for (int rep = 0; rep < 8; ++rep) {
      const Row r = random_row(rng, w);
      detail::RelativeRowParams p{
          1.f / static_cast<float>(40 + rep * 25), 1.f / 150.f, 1.f / 130.f, 0.2f, 0.45f, 0.08f};
      if (rep == 7 && w > 0) {
        const Out o = run(portable, p, r, w);
        p.shadow = o.d[0];
        p.contact = o.d[static_cast<std::size_t>(w - 1)];
        p.warmth = o.w[static_cast<std::size_t>(w / 2)];
      }
      ++rows;
      mismatched_rows += !(run(portable, p, r, w) == run(k, p, r, w));
    }
  CHECK(rows == 71 * 8);
  return mismatched_rows;
}

TEST_CASE("relative_row: every vector kernel equals the portable one, every width") {
  std::mt19937 rng(11);
  for (const SegmentKernelKind kind : vector_kinds()) {
    CAPTURE(segment_kernel_name(kind));
    const detail::SegmentKernels& k = segment_kernels(kind);
    REQUIRE(k.kind == kind);
    CHECK(relative_row_mismatches(k.relative_row, rng) == 0);
  }
}

#if SHADOWSENSE_SEGMENT_X86
// The avx512 kind runs one of two kernels, by whether the CPU has VBMI: both are checked here
// where the CPU runs them (the test above checks only the one picked).
TEST_CASE("relative_row: both AVX-512 kernels (byte shuffles, VBMI permutes) equal the portable "
          "one") {
  std::mt19937 rng(12);
  if (segment_cpu_has(SegmentKernelKind::avx512))
    CHECK(relative_row_mismatches(detail::relative_row_avx512, rng) == 0);
  if (detail::segment_cpu_has_vbmi())
    CHECK(relative_row_mismatches(detail::relative_row_avx512_vbmi, rng) == 0);
  else
    MESSAGE("this CPU has no AVX-512 VBMI: relative_row_avx512_vbmi not run");
}
#endif

TEST_CASE("mask smoothing rows: every kernel equals the weighted sums written out") {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> byte(0, 255), coin(0, 1);
  std::vector<SegmentKernelKind> kinds = vector_kinds();
  kinds.push_back(SegmentKernelKind::portable);
  for (const SegmentKernelKind kind : kinds) {
    CAPTURE(segment_kernel_name(kind));
    const detail::SegmentKernels& k = segment_kernels(kind);
    for (const int K : {3, 5}) {
      const std::array<int, 5> wt =
          K == 3 ? std::array<int, 5>{1, 2, 1, 0, 0} : std::array<int, 5>{1, 4, 6, 4, 1};
      const int on = K == 3 ? 2040 : 32640;
      int bad = 0, set = 0;
      for (int w = 1; w <= 70; ++w) {
        std::vector<std::vector<std::uint16_t>> h(static_cast<std::size_t>(K));
        for (int t = 0; t < K; ++t) {
          std::vector<std::uint8_t> pad(static_cast<std::size_t>(w + K - 1));
          for (auto& v : pad)
            v = static_cast<std::uint8_t>(coin(rng) ? 255 * coin(rng) : byte(rng));
          // kGuard values past the row: a kernel must not write them.
          h[static_cast<std::size_t>(t)].assign(static_cast<std::size_t>(w + kGuard), 0xBEEF);
          (K == 3 ? k.hsum3 : k.hsum5)(pad.data(), w, h[static_cast<std::size_t>(t)].data());
          for (int x = w; x < w + kGuard; ++x)
            bad += h[static_cast<std::size_t>(t)][static_cast<std::size_t>(x)] != 0xBEEF;
          for (int x = 0; x < w; ++x) {
            int sum = 0;
            for (int j = 0; j < K; ++j)
              sum += wt[static_cast<std::size_t>(j)] * pad[static_cast<std::size_t>(x + j)];
            bad += h[static_cast<std::size_t>(t)][static_cast<std::size_t>(x)] != sum;
          }
        }
        std::array<const std::uint16_t*, 5> rows{};
        for (int t = 0; t < K; ++t)
          rows[static_cast<std::size_t>(t)] = h[static_cast<std::size_t>(t)].data();
        std::vector<std::uint8_t> mask(static_cast<std::size_t>(w + kGuard), 7), marks(mask);
        const bool any = (K == 3 ? k.vsum3 : k.vsum5)(rows.data(), w, mask.data(), marks.data());
        std::vector<std::uint8_t> mask_only(static_cast<std::size_t>(w + kGuard), 7);
        const bool any_only =
            (K == 3 ? k.vsum3 : k.vsum5)(rows.data(), w, mask_only.data(), nullptr);
        int lit_here = 0;
        for (int x = 0; x < w; ++x) {
          int v = 0;
          for (int t = 0; t < K; ++t)
            v += wt[static_cast<std::size_t>(t)] *
                 h[static_cast<std::size_t>(t)][static_cast<std::size_t>(x)];
          const bool lit = v >= on;
          set += lit;
          lit_here += lit;
          const auto ux = static_cast<std::size_t>(x);
          bad += mask[ux] != (lit ? 255 : 0) || marks[ux] != (lit ? 1 : 0) ||
                 mask_only[ux] != mask[ux];
        }
        bad += any != (lit_here > 0) || any_only != any;
        for (int x = w; x < w + kGuard; ++x) {
          const auto ux = static_cast<std::size_t>(x);
          bad += mask[ux] != 7 || marks[ux] != 7 || mask_only[ux] != 7;
        }
      }
      CHECK(bad == 0);
      CHECK(set > 0);
    }
  }
}

TEST_CASE("segment_kernels: automatic picks the vector kernel the CPU runs; others refused") {
  const std::vector<SegmentKernelKind> kinds = vector_kinds();
  CHECK(segment_kernels().kind == (kinds.empty() ? SegmentKernelKind::portable : kinds.front()));
  CHECK(segment_cpu_has(SegmentKernelKind::portable));
  CHECK_FALSE(segment_cpu_has(SegmentKernelKind::automatic));
  for (const SegmentKernelKind kind : kinds) CHECK(segment_kernels(kind).kind == kind);
  CHECK(segment_kernels(SegmentKernelKind::portable).kind == SegmentKernelKind::portable);
#if defined(__aarch64__)
  CHECK_FALSE(segment_cpu_has(SegmentKernelKind::avx2));
  CHECK_THROWS_AS(segment_kernels(SegmentKernelKind::avx2), InvalidArgument);
  CHECK_FALSE(segment_cpu_has(SegmentKernelKind::avx512));
  CHECK_THROWS_AS(segment_kernels(SegmentKernelKind::avx512), InvalidArgument);
#else
  // AVX-512 implies AVX2: a CPU with the first and not the second does not exist.
  if (segment_cpu_has(SegmentKernelKind::avx512)) CHECK(segment_cpu_has(SegmentKernelKind::avx2));
  if (!segment_cpu_has(SegmentKernelKind::avx512))
    CHECK_THROWS_AS(segment_kernels(SegmentKernelKind::avx512), InvalidArgument);
  CHECK_FALSE(segment_cpu_has(SegmentKernelKind::neon));
  CHECK_THROWS_AS(segment_kernels(SegmentKernelKind::neon), InvalidArgument);
#endif
}

TEST_CASE("reference_bins: every kernel equals the definition, clamped at both ends") {
  std::mt19937 rng(8);
  const int w = 37, h = 23;
  const std::size_t step = 3 * w + 5; // rows with padding, as in a sub-image
  std::vector<std::uint8_t> frame(step * h);
  std::uniform_int_distribution<int> byte(0, 255), col(1, w - 1), row(0, h - 1), pick(0, 9);
  std::uniform_real_distribution<float> inv(0.5f, 2.f), big(4.1f, 60.f);
  for (auto& b : frame) b = static_cast<std::uint8_t>(byte(rng));
  for (const int n : {0, 1, 7, 8, 9, 63, 200}) {
    CAPTURE(n);
    const auto un = static_cast<std::size_t>(n);
    std::vector<std::int32_t> ys(un), xs(un);
    std::vector<float> ib(un), ig(un), ir(un);
    for (std::size_t i = 0; i < un; ++i) {
      ys[i] = i + 1 == un ? h - 1 : row(rng); // the last pixel of the frame too
      xs[i] = i + 1 == un ? w - 1 : col(rng);
      for (std::vector<float>* p : {&ib, &ig, &ir})
        (*p)[i] = pick(rng) == 0 ? 0.f : pick(rng) == 0 ? big(rng) : inv(rng);
    }
    std::vector<SegmentKernelKind> kinds = vector_kinds();
    kinds.push_back(SegmentKernelKind::portable);
    for (const SegmentKernelKind kind : kinds) {
      CAPTURE(segment_kernel_name(kind));
      std::vector<std::uint16_t> bins(3 * un, 9999);
      segment_kernels(kind).reference_bins(frame.data(), step, ys.data(), xs.data(), ib.data(),
                                           ig.data(), ir.data(), n, bins.data(), bins.data() + un,
                                           bins.data() + 2 * un);
      int bad = 0;
      for (std::size_t i = 0; i < un; ++i) {
        const std::uint8_t* px = frame.data() + static_cast<std::size_t>(ys[i]) * step +
                                 3 * static_cast<std::size_t>(xs[i]);
        const std::array<float, 3> iv{ib[i], ig[i], ir[i]};
        for (std::size_t k = 0; k < 3; ++k) {
          const int expected = std::clamp(static_cast<int>(product(px[k], iv[k], 4.f)), 0, 1023);
          bad += bins[k * un + i] != expected;
        }
      }
      CHECK(bad == 0);
    }
  }
}

TEST_CASE("run_end: the first byte that differs, at every start and end of rows up to 80 bytes") {
  std::mt19937 rng(41);
  int checked = 0, wrong = 0;
  for (const std::int8_t value :
       {std::int8_t{0}, std::int8_t{1}, std::int8_t{2}, std::int8_t{-126}})
    for (int trial = 0; trial < 40; ++trial) {
      // Runs of value broken by a few other bytes (0, 1, 2, -126 or any), then bytes equal to
      // value past the end: a kernel that looked beyond end would run on into them.
      std::vector<std::int8_t> row(80 + 16, value);
      std::uniform_int_distribution<int> where(0, 79), kind(0, 4), any(-128, 127);
      const int breaks = trial % 5;
      for (int b = 0; b < breaks; ++b) {
        const std::int8_t pick[] = {0, 1, 2, -126, static_cast<std::int8_t>(any(rng))};
        const std::int8_t v = pick[kind(rng)];
        row[static_cast<std::size_t>(where(rng))] = v;
      }
      for (int end = 0; end <= 80; ++end)
        for (int x = 0; x <= end; ++x) {
          int want = x;
          while (want < end && row[static_cast<std::size_t>(want)] == value) ++want;
          const int got = detail::run_end(row.data(), x, end, value);
          if (got != want && wrong++ < 5) { // the first few, with their place
            CAPTURE(static_cast<int>(value));
            CAPTURE(x);
            CAPTURE(end);
            CHECK(got == want);
          }
          ++checked;
        }
    }
  CHECK(wrong == 0);
  MESSAGE("run_end calls checked: " << checked);
}
