// The end of a run of equal bytes, 16 bytes a step where the target's baseline has 128-bit
// vectors (SSE2 on x86-64, NEON on AArch64: no dispatch), 8 a step (one 64-bit word) elsewhere.
// The contour scan (border_following.hpp) walks each mask row run by run with it.
//
// detail::run_end(row, x, end, value) -> the first i in [x, end) with row[i] != value, or end.
//   requires: row[x .. end - 1] readable (nothing outside it is read); x <= end.
// Threading: a pure function.
#pragma once

#include <shadowsense/core/version.hpp>

#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#elif defined(__ARM_NEON)
#include <arm_neon.h>
#endif

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

inline int run_end(const std::int8_t* row, int x, int end, std::int8_t value) {
#if defined(__SSE2__)
  const __m128i pattern = _mm_set1_epi8(static_cast<char>(value));
  while (x + 16 <= end) {
    const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + x));
    const int differ = _mm_movemask_epi8(_mm_cmpeq_epi8(v, pattern)) ^ 0xFFFF;
    if (differ) return x + __builtin_ctz(static_cast<unsigned>(differ));
    x += 16;
  }
#elif defined(__ARM_NEON)
  const int8x16_t pattern = vdupq_n_s8(value);
  while (x + 16 <= end) {
    const uint8x16_t same = vceqq_s8(vld1q_s8(row + x), pattern);
    // Four bits per byte (a narrowing shift): all ones where the 16 bytes equal value.
    const std::uint64_t bits =
        vget_lane_u64(vreinterpret_u64_u8(vshrn_n_u16(vreinterpretq_u16_u8(same), 4)), 0);
    if (bits != ~std::uint64_t{0}) return x + __builtin_ctzll(~bits) / 4;
    x += 16;
  }
#endif
  const std::uint64_t pattern8 = 0x0101010101010101ull * static_cast<std::uint8_t>(value);
  while (x + 8 <= end) {
    std::uint64_t v;
    std::memcpy(&v, row + x, 8);
    if (v != pattern8) break;
    x += 8;
  }
  while (x < end && row[x] == value) ++x;
  return x;
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
