// A cheap check that one instance of a stateful type is not used from two threads at once.
//
// OwnerCheck is a member of Segmenter, ContactTracker, TouchStateMachine and TouchPipeline. Every
// mutating entry point holds an OwnerCheck::Scope for its duration: the first scope records the
// calling thread (one atomic compare-exchange), nested scopes on the same thread pass, and a
// scope opened from another thread while the first is still open throws InvalidArgument naming
// the type ("... used from two threads at once; use one instance per thread"). Sequential use
// from different threads (hand-over with proper synchronisation) is allowed.
//
// Cost: two atomic operations per call. Builds that define SHADOWSENSE_NO_THREAD_CHECK compile
// the check out (Scope does nothing); it is on in every other build, release included.
//
// Copying or moving an OwnerCheck gives a fresh, unowned check (the owner is per instance).
#pragma once

#include <shadowsense/core/error.hpp>

#include <atomic>
#include <string>
#include <thread>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

class OwnerCheck {
public:
  OwnerCheck() = default;
  OwnerCheck(const OwnerCheck&) noexcept {}
  OwnerCheck& operator=(const OwnerCheck&) noexcept { return *this; }

  // Holds the instance for the current thread until destroyed. Throws InvalidArgument when
  // another thread holds it. `type` names the class in the message.
  class Scope {
  public:
    Scope(OwnerCheck& c, const char* type) {
#ifndef SHADOWSENSE_NO_THREAD_CHECK
      const std::thread::id me = std::this_thread::get_id();
      std::thread::id expected{};
      if (c.owner_.compare_exchange_strong(expected, me, std::memory_order_acquire)) {
        check_ = &c;
      } else if (expected != me) {
        throw InvalidArgument(std::string(type) +
                              ": used from two threads at once; this type is not thread-safe, "
                              "use one instance per thread");
      }
#else
      (void)c;
      (void)type;
#endif
    }
    ~Scope() {
      if (check_) check_->owner_.store(std::thread::id{}, std::memory_order_release);
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

  private:
    OwnerCheck* check_ = nullptr;
  };

private:
  std::atomic<std::thread::id> owner_{};
};

} // namespace detail
SHADOWSENSE_NAMESPACE_END
