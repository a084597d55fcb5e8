// Which per-row kernels the segmenter's one pass over the frame uses (the relative rule's
// per-pixel decision and the rows of the mask smoothing), picked once per process from what the
// CPU runs. The kernels live apart, all with one contract (segment_kernels_portable.hpp) and the
// same results, byte for byte and float for float:
//   segment_kernels_portable.hpp  plain C++ (any CPU)
//   segment_kernels_x86.hpp       AVX-512 (F + BW + VL) and AVX2 (x86-64), chosen at run
//                                 time, no -march needed
//   segment_kernels_neon.hpp      Advanced SIMD (aarch64), compiled in there
//
// SegmentKernelKind: automatic picks avx512 on an x86 CPU that has AVX-512 F, BW and VL, else
//   avx2 on one that has AVX2 and F16C, neon on aarch64, else portable. The avx512 kind's relative
//   rule splits the channels by byte permutes where the CPU also has VBMI.
// segment_cpu_has(kind): true when kind is compiled in and the CPU runs it (automatic: false).
// segment_kernels(kind)
//   requires: kind is automatic or segment_cpu_has(kind); throws InvalidArgument otherwise.
//   ensures:  the kernels of that kind (automatic: the CPU check runs once per process).
// No state but the cached tables (function-local statics, made once): any thread.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/segment_kernels_neon.hpp>
#include <shadowsense/sense/segment_kernels_portable.hpp>
#include <shadowsense/sense/segment_kernels_x86.hpp>

#include <array>
#include <cstddef>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

enum class SegmentKernelKind { automatic, avx2, neon, portable, avx512 };

inline const char* segment_kernel_name(SegmentKernelKind k) {
  switch (k) {
  case SegmentKernelKind::avx2:
    return "avx2";
  case SegmentKernelKind::avx512:
    return "avx512";
  case SegmentKernelKind::neon:
    return "neon";
  case SegmentKernelKind::portable:
    return "portable";
  default:
    return "automatic";
  }
}

inline bool segment_cpu_has(SegmentKernelKind kind) {
  switch (kind) {
  case SegmentKernelKind::portable:
    return true;
#if SHADOWSENSE_SEGMENT_X86
  case SegmentKernelKind::avx2: // F16C: the relative rule reads the model as binary16
    return __builtin_cpu_supports("avx2") && detail::segment_cpu_has_f16c();
  case SegmentKernelKind::avx512:
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512vl");
#endif
#if SHADOWSENSE_SEGMENT_NEON
  case SegmentKernelKind::neon:
    return true;
#endif
  default:
    return false;
  }
}

namespace detail {

struct SegmentKernels {
  SegmentKernelKind kind;
  RelativeRowFn relative_row;
  HsumRowFn hsum3, hsum5;
  VsumRowFn vsum3, vsum5;
  ReferenceBinsFn reference_bins;
};

inline SegmentKernels make_segment_kernels(SegmentKernelKind kind) {
  switch (kind) {
#if SHADOWSENSE_SEGMENT_X86
  case SegmentKernelKind::avx2:
    return {.kind = kind,
            .relative_row = relative_row_avx2,
            .hsum3 = hsum_row_avx2<3>,
            .hsum5 = hsum_row_avx2<5>,
            .vsum3 = vsum_row_avx2<3>,
            .vsum5 = vsum_row_avx2<5>,
            .reference_bins = reference_bins_avx2};
  case SegmentKernelKind::avx512:
    return {.kind = kind,
            .relative_row = segment_cpu_has_vbmi() ? relative_row_avx512_vbmi : relative_row_avx512,
            .hsum3 = hsum_row_avx512<3>,
            .hsum5 = hsum_row_avx512<5>,
            .vsum3 = vsum_row_avx512<3>,
            .vsum5 = vsum_row_avx512<5>,
            .reference_bins = reference_bins_avx512};
#endif
#if SHADOWSENSE_SEGMENT_NEON
  case SegmentKernelKind::neon: // NEON has no gather: the reference's samples stay portable
    return {.kind = kind,
            .relative_row = relative_row_neon,
            .hsum3 = hsum_row_portable<3>,
            .hsum5 = hsum_row_portable<5>,
            .vsum3 = vsum_row_portable<3>,
            .vsum5 = vsum_row_portable<5>,
            .reference_bins = reference_bins_portable};
#endif
  default:
    return {.kind = SegmentKernelKind::portable,
            .relative_row = relative_row_portable,
            .hsum3 = hsum_row_portable<3>,
            .hsum5 = hsum_row_portable<5>,
            .vsum3 = vsum_row_portable<3>,
            .vsum5 = vsum_row_portable<5>,
            .reference_bins = reference_bins_portable};
  }
}

inline SegmentKernelKind best_segment_kernel() {
  for (SegmentKernelKind k :
       {SegmentKernelKind::avx512, SegmentKernelKind::avx2, SegmentKernelKind::neon})
    if (segment_cpu_has(k)) return k;
  return SegmentKernelKind::portable;
}

} // namespace detail

inline const detail::SegmentKernels&
segment_kernels(SegmentKernelKind kind = SegmentKernelKind::automatic) {
  static const detail::SegmentKernels best =
      detail::make_segment_kernels(detail::best_segment_kernel());
  if (kind == SegmentKernelKind::automatic) return best;
  if (!segment_cpu_has(kind))
    SHADOWSENSE_THROW(InvalidArgument(std::string("segment_kernels: '") +
                                      segment_kernel_name(kind) +
                                      "' is not compiled in or not supported by this CPU"));
  if (kind == best.kind) return best;
  // Another kind the CPU runs (the portable kernels, or AVX2 where AVX-512 is picked): one
  // table per kind, made on first use.
  static const std::array<detail::SegmentKernels, 5> each = [] {
    std::array<detail::SegmentKernels, 5> all{};
    for (std::size_t k = 1; k < all.size(); ++k) {
      const auto kk = static_cast<SegmentKernelKind>(k);
      all[k] = detail::make_segment_kernels(segment_cpu_has(kk) ? kk : SegmentKernelKind::portable);
    }
    return all;
  }();
  return each[static_cast<std::size_t>(kind)];
}

SHADOWSENSE_NAMESPACE_END
