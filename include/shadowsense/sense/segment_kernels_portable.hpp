// The segmenter's per-row kernels in plain C++ (any CPU; the compiler vectorises what it can):
// the relative rule's per-pixel decision and the rows of the 3- and 5-tap mask smoothing. The
// x86 (segment_kernels_x86.hpp) and aarch64 (segment_kernels_neon.hpp) kernels have the same
// contracts and give the same bytes and floats; segment_kernels.hpp picks one at run time. No
// OpenCV: raw pointers only (so the aarch64 build under emulation can test them alone).
//
// relative_row_portable(p, bgr, ipb, ipg, ipr, skin, w, darkness, warmth, shadow, contact)
//   requires: bgr holds 3 w bytes (B, G, R per pixel); ipb, ipg, ipr w IEEE binary16 values (the
//             inverse empty-skin model, as bits: half the bytes of floats, and the segmenter reads
//             them every frame); darkness, warmth w floats; skin, shadow, contact w bytes; outputs
//             do not overlap the inputs.
//   ensures:  for every pixel x, with ib = half_to_float(ipb[x]) (exact), likewise ig and ir, in
//             this order of float operations (no fused multiply-add):
//               qb = (B * ib) * p.gb, qg = (G * ig) * p.gg, qr = (R * ir) * p.gr
//               darkness[x] = s - ((qb + qg) + qr) * (1 / 3), s = 1 when skin[x] != 0 else 0
//               warmth[x] = qr - qb
//               contact[x] = skin[x] when darkness >= p.contact and warmth >= p.warmth, else 0
//               shadow[x] = (skin[x] when darkness >= p.shadow, else 0) | contact[x]
//             (RelativeRule's definition, pixel_rule.hpp).
// half_to_float(h): the float of the IEEE binary16 value with bits h, exactly (every binary16
//   value, subnormals, infinities and NaNs included, is a float).
// hsum_row<K>(pad, w, out), K = 3 or 5
//   requires: pad holds w + K - 1 bytes (a row with K / 2 replicated pixels at each end).
//   ensures:  out[x] = sum over t of wt[t] pad[x + t], wt = (1 2 1) or (1 4 6 4 1) (exact in 16
//             bits: at most 16 x 255).
// vsum_row<K>(rows, w, mask, marks)
//   requires: rows holds K pointers to w values of hsum_row<K>; mask w bytes; marks w bytes or
//             null.
//   ensures:  V = sum over t of wt[t] rows[t][x] (exact in 16 bits); mask[x] = 255 when V >= on
//             (2040 for K = 3, 32640 for K = 5), else 0; marks[x] (when given) = 1 or 0 alike.
//             Returns whether any mask[x] is 255.
//             This is OpenCV's 8-bit Gaussian of size K followed by a threshold at 127
//             (mask_smoothing.hpp says why).
// reference_bins(frame, step, ys, xs, ib, ig, ir, n, bb, bg, br)
//   requires: for i < n, (ys[i], xs[i]) a pixel of the 8-bit BGR frame (rows step bytes apart)
//             with xs[i] >= 1; ib, ig, ir n floats >= 0 and < 64; bb, bg, br n values each.
//   ensures:  bb[i] = min(int(B * ib[i] * 4), 1023) for that pixel's B (float products,
//             truncated toward zero), likewise bg (G) and br (R): the quarter-unit histogram bin
//             of the pixel over the empty-skin model (the segmenter's per-frame reference).
// No state; callable from any thread.
#pragma once

#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/version.hpp>

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

// IEEE binary16 to float by the bits: 5 exponent bits (bias 15) and 10 fraction bits become 8
// (bias 127) and 23; a subnormal half (exponent 0) is normalised first. Normal values first:
// they are the model's (its inverse lies in 0.05 to 20, or is 0 off the skin).
constexpr float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
  const std::uint32_t exponent = (h >> 10) & 0x1Fu;
  std::uint32_t fraction = h & 0x3FFu;
  if (exponent - 1u < 30u) // normal: 1 to 30
    return std::bit_cast<float>(sign | ((exponent + 112u) << 23) | (fraction << 13));
  if (exponent == 0x1Fu) // infinity or NaN (the payload kept)
    return std::bit_cast<float>(sign | 0x7F800000u | (fraction << 13));
  if (fraction == 0) return std::bit_cast<float>(sign); // +-0
  std::uint32_t e = 113; // subnormal: fraction x 2^-24; shift its top bit to the implicit one
  while ((fraction & 0x400u) == 0) {
    fraction <<= 1;
    --e;
  }
  return std::bit_cast<float>(sign | (e << 23) | ((fraction & 0x3FFu) << 13));
}

// One frame's constants of the relative rule.
struct RelativeRowParams {
  float gb = 1, gg = 1, gr = 1;              // 1 / the frame's reference, per channel
  float shadow = 0, contact = 0, warmth = 0; // thresholds at the frame's light
};

using RelativeRowFn = void (*)(const RelativeRowParams& p, const std::uint8_t* bgr,
                               const std::uint16_t* ipb, const std::uint16_t* ipg,
                               const std::uint16_t* ipr, const std::uint8_t* skin, int w,
                               float* darkness, float* warmth, std::uint8_t* shadow,
                               std::uint8_t* contact);

// Pixels [x0, w) of relative_row with channel k's inverse model at pixel x read as
// inverse(k, x), a float (the rule's definition, one pixel at a time).
template <class Inverse>
SHADOWSENSE_STRICT_FP SHADOWSENSE_ALWAYS_INLINE void
relative_pixels(const RelativeRowParams& p, const std::uint8_t* bgr, const Inverse& inverse,
                const std::uint8_t* skin, int x0, int w, float* dk, float* wm, std::uint8_t* sm,
                std::uint8_t* cm) {
  SHADOWSENSE_STRICT_FP_BODY
  for (int x = x0; x < w; ++x) {
    const float qb = static_cast<float>(bgr[3 * x]) * inverse(0, x) * p.gb;
    const float qg = static_cast<float>(bgr[3 * x + 1]) * inverse(1, x) * p.gg;
    const float qr = static_cast<float>(bgr[3 * x + 2]) * inverse(2, x) * p.gr;
    const float s = skin[x] != 0 ? 1.f : 0.f;
    const float d = s - (qb + qg + qr) * (1.f / 3.f);
    const float wt = qr - qb;
    dk[x] = d;
    wm[x] = wt;
    const std::uint8_t c = (d >= p.contact && wt >= p.warmth) ? skin[x] : std::uint8_t{0};
    cm[x] = c;
    sm[x] = static_cast<std::uint8_t>((d >= p.shadow ? skin[x] : std::uint8_t{0}) | c);
  }
}

// Pixels [x0, w) of relative_row, each binary16 converted alone. Strict here too: the rule's
// arithmetic, inlined from relative_pixels, takes the flags of the function it lands in.
SHADOWSENSE_STRICT_FP inline void
relative_row_tail(const RelativeRowParams& p, const std::uint8_t* bgr, const std::uint16_t* ipb,
                  const std::uint16_t* ipg, const std::uint16_t* ipr, const std::uint8_t* skin,
                  int x0, int w, float* dk, float* wm, std::uint8_t* sm, std::uint8_t* cm) {
  SHADOWSENSE_STRICT_FP_BODY
  const std::array<const std::uint16_t*, 3> ip{ipb, ipg, ipr};
  relative_pixels(
      p, bgr, [&ip](int k, int x) { return half_to_float(ip[static_cast<std::size_t>(k)][x]); },
      skin, x0, w, dk, wm, sm, cm);
}

inline void relative_row_portable(const RelativeRowParams& p, const std::uint8_t* bgr,
                                  const std::uint16_t* ipb, const std::uint16_t* ipg,
                                  const std::uint16_t* ipr, const std::uint8_t* skin, int w,
                                  float* dk, float* wm, std::uint8_t* sm, std::uint8_t* cm) {
  relative_row_tail(p, bgr, ipb, ipg, ipr, skin, 0, w, dk, wm, sm, cm);
}

// The smoothing weights with the common factor taken out (mask_smoothing.hpp).
template <int K>
inline constexpr std::array<std::uint16_t, 5> smoothing_weights =
    K == 3 ? std::array<std::uint16_t, 5>{1, 2, 1, 0, 0}
           : std::array<std::uint16_t, 5>{1, 4, 6, 4, 1};
template <int K>
inline constexpr std::uint16_t smoothing_on = K == 3 ? 2040 : 32640;

// The loop bodies, inlined into the portable and the AVX2 functions (compiled for each).
template <int K>
SHADOWSENSE_ALWAYS_INLINE void hsum_row_body(const std::uint8_t* __restrict pad, int w,
                                             std::uint16_t* __restrict out) {
  static_assert(K == 3 || K == 5);
  constexpr std::array<std::uint16_t, 5> wt = smoothing_weights<K>;
  for (int x = 0; x < w; ++x) {
    std::uint16_t sum = 0;
    for (std::size_t t = 0; t < K; ++t)
      sum = static_cast<std::uint16_t>(sum + wt[t] * pad[static_cast<std::size_t>(x) + t]);
    out[x] = sum;
  }
}

template <int K>
SHADOWSENSE_ALWAYS_INLINE bool vsum_row_body(const std::uint16_t* const* rows, int w,
                                             std::uint8_t* __restrict mask,
                                             std::uint8_t* __restrict marks) {
  static_assert(K == 3 || K == 5);
  constexpr std::array<std::uint16_t, 5> wt = smoothing_weights<K>;
  std::array<const std::uint16_t* __restrict, K> in{};
  for (std::size_t t = 0; t < K; ++t) in[t] = rows[t];
  std::uint8_t any = 0;
  if (marks) {
    for (int x = 0; x < w; ++x) {
      std::uint16_t v = 0;
      for (std::size_t t = 0; t < K; ++t) v = static_cast<std::uint16_t>(v + wt[t] * in[t][x]);
      const std::uint8_t on = v >= smoothing_on<K> ? 1 : 0;
      mask[x] = static_cast<std::uint8_t>(-on);
      marks[x] = on;
      any |= on;
    }
  } else {
    for (int x = 0; x < w; ++x) {
      std::uint16_t v = 0;
      for (std::size_t t = 0; t < K; ++t) v = static_cast<std::uint16_t>(v + wt[t] * in[t][x]);
      const std::uint8_t on = v >= smoothing_on<K> ? 1 : 0;
      mask[x] = static_cast<std::uint8_t>(-on);
      any |= on;
    }
  }
  return any != 0;
}

using HsumRowFn = void (*)(const std::uint8_t* pad, int w, std::uint16_t* out);
using VsumRowFn = bool (*)(const std::uint16_t* const* rows, int w, std::uint8_t* mask,
                           std::uint8_t* marks);

template <int K>
inline void hsum_row_portable(const std::uint8_t* pad, int w, std::uint16_t* out) {
  hsum_row_body<K>(pad, w, out);
}
template <int K>
inline bool vsum_row_portable(const std::uint16_t* const* rows, int w, std::uint8_t* mask,
                              std::uint8_t* marks) {
  return vsum_row_body<K>(rows, w, mask, marks);
}

using ReferenceBinsFn = void (*)(const std::uint8_t* frame, std::size_t step,
                                 const std::int32_t* ys, const std::int32_t* xs, const float* ib,
                                 const float* ig, const float* ir, int n, std::uint16_t* bb,
                                 std::uint16_t* bg, std::uint16_t* br);

SHADOWSENSE_STRICT_FP inline int reference_bin(std::uint8_t v, float inv) {
  SHADOWSENSE_STRICT_FP_BODY
  const int b = static_cast<int>(static_cast<float>(v) * inv * 4.f);
  return b < 0 ? 0 : b > 1023 ? 1023 : b;
}

// Samples [i0, n) of reference_bins (the vector kernel finishes with it).
inline void reference_bins_tail(const std::uint8_t* frame, std::size_t step, const std::int32_t* ys,
                                const std::int32_t* xs, const float* ib, const float* ig,
                                const float* ir, int i0, int n, std::uint16_t* bb,
                                std::uint16_t* bg, std::uint16_t* br) {
  for (int i = i0; i < n; ++i) {
    const std::uint8_t* px =
        frame + static_cast<std::size_t>(ys[i]) * step + 3 * static_cast<std::size_t>(xs[i]);
    bb[i] = static_cast<std::uint16_t>(reference_bin(px[0], ib[i]));
    bg[i] = static_cast<std::uint16_t>(reference_bin(px[1], ig[i]));
    br[i] = static_cast<std::uint16_t>(reference_bin(px[2], ir[i]));
  }
}

inline void reference_bins_portable(const std::uint8_t* frame, std::size_t step,
                                    const std::int32_t* ys, const std::int32_t* xs, const float* ib,
                                    const float* ig, const float* ir, int n, std::uint16_t* bb,
                                    std::uint16_t* bg, std::uint16_t* br) {
  reference_bins_tail(frame, step, ys, xs, ib, ig, ir, 0, n, bb, bg, br);
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
