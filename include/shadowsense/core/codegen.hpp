// How the compiler is asked to generate the kernels' code, whatever the build's -O level.
//
// SHADOWSENSE_STRICT_FP: for float code whose results must not depend on the compiler's choice
//   to fuse a multiply and an add (GNU mode fuses by default where the target has FMA, e.g.
//   aarch64 or -march=native). Put it before a function's declaration and
//   SHADOWSENSE_STRICT_FP_BODY as the first line of its body: every multiply and add in it then
//   rounds on its own (GCC: the function attribute; Clang: the pragma). Lambdas and functions
//   it calls are not covered: mark them too.
// SHADOWSENSE_VECTORISE: put before a function whose loops are written for the compiler to
//   vectorise (plain unit-stride loops of unknown length). GCC 12 vectorises at -O2 only loops
//   that need no scalar epilogue and no alias check (its "very cheap" cost model; GCC 11 and
//   older not at all), so at -O2 - Debian's level and CMake's RelWithDebInfo, what a project
//   that vendors the library often builds with - such loops ran scalar, with a branch per
//   ReLU, and small fixed loops inside them were not unrolled: the DenseNet forward pass took
//   1.5x its -O3 time. The attribute asks for the -O3 cost model and the loop optimisations
//   the project's own Release build adds to -O2 (CMakeLists.txt, SHADOWSENSE_DEV_O2) on those
//   functions only. Clang vectorises at -O2 already; other compilers ignore it. Not for a
//   function that must be inlined into one without it (GCC does not inline across different
//   optimisation options).
// SHADOWSENSE_ALWAYS_INLINE: inline, and always inlined where the compiler allows it.
// prefetch_for_read(p): asks for the cache line holding p, to be read soon (GCC and Clang:
//   __builtin_prefetch, prefetcht0 on x86; nothing elsewhere). Never faults.
// prefetch_range_for_read(p, bytes): the same for every 64-byte line of [p, p + bytes), with
//   moderate locality (prefetcht1 on x86: into the L2), for data a kernel reads a little later.
#pragma once

#include <shadowsense/core/version.hpp>

#include <cstddef>

#if defined(__clang__)
#define SHADOWSENSE_STRICT_FP
#define SHADOWSENSE_STRICT_FP_BODY _Pragma("clang fp contract(off)")
#elif defined(__GNUC__)
#define SHADOWSENSE_STRICT_FP __attribute__((optimize("fp-contract=off")))
#define SHADOWSENSE_STRICT_FP_BODY
#else
#define SHADOWSENSE_STRICT_FP
#define SHADOWSENSE_STRICT_FP_BODY
#endif

#if defined(__GNUC__) && !defined(__clang__)
#define SHADOWSENSE_VECTORISE                                                                      \
  __attribute__((optimize("tree-vectorize", "vect-cost-model=dynamic", "unswitch-loops",           \
                          "peel-loops", "predictive-commoning")))
#else
#define SHADOWSENSE_VECTORISE
#endif

#if defined(__GNUC__) || defined(__clang__)
#define SHADOWSENSE_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define SHADOWSENSE_ALWAYS_INLINE inline
#endif

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {
inline void prefetch_for_read(const void* p) {
#if defined(__GNUC__) || defined(__clang__)
  __builtin_prefetch(p);
#else
  (void)p;
#endif
}

inline void prefetch_range_for_read(const void* p, std::size_t bytes) {
#if defined(__GNUC__) || defined(__clang__)
  const char* c = static_cast<const char*>(p);
  for (std::size_t o = 0; o < bytes; o += 64) __builtin_prefetch(c + o, 0, 2);
#else
  (void)p;
  (void)bytes;
#endif
}
} // namespace detail
SHADOWSENSE_NAMESPACE_END
