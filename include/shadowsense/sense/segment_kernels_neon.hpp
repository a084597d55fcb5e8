// The segmenter's per-row kernels for aarch64 Advanced SIMD (NEON; segment_kernels_portable.hpp
// has the contracts; the results are the same bytes and floats). NEON is mandatory on aarch64,
// so these are chosen at compile time: SHADOWSENSE_SEGMENT_NEON is 1 on aarch64 with GCC/Clang
// and the functions exist only there.
//
// relative_row_neon: 16 pixels a step (vld3q_u8 splits B, G, R; four 4-float quarters), the rest
//   with the portable loop. Multiplies and adds are separate instructions (no vfmaq), so the
//   rounding is the portable kernel's.
// The mask smoothing rows use the portable loops (the compiler vectorises them for NEON).
// No state; callable from any thread.
#pragma once

#include <shadowsense/sense/segment_kernels_portable.hpp>

#include <cstdint>

#if defined(__aarch64__) && defined(__ARM_NEON) && (defined(__GNUC__) || defined(__clang__))
#define SHADOWSENSE_SEGMENT_NEON 1
#include <arm_neon.h>
#else
#define SHADOWSENSE_SEGMENT_NEON 0
#endif

#if SHADOWSENSE_SEGMENT_NEON
SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

SHADOWSENSE_STRICT_FP inline void
relative_row_neon(const RelativeRowParams& p, const std::uint8_t* bgr, const std::uint16_t* ipb,
                  const std::uint16_t* ipg, const std::uint16_t* ipr, const std::uint8_t* skin,
                  int w, float* dk, float* wm, std::uint8_t* sm, std::uint8_t* cm) {
  SHADOWSENSE_STRICT_FP_BODY
  // Four binary16 values (bits) as floats, exactly (aarch64 converts half precision natively).
  const auto halves = [](const std::uint16_t* h) {
    return vcvt_f32_f16(vreinterpret_f16_u16(vld1_u16(h)));
  };
  const float32x4_t gb = vdupq_n_f32(p.gb), gg = vdupq_n_f32(p.gg), gr = vdupq_n_f32(p.gr);
  const float32x4_t third = vdupq_n_f32(1.f / 3.f), one = vdupq_n_f32(1.f);
  const float32x4_t ts = vdupq_n_f32(p.shadow), tc = vdupq_n_f32(p.contact),
                    tw = vdupq_n_f32(p.warmth);
  int x = 0;
  for (; x + 16 <= w; x += 16) {
    const uint8x16x3_t px = vld3q_u8(bgr + 3 * x);
    const uint8x16_t s8 = vld1q_u8(skin + x);
    // 16 bytes to four 4-lane u32 quarters.
    auto quarters = [](uint8x16_t v, uint32x4_t* q) {
      const uint16x8_t lo = vmovl_u8(vget_low_u8(v)), hi = vmovl_u8(vget_high_u8(v));
      q[0] = vmovl_u16(vget_low_u16(lo));
      q[1] = vmovl_u16(vget_high_u16(lo));
      q[2] = vmovl_u16(vget_low_u16(hi));
      q[3] = vmovl_u16(vget_high_u16(hi));
    };
    uint32x4_t b[4], g[4], r[4], s[4], cq[4], sq[4];
    quarters(px.val[0], b);
    quarters(px.val[1], g);
    quarters(px.val[2], r);
    quarters(s8, s);
    for (int j = 0; j < 4; ++j) {
      const int o = x + 4 * j;
      const float32x4_t qb = vmulq_f32(vmulq_f32(vcvtq_f32_u32(b[j]), halves(ipb + o)), gb);
      const float32x4_t qg = vmulq_f32(vmulq_f32(vcvtq_f32_u32(g[j]), halves(ipg + o)), gg);
      const float32x4_t qr = vmulq_f32(vmulq_f32(vcvtq_f32_u32(r[j]), halves(ipr + o)), gr);
      const float32x4_t on_skin =
          vreinterpretq_f32_u32(vandq_u32(vtstq_u32(s[j], s[j]), vreinterpretq_u32_f32(one)));
      const float32x4_t d = vsubq_f32(on_skin, vmulq_f32(vaddq_f32(vaddq_f32(qb, qg), qr), third));
      const float32x4_t wt = vsubq_f32(qr, qb);
      vst1q_f32(dk + o, d);
      vst1q_f32(wm + o, wt);
      cq[j] = vandq_u32(vcgeq_f32(d, tc), vcgeq_f32(wt, tw));
      sq[j] = vcgeq_f32(d, ts);
    }
    auto to_bytes = [](const uint32x4_t* q) {
      const uint16x8_t lo = vcombine_u16(vmovn_u32(q[0]), vmovn_u32(q[1]));
      const uint16x8_t hi = vcombine_u16(vmovn_u32(q[2]), vmovn_u32(q[3]));
      return vcombine_u8(vmovn_u16(lo), vmovn_u16(hi));
    };
    const uint8x16_t c = vandq_u8(to_bytes(cq), s8);
    vst1q_u8(cm + x, c);
    vst1q_u8(sm + x, vorrq_u8(vandq_u8(to_bytes(sq), s8), c));
  }
  if (x < w) { // the last 1-15 pixels: their halves converted four at a time, then alone
    std::uint16_t h[3][16] = {};
    float inv[3][16];
    const std::uint16_t* ip[3] = {ipb, ipg, ipr};
    for (int c = 0; c < 3; ++c) {
      for (int i = 0; x + i < w; ++i) h[c][i] = ip[c][x + i];
      for (int q = 0; q < 16; q += 4) vst1q_f32(inv[c] + q, halves(h[c] + q));
    }
    relative_pixels(
        p, bgr, [&inv, x](int c, int px) { return inv[c][px - x]; }, skin, x, w, dk, wm, sm, cm);
  }
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
#endif
