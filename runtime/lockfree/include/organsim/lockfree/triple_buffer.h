// Wait-free hand-off of the latest value from one writer thread to one reader
// thread: three slots, one being written, one being read, one in between.
// Neither side ever waits for the other, allocates or locks; the reader always
// gets the most recently published complete value (never a torn one).
#pragma once

#include <atomic>
#include <cstdint>
#include <type_traits>

namespace organsim::lockfree {

template <typename T>
class TripleBuffer {
 public:
  TripleBuffer() = default;
  explicit TripleBuffer(const T& initial) : slots_{initial, initial, initial} {}

  // --- writer side (one thread) ---
  /// The slot to fill; stays the writer's until publish().
  T& write_slot() noexcept { return slots_[back_]; }
  /// Makes the filled slot the latest value and takes the spare slot to write next.
  void publish() noexcept {
    const std::uint8_t previous =
        middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = previous & kIndex;
  }

  // --- reader side (one thread) ---
  /// Takes the latest published value if there is a newer one; returns whether
  /// it did. read() then refers to it.
  bool update() noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    const std::uint8_t previous = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = previous & kIndex;
    return true;
  }
  /// The value taken by the last update() (or the initial value).
  const T& read() const noexcept { return slots_[front_]; }

 private:
  static constexpr std::uint8_t kIndex = 0x3, kFresh = 0x4;
  T slots_[3]{};
  alignas(64) std::atomic<std::uint8_t> middle_{1};  // index of the in-between slot, plus the fresh bit
  alignas(64) std::uint8_t back_ = 2;                // writer's slot
  alignas(64) std::uint8_t front_ = 0;               // reader's slot
  static_assert(std::atomic<std::uint8_t>::is_always_lock_free, "the hand-off must be lock-free");
};

}  // namespace organsim::lockfree
