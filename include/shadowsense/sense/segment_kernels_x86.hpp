// The segmenter's per-row kernels for x86-64 with AVX2 and with AVX-512 (F + BW + VL)
// (segment_kernels_portable.hpp has the contracts; the results are the same bytes and floats).
// Each function carries a function-level target attribute, so the library needs no -march flag;
// segment_kernels.hpp calls them only after checking the CPU (__builtin_cpu_supports, and
// segment_cpu_has_f16c() for the AVX2 relative rule's F16C). AVX2 without FMA; the AVX-512 target
// implies FMA, so its relative rule is compiled with contraction off (SHADOWSENSE_STRICT_FP): both
// round after every multiply and add, as the portable kernel does. Compiled only with GCC/Clang on
// x86 (SHADOWSENSE_SEGMENT_X86 is 1), empty elsewhere.
//
// relative_row_avx2: 16 pixels a step (SSSE3 shuffles split B, G, R; two 8-float halves; the
//   model's binary16 values converted by F16C), the last 1-15 pixels' halves converted by F16C
//   into a stack array, then the portable loop body.
// reference_bins_avx2: 8 samples a step (a 32-bit gather per sample), the frame bytes of later
//   samples prefetched (prefetch_reference_samples: gathers do not train the prefetcher).
// hsum_row_avx2<K>, vsum_row_avx2<K>: 16 lanes of 16 bits a step, written with intrinsics (left
//   to the compiler, they were vectorised at -O3 only: at GCC's -O2, what Debian and CMake's
//   RelWithDebInfo build with, they ran scalar and the segmenter took 5x longer), the rest with
//   the portable loop body. The sums cannot overflow 16 bits (at most 16 * 16 * 255), so the
//   lane arithmetic is exact.
// relative_row_avx512: 16 pixels a step (the same byte shuffles; one 16-float vector per
//   channel, compares into mask registers), the last 1-15 pixels the same way with masked loads
//   and stores.
// relative_row_avx512_vbmi: the same, each channel split by one byte permute (AVX-512 VBMI);
//   segment_kernels.hpp picks it for the avx512 kind where the CPU has VBMI
//   (segment_cpu_has_vbmi()).
// reference_bins_avx512: 16 samples a step (a 16-lane gather), prefetching as the AVX2 one.
// hsum_row_avx512<K>, vsum_row_avx512<K>: 32 lanes of 16 bits a step; the last partial step
//   with masked loads and stores (a masked-out lane is never read, so nothing past the row is).
// No state; callable from any thread.
#pragma once

#include <shadowsense/sense/segment_kernels_portable.hpp>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define SHADOWSENSE_SEGMENT_X86 1
#include <cpuid.h>
#include <immintrin.h>
#else
#define SHADOWSENSE_SEGMENT_X86 0
#endif

#if SHADOWSENSE_SEGMENT_X86
SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

// pshufb masks taking channel c of 16 packed BGR pixels from 16-byte chunk j (-128: none).
constexpr std::array<std::array<std::array<std::int8_t, 16>, 3>, 3> bgr_split_masks() {
  std::array<std::array<std::array<std::int8_t, 16>, 3>, 3> m{};
  for (int c = 0; c < 3; ++c)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 16; ++i) {
        const int at = 3 * i + c;
        m[static_cast<std::size_t>(c)][static_cast<std::size_t>(j)][static_cast<std::size_t>(i)] =
            at / 16 == j ? static_cast<std::int8_t>(at % 16) : std::int8_t{-128};
      }
  return m;
}
inline constexpr auto kBgrSplit = bgr_split_masks();

// Helpers as functions, not lambdas: a lambda does not take its caller's target attribute.
// The low 8 bytes of v as 8 floats.
__attribute__((target("avx2"))) inline __m256 widen_bytes_avx2(__m128i v) {
  return _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(v));
}
// 2 x 8 lanes of 0 / -1 to 16 bytes in pixel order (the packs work within 128-bit halves).
__attribute__((target("avx2"))) inline __m128i lanes_to_bytes_avx2(__m256i lo, __m256i hi) {
  const __m256i p16 = _mm256_permute4x64_epi64(_mm256_packs_epi32(lo, hi), 0xD8);
  return _mm_packs_epi16(_mm256_castsi256_si128(p16), _mm256_extracti128_si256(p16, 1));
}
// min(max(int(v * inv * 4), 0), 1023) for 8 samples.
__attribute__((target("avx2"))) SHADOWSENSE_STRICT_FP inline __m256i
quarter_bins_avx2(__m256i v, const float* inv) {
  const __m256 f = _mm256_mul_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(v), _mm256_loadu_ps(inv)),
                                 _mm256_set1_ps(4.f));
  return _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(f), _mm256_setzero_si256()),
                          _mm256_set1_epi32(1023));
}
// 8 x 32 bits (< 1024) to 8 x 16 bits.
__attribute__((target("avx2"))) inline void store_u16_avx2(std::uint16_t* dst, __m256i v) {
  const __m128i packed =
      _mm_packus_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), packed);
}

// Eight binary16 values (bits) at p as floats, exactly (F16C, which every AVX2 CPU has; the
// avx2 kind requires it).
__attribute__((target("avx2,f16c"))) inline __m256 load_halves_avx2(const std::uint16_t* p) {
  return _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}

__attribute__((target("avx2,f16c"))) SHADOWSENSE_STRICT_FP inline void
relative_row_avx2(const RelativeRowParams& p, const std::uint8_t* bgr, const std::uint16_t* ipb,
                  const std::uint16_t* ipg, const std::uint16_t* ipr, const std::uint8_t* skin,
                  int w, float* dk, float* wm, std::uint8_t* sm, std::uint8_t* cm) {
  const __m256 gb = _mm256_set1_ps(p.gb), gg = _mm256_set1_ps(p.gg), gr = _mm256_set1_ps(p.gr);
  const __m256 third = _mm256_set1_ps(1.f / 3.f), one = _mm256_set1_ps(1.f);
  const __m256 ts = _mm256_set1_ps(p.shadow), tc = _mm256_set1_ps(p.contact),
               tw = _mm256_set1_ps(p.warmth);
  const __m256i zero = _mm256_setzero_si256();
  const __m128i mb0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[0][0].data())),
                mb1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[0][1].data())),
                mb2 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[0][2].data()));
  const __m128i mg0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[1][0].data())),
                mg1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[1][1].data())),
                mg2 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[1][2].data()));
  const __m128i mr0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[2][0].data())),
                mr1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[2][1].data())),
                mr2 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[2][2].data()));
  int x = 0;
  for (; x + 16 <= w; x += 16) {
    const auto* src = reinterpret_cast<const __m128i*>(bgr + 3 * x);
    const __m128i a0 = _mm_loadu_si128(src), a1 = _mm_loadu_si128(src + 1),
                  a2 = _mm_loadu_si128(src + 2);
    const __m128i b8 =
        _mm_or_si128(_mm_or_si128(_mm_shuffle_epi8(a0, mb0), _mm_shuffle_epi8(a1, mb1)),
                     _mm_shuffle_epi8(a2, mb2));
    const __m128i g8 =
        _mm_or_si128(_mm_or_si128(_mm_shuffle_epi8(a0, mg0), _mm_shuffle_epi8(a1, mg1)),
                     _mm_shuffle_epi8(a2, mg2));
    const __m128i r8 =
        _mm_or_si128(_mm_or_si128(_mm_shuffle_epi8(a0, mr0), _mm_shuffle_epi8(a1, mr1)),
                     _mm_shuffle_epi8(a2, mr2));
    const __m128i s8 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(skin + x));
    __m256i cmask[2], smask[2];
    for (int h = 0; h < 2; ++h) {
      const int o = x + 8 * h;
      const __m128i bh = h == 0 ? b8 : _mm_srli_si128(b8, 8),
                    gh = h == 0 ? g8 : _mm_srli_si128(g8, 8),
                    rh = h == 0 ? r8 : _mm_srli_si128(r8, 8);
      const __m256 qb =
          _mm256_mul_ps(_mm256_mul_ps(widen_bytes_avx2(bh), load_halves_avx2(ipb + o)), gb);
      const __m256 qg =
          _mm256_mul_ps(_mm256_mul_ps(widen_bytes_avx2(gh), load_halves_avx2(ipg + o)), gg);
      const __m256 qr =
          _mm256_mul_ps(_mm256_mul_ps(widen_bytes_avx2(rh), load_halves_avx2(ipr + o)), gr);
      const __m256i s32 = _mm256_cvtepu8_epi32(h == 0 ? s8 : _mm_srli_si128(s8, 8));
      const __m256 on_skin =
          _mm256_andnot_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(s32, zero)), one);
      const __m256 d =
          _mm256_sub_ps(on_skin, _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(qb, qg), qr), third));
      const __m256 wt = _mm256_sub_ps(qr, qb);
      _mm256_storeu_ps(dk + o, d);
      _mm256_storeu_ps(wm + o, wt);
      cmask[h] = _mm256_castps_si256(
          _mm256_and_ps(_mm256_cmp_ps(d, tc, _CMP_GE_OQ), _mm256_cmp_ps(wt, tw, _CMP_GE_OQ)));
      smask[h] = _mm256_castps_si256(_mm256_cmp_ps(d, ts, _CMP_GE_OQ));
    }
    const __m128i c = _mm_and_si128(lanes_to_bytes_avx2(cmask[0], cmask[1]), s8);
    const __m128i s = _mm_or_si128(_mm_and_si128(lanes_to_bytes_avx2(smask[0], smask[1]), s8), c);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(cm + x), c);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(sm + x), s);
  }
  if (x < w) { // the last 1-15 pixels: their halves converted by F16C (16 at a time), then alone
    alignas(32) std::uint16_t h[3][16] = {};
    alignas(32) float inv[3][16];
    const std::array<const std::uint16_t*, 3> ip{ipb, ipg, ipr};
    for (std::size_t c = 0; c < 3; ++c) {
      std::copy(ip[c] + x, ip[c] + w, h[c]);
      _mm256_store_ps(inv[c], load_halves_avx2(h[c]));
      _mm256_store_ps(inv[c] + 8, load_halves_avx2(h[c] + 8));
    }
    relative_pixels(
        p, bgr, [&inv, x](int c, int px) { return inv[static_cast<std::size_t>(c)][px - x]; }, skin,
        x, w, dk, wm, sm, cm);
  }
}

// A gather does not train the hardware prefetcher, and reference_bins is among the first code
// to read a new frame, which need not be in the cache (straight from a camera's DMA buffer, or
// after other work): the vector kernels ask for the bytes of the samples this far ahead, every
// fifth sample (the samples run along every third row, 9 bytes apart, so each 64-byte line is asked
// for at least once). Measured on 635 x 350 frames not in the cache (docs/densenet.md, "The
// reference's samples prefetched"): AVX-512 0.084 -> 0.029 ms, AVX2 0.105 -> 0.028 ms. The portable
// loop, slower per sample, gains nothing from it.
inline constexpr int reference_prefetch_distance = 192;
inline constexpr int reference_prefetch_stride = 5;

// Prefetches the frame bytes of samples [i + distance, i + distance + count) at the stride,
// those below n only.
inline void prefetch_reference_samples(const std::uint8_t* frame, std::size_t step,
                                       const std::int32_t* ys, const std::int32_t* xs, int i,
                                       int count, int n) {
  const int end = std::min(i + reference_prefetch_distance + count, n);
  for (int k = i + reference_prefetch_distance; k < end; k += reference_prefetch_stride)
    prefetch_for_read(frame + static_cast<std::size_t>(ys[k]) * step +
                      3 * static_cast<std::size_t>(xs[k]));
}

// 8 samples a step: one 32-bit gather per sample from the byte before B (so B, G, R are bytes
// 1..3 and nothing past the pixel is read), then the three channels' bins.
__attribute__((target("avx2"))) SHADOWSENSE_STRICT_FP inline void
reference_bins_avx2(const std::uint8_t* frame, std::size_t step, const std::int32_t* ys,
                    const std::int32_t* xs, const float* ib, const float* ig, const float* ir,
                    int n, std::uint16_t* bb, std::uint16_t* bg, std::uint16_t* br) {
  int i = 0;
  // Offsets y step + 3 x in 32 bits: certain for rows of up to 32767 bytes (y < 65536, the
  // segmenter's largest side); wider frames take the scalar loop.
  if (step <= 0x7fffffffull / 65536) {
    const __m256i vstep = _mm256_set1_epi32(static_cast<int>(step)), three = _mm256_set1_epi32(3);
    const __m256i byte = _mm256_set1_epi32(255);
    const auto* base = reinterpret_cast<const int*>(frame);
    const __m256i minus_one = _mm256_set1_epi32(-1);
    for (; i + 8 <= n; i += 8) {
      prefetch_reference_samples(frame, step, ys, xs, i, 8, n);
      const __m256i y = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ys + i));
      const __m256i x = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(xs + i));
      const __m256i off = _mm256_add_epi32(
          _mm256_add_epi32(_mm256_mullo_epi32(y, vstep), _mm256_mullo_epi32(x, three)), minus_one);
      const __m256i px = _mm256_i32gather_epi32(base, off, 1);
      store_u16_avx2(bb + i,
                     quarter_bins_avx2(_mm256_and_si256(_mm256_srli_epi32(px, 8), byte), ib + i));
      store_u16_avx2(bg + i,
                     quarter_bins_avx2(_mm256_and_si256(_mm256_srli_epi32(px, 16), byte), ig + i));
      store_u16_avx2(br + i, quarter_bins_avx2(_mm256_srli_epi32(px, 24), ir + i));
    }
  }
  reference_bins_tail(frame, step, ys, xs, ib, ig, ir, i, n, bb, bg, br);
}

// sum_t wt[t] * v[t] with the weights 1 2 1 or 1 4 6 4 1 as shifts and adds.
template <int K>
__attribute__((target("avx2"))) inline __m256i weighted_sum_avx2(const __m256i* v) {
  // The shifts below hard-code these weights; a change to them must change this function.
  static_assert(smoothing_weights<3> == std::array<std::uint16_t, 5>{1, 2, 1, 0, 0});
  static_assert(smoothing_weights<5> == std::array<std::uint16_t, 5>{1, 4, 6, 4, 1});
  if constexpr (K == 3) {
    return _mm256_add_epi16(_mm256_add_epi16(v[0], v[2]), _mm256_slli_epi16(v[1], 1));
  } else {
    const __m256i c = v[2];
    return _mm256_add_epi16(_mm256_add_epi16(_mm256_add_epi16(v[0], v[4]),
                                             _mm256_slli_epi16(_mm256_add_epi16(v[1], v[3]), 2)),
                            _mm256_add_epi16(_mm256_slli_epi16(c, 2), _mm256_slli_epi16(c, 1)));
  }
}

template <int K>
__attribute__((target("avx2"))) inline void hsum_row_avx2(const std::uint8_t* pad, int w,
                                                          std::uint16_t* out) {
  int x = 0;
  for (; x + 16 <= w; x += 16) {
    __m256i v[K];
    // Unrolled so v stays in registers at -O2 too (GCC unrolls this fully at -O3 only).
#pragma GCC unroll 5
    for (int t = 0; t < K; ++t)
      v[t] = _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(pad + x + t)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + x), weighted_sum_avx2<K>(v));
  }
  if (x < w) hsum_row_body<K>(pad + x, w - x, out + x);
}
template <int K>
__attribute__((target("avx2"))) inline bool vsum_row_avx2(const std::uint16_t* const* rows, int w,
                                                          std::uint8_t* mask, std::uint8_t* marks) {
  const __m256i on = _mm256_set1_epi16(static_cast<short>(smoothing_on<K>));
  const __m128i one = _mm_set1_epi8(1);
  int any = 0;
  int x = 0;
  for (; x + 16 <= w; x += 16) {
    __m256i r[K];
#pragma GCC unroll 5
    for (int t = 0; t < K; ++t)
      r[t] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rows[t] + x));
    const __m256i v = weighted_sum_avx2<K>(r);
    // v >= on, unsigned: 0xFFFF or 0 per lane, then one byte per lane (0xFF or 0).
    const __m256i ge = _mm256_cmpeq_epi16(_mm256_max_epu16(v, on), v);
    const __m128i bytes =
        _mm_packs_epi16(_mm256_castsi256_si128(ge), _mm256_extracti128_si256(ge, 1));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(mask + x), bytes);
    if (marks) _mm_storeu_si128(reinterpret_cast<__m128i*>(marks + x), _mm_and_si128(bytes, one));
    any |= _mm_movemask_epi8(bytes);
  }
  if (x < w) {
    std::array<const std::uint16_t*, K> rest{};
    for (std::size_t t = 0; t < K; ++t) rest[t] = rows[t] + x;
    if (vsum_row_body<K>(rest.data(), w - x, mask + x, marks ? marks + x : nullptr)) any = 1;
  }
  return any != 0;
}

// ---- AVX-512 (F + BW + VL) ----------------------------------------------------------------

#define SHADOWSENSE_AVX512 __attribute__((target("avx512f,avx512bw,avx512vl")))

// GCC 12 warns "uninitialized" inside the plain forms of several AVX-512 intrinsics (their
// unused merge source); the zero-masking forms with every lane selected are the same
// instructions without it.
constexpr __mmask16 kAll16 = 0xFFFF;
constexpr __mmask32 kAll32 = 0xFFFFFFFF;

SHADOWSENSE_AVX512 inline __m512 widen_bytes_avx512(__m128i v) {
  return _mm512_maskz_cvtepi32_ps(kAll16, _mm512_maskz_cvtepu8_epi32(kAll16, v));
}

// The relative rule's constants as vectors, and the rule for 16 pixels from their channel
// values as floats (f[0..2]: B, G, R), shared by both AVX-512 row kernels.
struct RelativeConsts512 {
  __m512 g[3], third, one, ts, tc, tw;
};
SHADOWSENSE_AVX512 inline RelativeConsts512 relative_consts_avx512(const RelativeRowParams& p) {
  return {{_mm512_set1_ps(p.gb), _mm512_set1_ps(p.gg), _mm512_set1_ps(p.gr)},
          _mm512_set1_ps(1.f / 3.f),
          _mm512_set1_ps(1.f),
          _mm512_set1_ps(p.shadow),
          _mm512_set1_ps(p.contact),
          _mm512_set1_ps(p.warmth)};
}
// 16 binary16 values (bits) at h as floats, exactly; Tail: only the lanes in `lanes` read.
template <bool Tail>
SHADOWSENSE_AVX512 inline __m512 load_halves16_avx512(const std::uint16_t* h, __mmask16 lanes) {
  const __m256i v = Tail ? _mm256_maskz_loadu_epi16(lanes, h)
                         : _mm256_loadu_si256(reinterpret_cast<const __m256i*>(h));
  return _mm512_maskz_cvtph_ps(kAll16, v);
}

// Tail: only the pixels in `lanes` are read and written (masked loads and stores, which do not
// touch the memory of the other lanes): a row's last 1-15 pixels take the same vector operations
// as the others (a scalar tail converting each binary16 alone cost a tenth of the rule).
template <bool Tail>
SHADOWSENSE_AVX512 SHADOWSENSE_STRICT_FP inline void
relative_pixels16_avx512(const RelativeConsts512& k, const __m512* f, const std::uint16_t* ipb,
                         const std::uint16_t* ipg, const std::uint16_t* ipr,
                         const std::uint8_t* skin, int x, __mmask16 lanes, float* dk, float* wm,
                         std::uint8_t* sm, std::uint8_t* cm) {
  SHADOWSENSE_STRICT_FP_BODY
  // B, G, R over the model (16 binary16 values each, converted exactly), times the frame's gains.
  const __m512 qb =
      _mm512_mul_ps(_mm512_mul_ps(f[0], load_halves16_avx512<Tail>(ipb + x, lanes)), k.g[0]);
  const __m512 qg =
      _mm512_mul_ps(_mm512_mul_ps(f[1], load_halves16_avx512<Tail>(ipg + x, lanes)), k.g[1]);
  const __m512 qr =
      _mm512_mul_ps(_mm512_mul_ps(f[2], load_halves16_avx512<Tail>(ipr + x, lanes)), k.g[2]);
  const __m128i s8 = Tail ? _mm_maskz_loadu_epi8(lanes, skin + x)
                          : _mm_loadu_si128(reinterpret_cast<const __m128i*>(skin + x));
  const __mmask16 on_skin = _mm_test_epi8_mask(s8, s8);
  const __m512 d = _mm512_sub_ps(_mm512_maskz_mov_ps(on_skin, k.one),
                                 _mm512_mul_ps(_mm512_add_ps(_mm512_add_ps(qb, qg), qr), k.third));
  const __m512 wt = _mm512_sub_ps(qr, qb);
  const __mmask16 contact =
      _mm512_cmp_ps_mask(d, k.tc, _CMP_GE_OQ) & _mm512_cmp_ps_mask(wt, k.tw, _CMP_GE_OQ);
  const __mmask16 shadow = _mm512_cmp_ps_mask(d, k.ts, _CMP_GE_OQ);
  const __m128i c = _mm_maskz_mov_epi8(contact, s8);
  const __m128i sc = _mm_or_si128(_mm_maskz_mov_epi8(shadow, s8), c);
  if constexpr (Tail) {
    _mm512_mask_storeu_ps(dk + x, lanes, d);
    _mm512_mask_storeu_ps(wm + x, lanes, wt);
    _mm_mask_storeu_epi8(cm + x, lanes, c);
    _mm_mask_storeu_epi8(sm + x, lanes, sc);
  } else {
    _mm512_storeu_ps(dk + x, d);
    _mm512_storeu_ps(wm + x, wt);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(cm + x), c);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(sm + x), sc);
  }
}

// The lanes of a row's last `left` (1-15) pixels, and the mask of their 3 x left bytes.
inline __mmask16 tail_lanes16(int left) {
  return static_cast<__mmask16>((1u << left) - 1);
}
inline __mmask64 tail_bytes48(int left) {
  return (__mmask64{1} << (3 * left)) - 1;
}

// B, G, R of 16 pixels (48 bytes in three vectors) as floats, by byte shuffles.
SHADOWSENSE_AVX512 inline void split_bgr16_avx512(__m128i a0, __m128i a1, __m128i a2,
                                                  const __m128i (&split)[3][3], __m512* f) {
  for (std::size_t c = 0; c < 3; ++c)
    f[c] = widen_bytes_avx512(_mm_or_si128(
        _mm_or_si128(_mm_shuffle_epi8(a0, split[c][0]), _mm_shuffle_epi8(a1, split[c][1])),
        _mm_shuffle_epi8(a2, split[c][2])));
}

SHADOWSENSE_AVX512 SHADOWSENSE_STRICT_FP inline void
relative_row_avx512(const RelativeRowParams& p, const std::uint8_t* bgr, const std::uint16_t* ipb,
                    const std::uint16_t* ipg, const std::uint16_t* ipr, const std::uint8_t* skin,
                    int w, float* dk, float* wm, std::uint8_t* sm, std::uint8_t* cm) {
  SHADOWSENSE_STRICT_FP_BODY
  const RelativeConsts512 k = relative_consts_avx512(p);
  __m128i split[3][3];
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t j = 0; j < 3; ++j)
      split[c][j] = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kBgrSplit[c][j].data()));
  __m512 f[3];
  int x = 0;
  for (; x + 16 <= w; x += 16) {
    const auto* src = reinterpret_cast<const __m128i*>(bgr + 3 * x);
    split_bgr16_avx512(_mm_loadu_si128(src), _mm_loadu_si128(src + 1), _mm_loadu_si128(src + 2),
                       split, f);
    relative_pixels16_avx512<false>(k, f, ipb, ipg, ipr, skin, x, kAll16, dk, wm, sm, cm);
  }
  if (x < w) {
    const __mmask64 bytes = tail_bytes48(w - x);
    const std::uint8_t* src = bgr + 3 * x;
    split_bgr16_avx512(_mm_maskz_loadu_epi8(static_cast<__mmask16>(bytes), src),
                       _mm_maskz_loadu_epi8(static_cast<__mmask16>(bytes >> 16), src + 16),
                       _mm_maskz_loadu_epi8(static_cast<__mmask16>(bytes >> 32), src + 32), split,
                       f);
    relative_pixels16_avx512<true>(k, f, ipb, ipg, ipr, skin, x, tail_lanes16(w - x), dk, wm, sm,
                                   cm);
  }
}

// vpermb index taking channel c of 16 packed BGR pixels into byte 0 of 32-bit lane i (the other
// bytes are zeroed by the permute's mask, kLowByteOfLanes).
constexpr std::array<std::array<std::uint8_t, 64>, 3> bgr_lane_index() {
  std::array<std::array<std::uint8_t, 64>, 3> m{};
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < 64; ++i)
      m[c][i] = static_cast<std::uint8_t>(i % 4 == 0 ? 3 * (i / 4) + c : 0);
  return m;
}
inline constexpr auto kBgrLaneIndex = bgr_lane_index();
constexpr __mmask64 kLowByteOfLanes = 0x1111111111111111ull;

// B, G, R of 16 pixels (48 packed bytes in v) as floats, one byte permute each.
__attribute__((target("avx512f,avx512bw,avx512vl,avx512vbmi"))) inline void
split_bgr16_vbmi(__m512i v, const __m512i (&index)[3], __m512* f) {
  for (std::size_t c = 0; c < 3; ++c)
    f[c] = _mm512_maskz_cvtepi32_ps(kAll16,
                                    _mm512_maskz_permutexvar_epi8(kLowByteOfLanes, index[c], v));
}

// As relative_row_avx512, the channels split by one byte permute each (AVX-512 VBMI) straight
// into 32-bit lanes: 3 permutes where the other kernel takes 9 shuffles, 6 ORs and 3 widenings
// (16 pixels' 48 bytes read by one masked load, nothing past them). The same floats and bytes.
__attribute__((target("avx512f,avx512bw,avx512vl,avx512vbmi"))) SHADOWSENSE_STRICT_FP inline void
relative_row_avx512_vbmi(const RelativeRowParams& p, const std::uint8_t* bgr,
                         const std::uint16_t* ipb, const std::uint16_t* ipg,
                         const std::uint16_t* ipr, const std::uint8_t* skin, int w, float* dk,
                         float* wm, std::uint8_t* sm, std::uint8_t* cm) {
  SHADOWSENSE_STRICT_FP_BODY
  const RelativeConsts512 k = relative_consts_avx512(p);
  __m512i index[3];
  for (std::size_t c = 0; c < 3; ++c) index[c] = _mm512_loadu_si512(kBgrLaneIndex[c].data());
  __m512 f[3];
  int x = 0;
  for (; x + 16 <= w; x += 16) {
    split_bgr16_vbmi(_mm512_maskz_loadu_epi8(tail_bytes48(16), bgr + 3 * x), index, f);
    relative_pixels16_avx512<false>(k, f, ipb, ipg, ipr, skin, x, kAll16, dk, wm, sm, cm);
  }
  if (x < w) { // the last 1-15 pixels, masked (the same operations)
    split_bgr16_vbmi(_mm512_maskz_loadu_epi8(tail_bytes48(w - x), bgr + 3 * x), index, f);
    relative_pixels16_avx512<true>(k, f, ipb, ipg, ipr, skin, x, tail_lanes16(w - x), dk, wm, sm,
                                   cm);
  }
}

// F16C (half-precision conversions) by CPUID leaf 1, ECX bit 29: Clang's __builtin_cpu_supports
// has no name for it.
inline bool segment_cpu_has_f16c() {
  unsigned a = 0, b = 0, c = 0, d = 0;
  return __get_cpuid(1, &a, &b, &c, &d) != 0 && (c & bit_F16C) != 0;
}

inline bool segment_cpu_has_vbmi() {
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
         __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512vbmi");
}

// min(max(int(v * inv * 4), 0), 1023) for 16 samples, as 16 x 16 bits.
SHADOWSENSE_AVX512 SHADOWSENSE_STRICT_FP inline __m256i quarter_bins_avx512(__m512i v,
                                                                            const float* inv) {
  SHADOWSENSE_STRICT_FP_BODY
  const __m512 f =
      _mm512_mul_ps(_mm512_mul_ps(_mm512_maskz_cvtepi32_ps(kAll16, v), _mm512_loadu_ps(inv)),
                    _mm512_set1_ps(4.f));
  const __m512i b = _mm512_maskz_min_epi32(
      kAll16,
      _mm512_maskz_max_epi32(kAll16, _mm512_maskz_cvttps_epi32(kAll16, f), _mm512_setzero_si512()),
      _mm512_set1_epi32(1023));
  return _mm512_maskz_cvtepi32_epi16(kAll16, b);
}

SHADOWSENSE_AVX512 inline void reference_bins_avx512(const std::uint8_t* frame, std::size_t step,
                                                     const std::int32_t* ys, const std::int32_t* xs,
                                                     const float* ib, const float* ig,
                                                     const float* ir, int n, std::uint16_t* bb,
                                                     std::uint16_t* bg, std::uint16_t* br) {
  int i = 0;
  // As reference_bins_avx2: 32-bit offsets from the byte before B, rows up to 32767 bytes.
  if (step <= 0x7fffffffull / 65536) {
    const __m512i vstep = _mm512_set1_epi32(static_cast<int>(step)), three = _mm512_set1_epi32(3),
                  byte = _mm512_set1_epi32(255), minus_one = _mm512_set1_epi32(-1);
    for (; i + 16 <= n; i += 16) {
      prefetch_reference_samples(frame, step, ys, xs, i, 16, n);
      const __m512i y = _mm512_loadu_si512(ys + i), x = _mm512_loadu_si512(xs + i);
      const __m512i off = _mm512_add_epi32(
          _mm512_add_epi32(_mm512_mullo_epi32(y, vstep), _mm512_mullo_epi32(x, three)), minus_one);
      const __m512i px = _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), kAll16, off, frame, 1);
      _mm256_storeu_si256(
          reinterpret_cast<__m256i*>(bb + i),
          quarter_bins_avx512(_mm512_and_si512(_mm512_maskz_srli_epi32(kAll16, px, 8), byte),
                              ib + i));
      _mm256_storeu_si256(
          reinterpret_cast<__m256i*>(bg + i),
          quarter_bins_avx512(_mm512_and_si512(_mm512_maskz_srli_epi32(kAll16, px, 16), byte),
                              ig + i));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(br + i),
                          quarter_bins_avx512(_mm512_maskz_srli_epi32(kAll16, px, 24), ir + i));
    }
  }
  reference_bins_tail(frame, step, ys, xs, ib, ig, ir, i, n, bb, bg, br);
}

template <int K>
SHADOWSENSE_AVX512 inline __m512i weighted_sum_avx512(const __m512i* v) {
  // The shifts below hard-code these weights; a change to them must change this function.
  static_assert(smoothing_weights<3> == std::array<std::uint16_t, 5>{1, 2, 1, 0, 0});
  static_assert(smoothing_weights<5> == std::array<std::uint16_t, 5>{1, 4, 6, 4, 1});
  if constexpr (K == 3) {
    return _mm512_add_epi16(_mm512_add_epi16(v[0], v[2]), _mm512_maskz_slli_epi16(kAll32, v[1], 1));
  } else {
    const __m512i c = v[2];
    return _mm512_add_epi16(
        _mm512_add_epi16(_mm512_add_epi16(v[0], v[4]),
                         _mm512_maskz_slli_epi16(kAll32, _mm512_add_epi16(v[1], v[3]), 2)),
        _mm512_add_epi16(_mm512_maskz_slli_epi16(kAll32, c, 2),
                         _mm512_maskz_slli_epi16(kAll32, c, 1)));
  }
}

// The first n (0..32) of 32 lanes.
inline std::uint32_t first_lanes32(int n) {
  return n >= 32 ? ~std::uint32_t{0} : (std::uint32_t{1} << n) - 1;
}

template <int K>
SHADOWSENSE_AVX512 inline void hsum_row_avx512(const std::uint8_t* pad, int w, std::uint16_t* out) {
  for (int x = 0; x < w; x += 32) {
    const __mmask32 m = first_lanes32(w - x);
    __m512i v[K];
#pragma GCC unroll 5
    for (int t = 0; t < K; ++t)
      v[t] = _mm512_maskz_cvtepu8_epi16(kAll32, _mm256_maskz_loadu_epi8(m, pad + x + t));
    _mm512_mask_storeu_epi16(out + x, m, weighted_sum_avx512<K>(v));
  }
}

template <int K>
SHADOWSENSE_AVX512 inline bool vsum_row_avx512(const std::uint16_t* const* rows, int w,
                                               std::uint8_t* mask, std::uint8_t* marks) {
  const __m512i on = _mm512_set1_epi16(static_cast<short>(smoothing_on<K>));
  const __m256i one = _mm256_set1_epi8(1);
  __mmask32 any = 0;
  for (int x = 0; x < w; x += 32) {
    const __mmask32 m = first_lanes32(w - x);
    __m512i r[K];
#pragma GCC unroll 5
    for (int t = 0; t < K; ++t) r[t] = _mm512_maskz_loadu_epi16(m, rows[t] + x);
    // v >= on, unsigned; lanes past the row are 0 and never set (on > 0).
    const __mmask32 ge = _mm512_cmpge_epu16_mask(weighted_sum_avx512<K>(r), on);
    _mm256_mask_storeu_epi8(mask + x, m, _mm256_movm_epi8(ge));
    if (marks) _mm256_mask_storeu_epi8(marks + x, m, _mm256_maskz_mov_epi8(ge, one));
    any |= ge;
  }
  return any != 0;
}

#undef SHADOWSENSE_AVX512

} // namespace detail
SHADOWSENSE_NAMESPACE_END
#endif
