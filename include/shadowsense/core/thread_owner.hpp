// A cheap check that one instance of a stateful type is not used from two threads at once.
//
// WHAT THIS IS
//   Most stateful library types (Segmenter, Classifier, Tracker, ...) follow the contract
//   "one instance per thread": different instances may run in different threads at the same
//   time, one instance must not. Sharing one silently corrupts its scratch buffers (issue 11:
//   a shared Segmenter segfaulted, a shared Classifier returned wrong probabilities). A
//   ThreadOwner turns that misuse into a clear error instead:
//
//     class Segmenter {
//       mutable ThreadOwner owner_;
//       void segment(...) {
//         const auto guard = owner_.enter("Segmenter");   // first line of each entry point
//         ...
//       }
//     };
//
//   enter() atomically records the calling thread as the owner and the returned guard clears
//   it when the call ends. A second thread entering while the first is inside fails with
//   ConcurrentUseError("Segmenter: one instance is used from two threads at once; ...").
//   Nested entry from the owning thread (an entry point calling another) is allowed.
//   Cost: one compare-exchange and one store per call (no lock, no allocation).
//   It detects overlapping calls only; calls from different threads that never overlap (the
//   instance handed from one thread to another with proper synchronisation) are fine.
//   Detection is best effort for overlaps: the thread that enters second reports it; the
//   first continues. Defining SHADOWSENSE_NO_THREAD_CHECK (before including the library)
//   compiles the check out entirely.
//
// API
//   ThreadOwner()                unowned. Copying or moving a ThreadOwner gives an unowned
//                                one (a copied object is a new instance with its own owner).
//   Guard enter(const char* type_name)
//     requires: type_name is a string literal (kept by pointer for the message).
//     ensures:  the calling thread owns the instance until the guard is destroyed.
//     throws:   ConcurrentUseError naming type_name if another thread is inside.
//   bool owned() const           true while some thread is inside (for tests).
//
// THREADING
//   ThreadOwner itself is internally synchronised (atomic); that is its purpose.
#pragma once

#include <shadowsense/core/error.hpp>

#include <atomic>
#include <cstdint>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

class ThreadOwner {
public:
  class [[nodiscard]] Guard {
  public:
    Guard(const Guard&) = delete;
    Guard& operator=(const Guard&) = delete;
    Guard(Guard&& o) noexcept : owner_(o.owner_) { o.owner_ = nullptr; }
    Guard& operator=(Guard&&) = delete;
    ~Guard() {
      if (owner_ != nullptr) owner_->store(0, std::memory_order_release);
    }

  private:
    friend class ThreadOwner;
    explicit Guard(std::atomic<std::uintptr_t>* owner) : owner_(owner) {}
    std::atomic<std::uintptr_t>* owner_; // null: nothing to release (nested or disabled)
  };

  ThreadOwner() = default;
  ThreadOwner(const ThreadOwner&) noexcept {}
  ThreadOwner& operator=(const ThreadOwner&) noexcept { return *this; }

  Guard enter([[maybe_unused]] const char* type_name) {
#ifdef SHADOWSENSE_NO_THREAD_CHECK
    return Guard(nullptr);
#else
    const std::uintptr_t me = this_thread_tag();
    std::uintptr_t expected = 0;
    if (owner_.compare_exchange_strong(expected, me, std::memory_order_acquire,
                                       std::memory_order_relaxed))
      return Guard(&owner_);
    if (expected == me) return Guard(nullptr); // nested call from the owning thread
    SHADOWSENSE_THROW(ConcurrentUseError(
        std::string(type_name) +
        ": one instance is used from two threads at once; this type is not internally "
        "synchronised: give each thread its own instance (or serialise the calls)"));
#endif
  }

  bool owned() const {
    return owner_.load(std::memory_order_acquire) != 0;
  }

private:
  // A non-zero value unique to each live thread: the address of a thread_local.
  static std::uintptr_t this_thread_tag() {
    static thread_local char tag = 0;
    return reinterpret_cast<std::uintptr_t>(&tag);
  }

  std::atomic<std::uintptr_t> owner_{0};
};

SHADOWSENSE_NAMESPACE_END
