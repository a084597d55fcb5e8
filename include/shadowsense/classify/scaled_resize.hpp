// The rows of the Preprocessor's bilinear resize of an 8-bit 3-channel frame whose values are
// scaled on the way (classify/preprocess.hpp, run_scaled): value v of channel c becomes
//   scaled_byte(v, gain[c]) = clamp((v / 255) * gain[c], 0, 1)      (in float, as written)
// which is ToTensor (gain 1) and the lighting normalisation (LightingNormaliser::gains). Two
// kernels with one contract:
//   scaled_resize_row_portable  plain C++ (any CPU): a table lookup per tap
//   scaled_resize_row_vbmi      x86-64 with AVX-512 F, BW and VBMI, chosen at run time: 8 output
//                               pixels a step; one two-register byte permute (vpermi2b) fetches
//                               the 48 tap bytes of both taps and all three channels from a
//                               128-byte window of each row, and the values are computed, not
//                               looked up: v / 255 as v * r + a correction by fused multiply-adds
//                               (r = 1 / 255 in float), the correctly rounded quotient for every
//                               byte (checked for all 256 by the tests), then * gain and the
//                               clamp. Pixels whose taps do not fit a window run the portable loop.
// The lookups are the work of the portable loop (12 per output pixel, each a dependent pair of
// loads): a 635 x 350 frame resized to 160 x 88 spent about 40% of the frame encoder there.
//
// ResizeTaps: torch's bilinear taps along one axis (pixels a[x] <= b[x], both nondecreasing in
//   x, and their weights); resize_taps(in, out, taps) makes them for in -> out pixels.
// scaled_byte(v, gain), fill_scaled_table(gains, table): the value above, and ScaledTable
//   (3 x 256 floats, one row per channel) filled with it.
// ScaledResizePlan::make(out_w, row_bytes, taps): the window and byte indices of each group of 8
//   output pixels of a row of row_bytes bytes; made once per geometry (a plain value).
// scaled_resize_row_*(plan, taps, r0, r1, h0, h1, table, gains, d)
//   requires: plan made from taps (out_w = n of them); r0, r1 rows of plan's row_bytes readable
//             bytes (3 per pixel) with 3 b[x] + 2 < row_bytes; table[c][v] =
//             scaled_byte(v, gains[c]) for every c < 3 and v < 256; d[0], d[1], d[2] rows of n
//             floats each (n output pixels; one row per channel, in the frame's channel order).
//   ensures:  for x < n and c < 3, with T = table[c], each operation rounded on its own (no fused
//             multiply-add):
//               t0 = T[r0[3 a[x] + c]] * w0[x] + T[r0[3 b[x] + c]] * w1[x]
//               t1 = T[r1[3 a[x] + c]] * w0[x] + T[r1[3 b[x] + c]] * w1[x]
//               d[c][x] = t0 * h0 + t1 * h1
//             the same floats from both kernels. Reads nothing outside the rows.
// scaled_resize_cpu_has_vbmi(): whether this build and CPU run the VBMI kernel.
// No state but the cached CPU check: callable from any thread.
#pragma once

#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define SHADOWSENSE_SCALED_RESIZE_X86 1
#include <immintrin.h>
#else
#define SHADOWSENSE_SCALED_RESIZE_X86 0
#endif

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

// The scaled value of byte v: ToTensor's v / 255 (a division, as torchvision does), times the
// gain, clamped to [0, 1]; the one definition LightingNormaliser::table and the kernels share.
inline float scaled_byte(int v, float gain) {
  return std::clamp((static_cast<float>(v) / 255.0f) * gain, 0.0f, 1.0f);
}

using ScaledTable = std::array<std::array<float, 256>, 3>;

inline void fill_scaled_table(const std::array<float, 3>& gains, ScaledTable& table) {
  for (std::size_t c = 0; c < 3; ++c)
    for (int v = 0; v < 256; ++v) table[c][static_cast<std::size_t>(v)] = scaled_byte(v, gains[c]);
}

struct ResizeTaps {
  std::vector<int> a, b;
  std::vector<float> w0, w1;
};

// torch's compute_indices_weights_linear (align_corners=False, no explicit scale factor):
// the scale is a float, the source position and the weights are computed in double (CPU
// acc_type of float) and the weights stored as float.
inline void resize_taps(int in, int out, ResizeTaps& t) {
  const double scale = static_cast<float>(in) / static_cast<float>(out);
  t.a.resize(static_cast<std::size_t>(out));
  t.b.resize(t.a.size());
  t.w0.resize(t.a.size());
  t.w1.resize(t.a.size());
  for (int o = 0; o < out; ++o) {
    const double real = std::max(scale * (o + 0.5) - 0.5, 0.0);
    const int i = std::min(static_cast<int>(real), in - 1);
    const double l1 = std::clamp(real - i, 0.0, 1.0);
    const auto k = static_cast<std::size_t>(o);
    t.a[k] = i;
    t.b[k] = i < in - 1 ? i + 1 : i;
    t.w0[k] = static_cast<float>(1.0 - l1);
    t.w1[k] = static_cast<float>(l1);
  }
}

struct ScaledResizePlan {
  static constexpr int group = 8;    // output pixels a vector step
  static constexpr int window = 128; // bytes one two-register permute reads from
  int out_w = 0, row_bytes = 0;
  // Per group of 8 output pixels: the window's first byte in the row (-1: the group does not
  // fit a window, the portable loop runs it) and 64 permute indices: byte 16 c + k is channel c
  // of tap a (k < 8) or b (k >= 8) of output pixel 8 g + k % 8, as an offset in the window.
  std::vector<int> start;
  std::vector<std::array<std::uint8_t, 64>> index;

  static ScaledResizePlan make(int out_w, int row_bytes, const ResizeTaps& taps) {
    ScaledResizePlan p;
    p.out_w = out_w;
    p.row_bytes = row_bytes;
    const int groups = out_w / group;
    p.start.assign(static_cast<std::size_t>(groups), -1);
    p.index.assign(static_cast<std::size_t>(groups), {});
    for (int g = 0; g < groups; ++g) {
      const int first = 3 * taps.a[static_cast<std::size_t>(g * group)];
      const int last = 3 * taps.b[static_cast<std::size_t>(g * group + group - 1)] + 2;
      // The window ends inside the row: shifted left where the group sits at the row's end.
      const int s = std::min(first, row_bytes - window);
      if (s < 0 || last - s >= window) continue;
      auto& idx = p.index[static_cast<std::size_t>(g)];
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 16; ++k) {
          const auto x = static_cast<std::size_t>(g * group + k % group);
          const int pixel = k < group ? taps.a[x] : taps.b[x];
          idx[static_cast<std::size_t>(16 * c + k)] = static_cast<std::uint8_t>(3 * pixel + c - s);
        }
      p.start[static_cast<std::size_t>(g)] = s;
    }
    return p;
  }
};

// One output row per channel (planar): d[c][x] is channel c of output pixel x.
using PlanarRow = std::array<float*, 3>;

// Output pixels [x0, x1) of a row by table lookups. The three channels written out: at -O2 GCC
// kept a loop over them (the resize took 0.13 ms at -O2 against 0.07 ms at -O3 in a profile).
SHADOWSENSE_STRICT_FP inline void scaled_resize_pixels(const ResizeTaps& t, int x0, int x1,
                                                       const std::uint8_t* r0,
                                                       const std::uint8_t* r1, float h0, float h1,
                                                       const ScaledTable& table,
                                                       const PlanarRow& d) {
  SHADOWSENSE_STRICT_FP_BODY
  const float* t_0 = table[0].data();
  const float* t_1 = table[1].data();
  const float* t_2 = table[2].data();
  for (int x = x0; x < x1; ++x) {
    const auto k = static_cast<std::size_t>(x);
    const int a = 3 * t.a[k], b = 3 * t.b[k];
    const float u0 = t.w0[k], u1 = t.w1[k];
    auto tap = [&](const float* v, int i, int j) {
      const float t0 = v[r0[i]] * u0 + v[r0[j]] * u1;
      const float t1 = v[r1[i]] * u0 + v[r1[j]] * u1;
      return t0 * h0 + t1 * h1;
    };
    d[0][x] = tap(t_0, a, b);
    d[1][x] = tap(t_1, a + 1, b + 1);
    d[2][x] = tap(t_2, a + 2, b + 2);
  }
}

inline void scaled_resize_row_portable(const ScaledResizePlan& plan, const ResizeTaps& t,
                                       const std::uint8_t* r0, const std::uint8_t* r1, float h0,
                                       float h1, const ScaledTable& table,
                                       const std::array<float, 3>&, const PlanarRow& d) {
  scaled_resize_pixels(t, 0, plan.out_w, r0, r1, h0, h1, table, d);
}

#if SHADOWSENSE_SCALED_RESIZE_X86
#define SHADOWSENSE_VBMI __attribute__((target("avx512f,avx512bw,avx512vbmi")))

// (The masked forms with every lane selected and no undefined upper halves: GCC 12 warns
// "may be used uninitialized" inside the plain AVX-512 forms, about their unused merge source.)
constexpr __mmask16 kScaledAll16 = 0xFFFF;

// Lanes 0-7 (half 0) or 8-15 (half 1) of v.
template <int Half>
SHADOWSENSE_VBMI inline __m256 half_of(__m512 v) {
  return _mm256_castpd_ps(_mm512_maskz_extractf64x4_pd(0xF, _mm512_castps_pd(v), Half));
}
// lo in lanes 0-7, hi in lanes 8-15.
SHADOWSENSE_VBMI inline __m512 join_halves(__m256 lo, __m256 hi) {
  const __m512d low = _mm512_maskz_insertf64x4(0xFF, _mm512_setzero_pd(), _mm256_castps_pd(lo), 0);
  return _mm512_castpd_ps(_mm512_maskz_insertf64x4(0xFF, low, _mm256_castps_pd(hi), 1));
}

// scaled_byte of 16 bytes (widened to floats): the quotient v / 255 from v * r and one
// correction step (exact for every byte: the tests compare all 256 with the division), then the
// gain and the clamp as in scaled_byte.
SHADOWSENSE_VBMI SHADOWSENSE_STRICT_FP inline __m512 scaled_bytes_vbmi(__m128i bytes, __m512 gain) {
  SHADOWSENSE_STRICT_FP_BODY
  const __m512 r = _mm512_set1_ps(1.0f / 255.0f), k255 = _mm512_set1_ps(255.0f);
  const __m512 v =
      _mm512_maskz_cvtepi32_ps(kScaledAll16, _mm512_maskz_cvtepu8_epi32(kScaledAll16, bytes));
  const __m512 q0 = _mm512_mul_ps(v, r);
  const __m512 rem = _mm512_fnmadd_ps(q0, k255, v); // v - 255 q0, exact
  const __m512 q = _mm512_fmadd_ps(rem, r, q0);
  return _mm512_maskz_min_ps(
      kScaledAll16, _mm512_maskz_max_ps(kScaledAll16, _mm512_mul_ps(q, gain), _mm512_setzero_ps()),
      _mm512_set1_ps(1.0f));
}

SHADOWSENSE_VBMI SHADOWSENSE_STRICT_FP inline void
scaled_resize_row_vbmi(const ScaledResizePlan& plan, const ResizeTaps& t, const std::uint8_t* r0,
                       const std::uint8_t* r1, float h0, float h1, const ScaledTable& table,
                       const std::array<float, 3>& gains, const PlanarRow& d) {
  SHADOWSENSE_STRICT_FP_BODY
  const __m512 g[3] = {_mm512_set1_ps(gains[0]), _mm512_set1_ps(gains[1]),
                       _mm512_set1_ps(gains[2])};
  const __m256 vh0 = _mm256_set1_ps(h0), vh1 = _mm256_set1_ps(h1);
  const int groups = static_cast<int>(plan.start.size());
  for (int gi = 0; gi < groups; ++gi) {
    const int x = gi * ScaledResizePlan::group, s = plan.start[static_cast<std::size_t>(gi)];
    if (s < 0) {
      scaled_resize_pixels(t, x, x + ScaledResizePlan::group, r0, r1, h0, h1, table, d);
      continue;
    }
    const __m512i idx = _mm512_loadu_si512(plan.index[static_cast<std::size_t>(gi)].data());
    const __m512i p0 =
        _mm512_permutex2var_epi8(_mm512_loadu_si512(r0 + s), idx, _mm512_loadu_si512(r0 + s + 64));
    const __m512i p1 =
        _mm512_permutex2var_epi8(_mm512_loadu_si512(r1 + s), idx, _mm512_loadu_si512(r1 + s + 64));
    // Weights of tap a in lanes 0-7, of tap b in lanes 8-15.
    const __m512 w =
        join_halves(_mm256_loadu_ps(t.w0.data() + x), _mm256_loadu_ps(t.w1.data() + x));
    // One channel: its 16 tap bytes of each row (lanes 0-7 tap a, 8-15 tap b) to 8 outputs,
    // tap a's product plus tap b's.
    auto channel = [&](__m128i b0, __m128i b1, __m512 gain) {
      const __m512 f0 = _mm512_mul_ps(scaled_bytes_vbmi(b0, gain), w);
      const __m512 f1 = _mm512_mul_ps(scaled_bytes_vbmi(b1, gain), w);
      const __m256 t0 = _mm256_add_ps(half_of<0>(f0), half_of<1>(f0));
      const __m256 t1 = _mm256_add_ps(half_of<0>(f1), half_of<1>(f1));
      return _mm256_add_ps(_mm256_mul_ps(t0, vh0), _mm256_mul_ps(t1, vh1));
    };
    _mm256_storeu_ps(d[0] + x, channel(_mm512_maskz_extracti32x4_epi32(0xF, p0, 0),
                                       _mm512_maskz_extracti32x4_epi32(0xF, p1, 0), g[0]));
    _mm256_storeu_ps(d[1] + x, channel(_mm512_maskz_extracti32x4_epi32(0xF, p0, 1),
                                       _mm512_maskz_extracti32x4_epi32(0xF, p1, 1), g[1]));
    _mm256_storeu_ps(d[2] + x, channel(_mm512_maskz_extracti32x4_epi32(0xF, p0, 2),
                                       _mm512_maskz_extracti32x4_epi32(0xF, p1, 2), g[2]));
  }
  scaled_resize_pixels(t, groups * ScaledResizePlan::group, plan.out_w, r0, r1, h0, h1, table, d);
}
#undef SHADOWSENSE_VBMI
#endif

inline bool scaled_resize_cpu_has_vbmi() {
#if SHADOWSENSE_SCALED_RESIZE_X86
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512vbmi");
  return has;
#else
  return false;
#endif
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
