#pragma once
// SpscQueue: a lock-free ring buffer from exactly one producer thread to
// exactly one consumer thread, for handing samples off the haptic loop (to a
// logger, a monitor) without locks or allocation on either side.
//
// Capacity: the caller's request rounded up to a power of two, so that an
// index is a mask instead of a division; capacity() reports the rounded
// value and every slot is usable. The storage is allocated once, in the
// constructor. A full queue refuses the push (try_push returns false): the
// producer is real-time and must never wait, so it counts the drop instead.
//
// Ordering: the producer publishes an element with a release store of the
// tail after writing the slot; the consumer's acquire load of the tail makes
// the slot visible before it reads it, and its release store of the head
// hands the slot back to the producer. Head and tail live on separate cache
// lines, each next to the owner's cached copy of the other index, so the two
// threads do not false-share.
//
// Not copyable or movable: both threads hold references to it.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace hapticlab {

template <typename T>
class SpscQueue {
  static_assert(std::is_trivially_copyable_v<T>,
                "SpscQueue<T>: T must be trivially copyable (copied without locks, never destroyed)");
  static_assert(std::is_default_constructible_v<T>, "SpscQueue<T>: T must be default constructible");

 public:
  // Largest request accepted: keeps the rounded capacity a valid power of two.
  static constexpr std::size_t kMaxCapacity = std::size_t{1} << 30;

  // `capacity` in [1, kMaxCapacity]; otherwise throws std::invalid_argument.
  explicit SpscQueue(std::size_t capacity)
      : capacity_(round_up_to_power_of_two(capacity)),
        mask_(capacity_ - 1),
        slots_(std::make_unique<T[]>(capacity_)) {}
  SpscQueue(const SpscQueue&) = delete;
  SpscQueue& operator=(const SpscQueue&) = delete;

  // Producer thread. False when full (the element is not stored).
  bool try_push(const T& value) noexcept {
    const std::size_t tail = producer_.tail.load(std::memory_order_relaxed);
    if (tail - producer_.cached_head == capacity_) {
      producer_.cached_head = consumer_.head.load(std::memory_order_acquire);
      if (tail - producer_.cached_head == capacity_) return false;
    }
    slots_[tail & mask_] = value;
    producer_.tail.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer thread. False when empty (`out` unchanged).
  bool try_pop(T& out) noexcept { return pop_bulk(&out, 1) == 1; }

  // Consumer thread. Pops up to `max` elements into out[0..), oldest first;
  // returns how many.
  std::size_t pop_bulk(T* out, std::size_t max) noexcept {
    const std::size_t head = consumer_.head.load(std::memory_order_relaxed);
    std::size_t available = consumer_.cached_tail - head;
    if (available < max) {
      consumer_.cached_tail = producer_.tail.load(std::memory_order_acquire);
      available = consumer_.cached_tail - head;
    }
    const std::size_t n = available < max ? available : max;
    for (std::size_t k = 0; k < n; ++k) out[k] = slots_[(head + k) & mask_];
    if (n > 0) consumer_.head.store(head + n, std::memory_order_release);
    return n;
  }

  std::size_t capacity() const noexcept { return capacity_; }

  // Any thread. Exact when neither side is active; otherwise a snapshot that
  // may be stale by the operations in flight.
  std::size_t size_approx() const noexcept {
    const std::size_t head = consumer_.head.load(std::memory_order_acquire);
    const std::size_t tail = producer_.tail.load(std::memory_order_acquire);
    // Read in this order the tail is never behind the head; guard anyway.
    return tail >= head ? tail - head : 0;
  }

 private:
  // A cache line on the x86-64 and ARM64 machines we run on. A literal, not
  // std::hardware_destructive_interference_size, whose value GCC warns may
  // change between compiler versions (it would change this class's layout).
  static constexpr std::size_t kCacheLine = 64;

  static std::size_t round_up_to_power_of_two(std::size_t requested) {
    if (requested == 0 || requested > kMaxCapacity) {
      throw std::invalid_argument("SpscQueue(): capacity is " + std::to_string(requested) +
                                  ", but must be >= 1 and <= " + std::to_string(kMaxCapacity));
    }
    std::size_t capacity = 1;
    while (capacity < requested) capacity <<= 1;
    return capacity;
  }

  // Indices count pushes and pops since construction; they wrap modulo
  // 2^64, and the differences stay exact because capacity divides 2^64.
  struct alignas(kCacheLine) ProducerSide {
    std::atomic<std::size_t> tail{0};
    std::size_t cached_head = 0;  // producer's last view of head
  };
  struct alignas(kCacheLine) ConsumerSide {
    std::atomic<std::size_t> head{0};
    std::size_t cached_tail = 0;  // consumer's last view of tail
  };

  const std::size_t capacity_;
  const std::size_t mask_;
  const std::unique_ptr<T[]> slots_;
  ProducerSide producer_;
  ConsumerSide consumer_;
};

}  // namespace hapticlab
