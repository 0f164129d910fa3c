#pragma once
// Hands settings from a control thread (operator, slider window, study runner)
// to the real-time thread without locks on the real-time side: a triple
// buffer. The writer fills a spare slot and publishes it with one atomic
// exchange; the reader picks up the newest published slot between two
// updates. The reader never waits and never sees a half-written value.

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>
#include <type_traits>

namespace hapticlab {

template <typename T>
class TripleBuffer {
  static_assert(std::is_trivially_copyable_v<T>, "copied on the real-time thread");

 public:
  explicit TripleBuffer(const T& initial) : slots_{initial, initial, initial} {}

  // Any thread; writers are serialized among themselves.
  void publish(const T& value) {
    std::lock_guard<std::mutex> lock(writer_mutex_);
    slots_[back_] = value;
    back_ = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel) & kIndexMask;
  }

  // Reader thread only. Returns true if a newer value was taken; `current()`
  // then refers to it.
  bool take() noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndexMask;
    return true;
  }
  const T& current() const noexcept { return slots_[front_]; }

 private:
  static constexpr std::uint8_t kFresh = 0x4;
  static constexpr std::uint8_t kIndexMask = 0x3;
  std::array<T, 3> slots_;
  std::uint8_t front_ = 0;                    // reader-owned
  std::atomic<std::uint8_t> middle_{1};       // shared
  std::uint8_t back_ = 2;                     // writer-owned
  std::mutex writer_mutex_;
};

}  // namespace hapticlab
