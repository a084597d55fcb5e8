// Per-channel sums of a row of interleaved 3-channel 8-bit pixels (B, G, R or R, G, B), exact:
// the lighting normalisation's channel means (LightingNormaliser::channel_sums) read every byte
// of the frame through this, once per frame. Three kernels with one contract:
//   add_channel_sums_portable  plain C++: 16-bit lanes the compiler vectorises to its baseline
//                              (SSE2 on x86-64 without -march; at GCC 12's -O2, what Debian and
//                              CMake's RelWithDebInfo build with, only partly)
//   add_channel_sums_avx2      x86-64 with AVX2, chosen at run time (a function-level target
//                              attribute: no -march flag): per 32 pixels three loads, each
//                              byte masked to its channel and summed by vpsadbw into 64 bits
//   add_channel_sums_avx512    x86-64 with AVX-512 F and BW, chosen at run time before AVX2: per
//                              64 pixels three loads, each one's even and odd bytes added into
//                              16-bit lanes (flushed to 64 bits every 256 steps)
//   add_channel_sums_neon      aarch64, compiled in there: vld3q_u8 splits 16 pixels into their
//                              channels, pairwise widening adds into 32-bit lanes
//
// add_channel_sums_*(row, pixels, sums)
//   requires: row points to 3 * pixels readable bytes; 0 <= pixels <= 2^24 (each 32-bit lane of
//             the NEON kernel then holds at most 2^22 * 255 < 2^32).
//   ensures:  sums[c] += the sum of bytes row[3 i + c] over i < pixels, for c = 0, 1, 2; the same
//             sums from every kernel (integers: no rounding).
// ChannelSumsKind: automatic picks avx512, else avx2 on an x86 CPU that has them, neon on
//   aarch64, else portable. channel_sums_cpu_has(kind): compiled in and runnable here (automatic:
//   false).
// add_channel_sums(row, pixels, sums, kind = automatic)
//   requires: as above, and kind automatic or channel_sums_cpu_has(kind) (else InvalidArgument).
// No state but the cached automatic choice (a function-local static): any thread.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <array>
#include <cstddef>
#include <cstdint>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define SHADOWSENSE_CHANNEL_SUMS_X86 1
#include <immintrin.h>
#else
#define SHADOWSENSE_CHANNEL_SUMS_X86 0
#endif
#if defined(__aarch64__)
#define SHADOWSENSE_CHANNEL_SUMS_NEON 1
#include <arm_neon.h>
#else
#define SHADOWSENSE_CHANNEL_SUMS_NEON 0
#endif

SHADOWSENSE_NAMESPACE_BEGIN

using ChannelSums = std::array<std::uint64_t, 3>;

namespace detail {

// 48 lanes of 16 bits (16 pixels, three whole 16-byte vectors a step), flushed to 64 bits every
// 256 steps, before a lane can overflow (256 x 255 < 2^16).
inline void add_channel_sums_portable(const unsigned char* row, int pixels, ChannelSums& sums) {
  constexpr int lanes = 48, steps = 256;
  const int n = pixels * 3;
  int i = 0;
  while (n - i >= lanes) {
    std::uint16_t lane[lanes] = {};
    for (int step = 0; step < steps && n - i >= lanes; ++step, i += lanes)
      for (int k = 0; k < lanes; ++k) lane[k] = static_cast<std::uint16_t>(lane[k] + row[i + k]);
    for (int k = 0; k < lanes; ++k) sums[static_cast<std::size_t>(k % 3)] += lane[k];
  }
  for (; i < n; ++i) sums[static_cast<std::size_t>(i % 3)] += row[i];
}

#if SHADOWSENSE_CHANNEL_SUMS_X86
// Byte masks of channel c in the j-th 32-byte load of a 96-byte step: byte i of load j is byte
// 32 j + i of the step, of channel (32 j + i) % 3.
inline const std::array<std::array<std::array<std::uint8_t, 32>, 3>, 3>& channel_byte_masks() {
  static const auto masks = [] {
    std::array<std::array<std::array<std::uint8_t, 32>, 3>, 3> m{};
    for (std::size_t j = 0; j < 3; ++j)
      for (std::size_t c = 0; c < 3; ++c)
        for (std::size_t i = 0; i < 32; ++i) m[j][c][i] = (32 * j + i) % 3 == c ? 0xff : 0x00;
    return m;
  }();
  return masks;
}

// One 32-byte load's bytes of channels 0, 1, 2 (masks m0, m1, m2) summed into acc0..acc2.
__attribute__((target("avx2"))) inline void sum_load_avx2(__m256i v, __m256i m0, __m256i m1,
                                                          __m256i m2, __m256i& acc0, __m256i& acc1,
                                                          __m256i& acc2) {
  const __m256i zero = _mm256_setzero_si256();
  acc0 = _mm256_add_epi64(acc0, _mm256_sad_epu8(_mm256_and_si256(v, m0), zero));
  acc1 = _mm256_add_epi64(acc1, _mm256_sad_epu8(_mm256_and_si256(v, m1), zero));
  acc2 = _mm256_add_epi64(acc2, _mm256_sad_epu8(_mm256_and_si256(v, m2), zero));
}

__attribute__((target("avx2"))) inline std::uint64_t sum_lanes_avx2(__m256i v) {
  const __m128i s = _mm_add_epi64(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  return static_cast<std::uint64_t>(_mm_cvtsi128_si64(s)) +
         static_cast<std::uint64_t>(_mm_extract_epi64(s, 1));
}

// Channel c's byte mask of load j (a function, not a lambda: a lambda does not take its
// caller's target attribute).
__attribute__((target("avx2"))) inline __m256i channel_mask_avx2(int j, int c) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(
      channel_byte_masks()[static_cast<std::size_t>(j)][static_cast<std::size_t>(c)].data()));
}

// Written out with named registers: at GCC's -O2 loops over arrays of vectors stay loops over
// memory.
__attribute__((target("avx2"))) inline void add_channel_sums_avx2(const unsigned char* row,
                                                                  int pixels, ChannelSums& sums) {
  const __m256i m00 = channel_mask_avx2(0, 0), m01 = channel_mask_avx2(0, 1),
                m02 = channel_mask_avx2(0, 2);
  const __m256i m10 = channel_mask_avx2(1, 0), m11 = channel_mask_avx2(1, 1),
                m12 = channel_mask_avx2(1, 2);
  const __m256i m20 = channel_mask_avx2(2, 0), m21 = channel_mask_avx2(2, 1),
                m22 = channel_mask_avx2(2, 2);
  __m256i acc0 = _mm256_setzero_si256(), acc1 = acc0, acc2 = acc0; // 4 x 64 bits a channel
  int p = 0;
  for (; pixels - p >= 32; p += 32) {
    const auto* s = reinterpret_cast<const __m256i*>(row + 3 * static_cast<std::size_t>(p));
    sum_load_avx2(_mm256_loadu_si256(s), m00, m01, m02, acc0, acc1, acc2);
    sum_load_avx2(_mm256_loadu_si256(s + 1), m10, m11, m12, acc0, acc1, acc2);
    sum_load_avx2(_mm256_loadu_si256(s + 2), m20, m21, m22, acc0, acc1, acc2);
  }
  sums[0] += sum_lanes_avx2(acc0);
  sums[1] += sum_lanes_avx2(acc1);
  sums[2] += sum_lanes_avx2(acc2);
  add_channel_sums_portable(row + 3 * static_cast<std::size_t>(p), pixels - p, sums);
}

// 192 bytes (64 pixels, three whole 64-byte vectors) a step. Each load's even and odd bytes are
// added into 16-bit lanes of two accumulators per load (an and, a shift and two adds: a third
// of the AVX2 kernel's work per byte); every 256 steps, before a lane can overflow (256 x 255 <
// 2^16), the lanes are added to their channels: lane k of load j's even accumulator holds byte
// 64 j + 2 k of each step, of channel (64 j + 2 k) % 3.
__attribute__((target("avx512f,avx512bw"))) inline void
add_channel_sums_avx512(const unsigned char* row, int pixels, ChannelSums& sums) {
  constexpr int steps = 256;
  const __m512i low = _mm512_set1_epi16(0x00ff);
  int p = 0;
  while (pixels - p >= 64) {
    __m512i e0 = _mm512_setzero_si512(), o0 = e0, e1 = e0, o1 = e0, e2 = e0, o2 = e0;
    for (int step = 0; step < steps && pixels - p >= 64; ++step, p += 64) {
      const unsigned char* s = row + 3 * static_cast<std::size_t>(p);
      const __m512i v0 = _mm512_loadu_si512(s), v1 = _mm512_loadu_si512(s + 64),
                    v2 = _mm512_loadu_si512(s + 128);
      e0 = _mm512_add_epi16(e0, _mm512_and_si512(v0, low));
      o0 = _mm512_add_epi16(o0, _mm512_srli_epi16(v0, 8));
      e1 = _mm512_add_epi16(e1, _mm512_and_si512(v1, low));
      o1 = _mm512_add_epi16(o1, _mm512_srli_epi16(v1, 8));
      e2 = _mm512_add_epi16(e2, _mm512_and_si512(v2, low));
      o2 = _mm512_add_epi16(o2, _mm512_srli_epi16(v2, 8));
    }
    alignas(64) std::uint16_t lanes[6][32];
    _mm512_store_si512(lanes[0], e0);
    _mm512_store_si512(lanes[1], o0);
    _mm512_store_si512(lanes[2], e1);
    _mm512_store_si512(lanes[3], o1);
    _mm512_store_si512(lanes[4], e2);
    _mm512_store_si512(lanes[5], o2);
    for (std::size_t a = 0; a < 6; ++a) // a = 2 j + (odd)
      for (std::size_t k = 0; k < 32; ++k) sums[(64 * (a / 2) + 2 * k + a % 2) % 3] += lanes[a][k];
  }
  add_channel_sums_portable(row + 3 * static_cast<std::size_t>(p), pixels - p, sums);
}
#endif

#if SHADOWSENSE_CHANNEL_SUMS_NEON
inline void add_channel_sums_neon(const unsigned char* row, int pixels, ChannelSums& sums) {
  uint32x4_t acc[3] = {vdupq_n_u32(0), vdupq_n_u32(0), vdupq_n_u32(0)};
  int p = 0;
  for (; pixels - p >= 16; p += 16) {
    const uint8x16x3_t v = vld3q_u8(row + 3 * p);
    acc[0] = vpadalq_u16(acc[0], vpaddlq_u8(v.val[0]));
    acc[1] = vpadalq_u16(acc[1], vpaddlq_u8(v.val[1]));
    acc[2] = vpadalq_u16(acc[2], vpaddlq_u8(v.val[2]));
  }
  for (int c = 0; c < 3; ++c) sums[static_cast<std::size_t>(c)] += vaddlvq_u32(acc[c]);
  add_channel_sums_portable(row + 3 * p, pixels - p, sums);
}
#endif

} // namespace detail

enum class ChannelSumsKind { automatic, avx2, neon, portable, avx512 };

inline bool channel_sums_cpu_has(ChannelSumsKind kind) {
  switch (kind) {
  case ChannelSumsKind::portable:
    return true;
#if SHADOWSENSE_CHANNEL_SUMS_X86
  case ChannelSumsKind::avx2:
    return __builtin_cpu_supports("avx2");
  case ChannelSumsKind::avx512:
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw");
#endif
#if SHADOWSENSE_CHANNEL_SUMS_NEON
  case ChannelSumsKind::neon:
    return true;
#endif
  default:
    return false;
  }
}

inline void add_channel_sums(const unsigned char* row, int pixels, ChannelSums& sums,
                             ChannelSumsKind kind = ChannelSumsKind::automatic) {
  if (kind == ChannelSumsKind::automatic) {
    static const ChannelSumsKind best =
        channel_sums_cpu_has(ChannelSumsKind::avx512) ? ChannelSumsKind::avx512
        : channel_sums_cpu_has(ChannelSumsKind::avx2) ? ChannelSumsKind::avx2
        : channel_sums_cpu_has(ChannelSumsKind::neon) ? ChannelSumsKind::neon
                                                      : ChannelSumsKind::portable;
    kind = best;
  }
  switch (kind) {
  case ChannelSumsKind::portable:
    detail::add_channel_sums_portable(row, pixels, sums);
    return;
#if SHADOWSENSE_CHANNEL_SUMS_X86
  case ChannelSumsKind::avx2:
    if (!channel_sums_cpu_has(kind)) break;
    detail::add_channel_sums_avx2(row, pixels, sums);
    return;
  case ChannelSumsKind::avx512:
    if (!channel_sums_cpu_has(kind)) break;
    detail::add_channel_sums_avx512(row, pixels, sums);
    return;
#endif
#if SHADOWSENSE_CHANNEL_SUMS_NEON
  case ChannelSumsKind::neon:
    detail::add_channel_sums_neon(row, pixels, sums);
    return;
#endif
  default:
    break;
  }
  SHADOWSENSE_THROW(InvalidArgument("add_channel_sums: the kernel asked for is not compiled in "
                                    "or this CPU cannot run it"));
}

SHADOWSENSE_NAMESPACE_END
