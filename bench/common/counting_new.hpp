// counting_new.hpp: replaces the global operator new and delete of the binary that includes it
// with versions that count heap allocations, for the programs and tests that check "0
// allocations per frame after warm-up". The library is not changed for it.
//
//   std::size_t counting_new::count()
//     ensures: the number of operator new calls (every form: plain, array, aligned) made by any
//     thread of this binary so far.
//   volatile bool counting_new::measuring
//     set by the caller while it measures, so that a debugger can break on the allocations
//     made then; the count does not depend on it.
//
// Include this header in exactly ONE translation unit of a binary: it defines the replaceable
// global allocation functions. They take precedence over AddressSanitizer's replacements, and
// the memory still comes from its intercepted malloc, so sanitizer builds keep working.
// Threading: the count is atomic; count() may be called from any thread.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

namespace counting_new {

inline std::atomic<std::size_t> allocations{0};
inline volatile bool measuring = false;

inline std::size_t count() {
  return allocations.load(std::memory_order_relaxed);
}

// Out of line: once inlined into operator new, GCC pairs this malloc with the delete below and
// warns about a mismatch that is not there.
__attribute__((noinline)) inline void* allocate(std::size_t n) {
  allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
__attribute__((noinline)) inline void* allocate_aligned(std::size_t n, std::align_val_t a) {
  allocations.fetch_add(1, std::memory_order_relaxed);
  const auto al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (std::max<std::size_t>(n, 1) + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}

} // namespace counting_new

// For the rest of the including file: GCC inlines these and then pairs malloc with delete.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

void* operator new(std::size_t n) {
  return counting_new::allocate(n);
}
void* operator new[](std::size_t n) {
  return counting_new::allocate(n);
}
void* operator new(std::size_t n, std::align_val_t a) {
  return counting_new::allocate_aligned(n, a);
}
void* operator new[](std::size_t n, std::align_val_t a) {
  return counting_new::allocate_aligned(n, a);
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}
