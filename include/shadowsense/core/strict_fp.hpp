// Float code whose results must not depend on the compiler's choice to fuse a multiply and an
// add (GNU mode fuses by default where the target has FMA, e.g. aarch64 or -march=native).
//
// SHADOWSENSE_STRICT_FP: put before a function's declaration; with SHADOWSENSE_STRICT_FP_BODY
//   as the first line of its body, every multiply and add in it rounds on its own (GCC: the
//   function attribute; Clang: the pragma). Lambdas and functions it calls are not covered:
//   mark them too.
// SHADOWSENSE_ALWAYS_INLINE: inline, and always inlined where the compiler allows it.
#pragma once

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

#if defined(__GNUC__) || defined(__clang__)
#define SHADOWSENSE_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define SHADOWSENSE_ALWAYS_INLINE inline
#endif
