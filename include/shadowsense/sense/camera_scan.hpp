// The camera check's scan of a frame (sense/camera_health.hpp): the counts and the signature of
// its grid of samples, by a portable loop and by an AVX-512 (F + BW) kernel that give the same
// result bit for bit.
//
// CameraScanGrid: the frame's rows (data, row_stride bytes apart, cols pixels of `channels`
// bytes, rows rows), the grid (pixel x = 0, step, 2 step, ... of rows y = 0, step, ...) and the
// bytes looked at: the first `colour` (1 or 3) of each sample; the levels of the two counts.
//   requires: data != nullptr, cols, rows >= 1, channels in {1, 3, 4}, colour = 1 for one channel
//             and 3 otherwise, step in [1, 64] (CameraHealthConfig's range), every row
//             cols * channels bytes readable.
// CameraScan: samples (the grid's size), dark (samples whose looked-at bytes are all <=
//   dark_level), saturated (all >= saturated_level), and hash, the signature of the looked-at
//   bytes:
//     each sampled row is read as 32-bit little-endian words from its first byte (bytes past
//     its end as 0), every byte that is not looked at taken as 0; every word that holds a
//     looked-at byte, rows and words in order, goes through lane (word's index in its row mod 16)
//     by the step h = (h ^ word) * 16777619 mod 2^32 (FNV-1a's 32-bit prime; lane j starts at
//     2166136261 ^ j), and the 16 lanes are folded at the end by 64-bit FNV-1a steps.
//   Identical looked-at bytes give the same hash. Which words are stepped depends on the grid
//   only, and every step is a bijection of its lane, so one changed looked-at byte always
//   changes the hash; several change it but for a chance of about 2^-32. Why this form: a
//   64-byte block of a row is 16 words, one per lane, so the kernel hashes a block with one
//   masked multiply (the signature before took a 64-bit multiply per sample, 14k a frame, in
//   four chains), and the portable loop still does one step per sample.
// camera_scan_portable(grid), camera_scan_avx512(grid) (x86 with GCC/Clang only; call it only
//   where camera_scan_cpu_has_avx512() is true), camera_scan(grid): the best the CPU runs.
// No state but the cached CPU check: callable from any thread.
#pragma once

#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/version.hpp>

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <numeric>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define SHADOWSENSE_CAMERA_SCAN_X86 1
#include <immintrin.h>
#else
#define SHADOWSENSE_CAMERA_SCAN_X86 0
#endif

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

struct CameraScanGrid {
  const std::uint8_t* data = nullptr;
  std::size_t row_stride = 0; // bytes from one row to the next
  int cols = 0, rows = 0;
  int channels = 3; // bytes per pixel: 1, 3 or 4
  int colour = 3;   // bytes looked at per sample: 1 (one channel) or 3 (alpha is not)
  int step = 4;
  int dark_level = 16, saturated_level = 255;
};

struct CameraScan {
  std::int64_t samples = 0, dark = 0, saturated = 0;
  std::uint64_t hash = 0;
  bool operator==(const CameraScan&) const = default;
};

inline constexpr std::uint32_t kScanPrime = 16777619u, kScanOffset = 2166136261u;

inline std::uint64_t fold_scan_lanes(const std::uint32_t (&h)[16]) {
  constexpr std::uint64_t offset = 1469598103934665603ull, prime = 1099511628211ull;
  std::uint64_t out = offset;
  for (const std::uint32_t v : h) out = (out ^ v) * prime;
  return out;
}

template <int Colour>
inline CameraScan camera_scan_portable_impl(const CameraScanGrid& g) {
  const std::size_t pitch = static_cast<std::size_t>(g.step) * static_cast<std::size_t>(g.channels);
  const int per_row = (g.cols + g.step - 1) / g.step;
  std::uint32_t h[16];
  for (std::uint32_t j = 0; j < 16; ++j) h[j] = kScanOffset ^ j;
  CameraScan out;
  for (int y = 0; y < g.rows; y += g.step) {
    const std::uint8_t* row = g.data + static_cast<std::size_t>(y) * g.row_stride;
    // The next sampled row, asked for while this one is read (see the AVX-512 kernel).
    const std::uint8_t* next =
        y + g.step < g.rows ? row + static_cast<std::size_t>(g.step) * g.row_stride : row;
    std::size_t word_at = ~std::size_t{0}; // the index of the word being gathered, if any
    std::uint32_t word = 0;
    for (int i = 0; i < per_row; ++i) {
      const std::size_t o = static_cast<std::size_t>(i) * pitch;
      if (i % 4 == 0) prefetch_for_read(next + o);
      int lo = row[o], hi = row[o];
      for (int c = 0; c < Colour; ++c) {
        const std::size_t at = o + static_cast<std::size_t>(c);
        const int v = row[at];
        lo = v < lo ? v : lo;
        hi = v > hi ? v : hi;
        if (at / 4 != word_at) { // this byte starts another word: the last one is complete
          if (word_at != ~std::size_t{0}) h[word_at % 16] = (h[word_at % 16] ^ word) * kScanPrime;
          word_at = at / 4;
          word = 0;
        }
        word |= static_cast<std::uint32_t>(v) << (8 * (at % 4));
      }
      out.dark += hi <= g.dark_level;
      out.saturated += lo >= g.saturated_level;
    }
    if (word_at != ~std::size_t{0}) h[word_at % 16] = (h[word_at % 16] ^ word) * kScanPrime;
    out.samples += per_row;
  }
  out.hash = fold_scan_lanes(h);
  return out;
}

inline CameraScan camera_scan_portable(const CameraScanGrid& g) {
  return g.colour == 3 ? camera_scan_portable_impl<3>(g) : camera_scan_portable_impl<1>(g);
}

// starts[b]: bit k set where byte 64 b + k of a row is a sample's first byte, for the blocks of
// one period of the pattern (pitch / gcd(pitch, 64) blocks, at most 256 for pitch <= 256).
inline int sample_start_pattern(std::size_t pitch, std::array<std::uint64_t, 256>& starts) {
  const int period = static_cast<int>(pitch / std::gcd(pitch, std::size_t{64}));
  for (int b = 0; b < period; ++b) starts[static_cast<std::size_t>(b)] = 0;
  for (std::size_t o = 0; o < static_cast<std::size_t>(period) * 64; o += pitch)
    starts[o / 64] |= std::uint64_t{1} << (o % 64);
  return period;
}

#if SHADOWSENSE_CAMERA_SCAN_X86
// Bits 0 .. n - 1 (n <= 64).
inline std::uint64_t low_bits(std::size_t n) {
  return n >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << n) - 1;
}

template <int Colour>
__attribute__((target("avx512f,avx512bw,popcnt"))) inline CameraScan
camera_scan_avx512_impl(const CameraScanGrid& g) {
  const std::size_t row_bytes =
      static_cast<std::size_t>(g.cols) * static_cast<std::size_t>(g.channels);
  const std::size_t pitch = static_cast<std::size_t>(g.step) * static_cast<std::size_t>(g.channels);
  std::array<std::uint64_t, 256> starts;
  const int period = sample_start_pattern(pitch, starts);
  const __m512i dark_level = _mm512_set1_epi8(static_cast<char>(g.dark_level));
  const __m512i saturated_level = _mm512_set1_epi8(static_cast<char>(g.saturated_level));
  const __m512i prime = _mm512_set1_epi32(static_cast<int>(kScanPrime));
  __m512i h =
      _mm512_xor_si512(_mm512_set1_epi32(static_cast<int>(kScanOffset)),
                       _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
  std::int64_t dark = 0, saturated = 0;
  const int per_row = (g.cols + g.step - 1) / g.step;
  CameraScan out;
  for (int y = 0; y < g.rows; y += g.step) {
    const std::uint8_t* row = g.data + static_cast<std::size_t>(y) * g.row_stride;
    // The next sampled row, asked for while this one is read: the scan is the first to touch a
    // frame, often straight from a camera's buffer and not in the cache.
    const std::uint8_t* next =
        y + g.step < g.rows ? row + static_cast<std::size_t>(g.step) * g.row_stride : row;
    std::uint64_t carry = 0; // the looked-at bytes of the previous block's last samples
    int phase = 0;           // the block's place in the start pattern
    for (std::size_t b = 0; b < row_bytes; b += 64) {
      prefetch_for_read(next + b);
      const std::size_t left = row_bytes - b;
      const std::uint64_t start = starts[static_cast<std::size_t>(phase)] & low_bits(left);
      phase = phase + 1 == period ? 0 : phase + 1;
      const __m512i v0 = _mm512_maskz_loadu_epi8(low_bits(left), row + b);
      __m512i hi = v0, lo = v0;
      std::uint64_t looked = start;
      if constexpr (Colour == 3) {
        // Bytes past the row's end are not read (masked out); a sample's bytes all lie in it.
        const __m512i v1 = _mm512_maskz_loadu_epi8(low_bits(left - 1), row + b + 1);
        const __m512i v2 = _mm512_maskz_loadu_epi8(left >= 2 ? low_bits(left - 2) : 0, row + b + 2);
        hi = _mm512_max_epu8(v0, _mm512_max_epu8(v1, v2));
        lo = _mm512_min_epu8(v0, _mm512_min_epu8(v1, v2));
        looked = start | (start << 1) | (start << 2) | carry;
        carry = (start >> 63) | (start >> 62);
      }
      dark += std::popcount(start & _mm512_cmple_epu8_mask(hi, dark_level));
      saturated += std::popcount(start & _mm512_cmpge_epu8_mask(lo, saturated_level));
      // The lanes whose word holds a looked-at byte take a step; the others keep their value.
      const __m512i bytes = _mm512_maskz_mov_epi8(looked, v0);
      const __mmask16 words =
          _mm512_test_epi32_mask(_mm512_movm_epi8(looked), _mm512_set1_epi8(-1));
      h = _mm512_mask_mullo_epi32(h, words, _mm512_xor_si512(h, bytes), prime);
    }
    out.samples += per_row;
  }
  alignas(64) std::uint32_t lanes[16];
  _mm512_store_si512(reinterpret_cast<__m512i*>(lanes), h);
  out.dark = dark;
  out.saturated = saturated;
  out.hash = fold_scan_lanes(lanes);
  return out;
}

inline CameraScan camera_scan_avx512(const CameraScanGrid& g) {
  return g.colour == 3 ? camera_scan_avx512_impl<3>(g) : camera_scan_avx512_impl<1>(g);
}
#endif

inline bool camera_scan_cpu_has_avx512() {
#if SHADOWSENSE_CAMERA_SCAN_X86
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw");
  return has;
#else
  return false;
#endif
}

inline CameraScan camera_scan(const CameraScanGrid& g) {
#if SHADOWSENSE_CAMERA_SCAN_X86
  if (camera_scan_cpu_has_avx512()) return camera_scan_avx512(g);
#endif
  return camera_scan_portable(g);
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
