// A fixed-capacity ring between one writer thread and one reader thread,
// wait-free on both sides: the writer never blocks (a record that finds the
// ring full is dropped and counted), the reader takes records in order. Sized
// once at construction; push() and take() allocate nothing.
#pragma once

#include <atomic>
#include <cstddef>
#include <vector>

namespace organsim::lockfree {

template <typename Record>
class SpscRing {
 public:
  explicit SpscRing(std::size_t capacity = 0) : records_(capacity) {}
  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  /// Sizes the ring to `capacity` records, empty; before either side runs.
  void allocate(std::size_t capacity) {
    records_.assign(capacity, Record{});
    head_.store(0, std::memory_order_relaxed);
    tail_.store(0, std::memory_order_relaxed);
    dropped_.store(0, std::memory_order_relaxed);
  }
  std::size_t capacity() const noexcept { return records_.size(); }
  /// The writer's side: false (and counted) when the ring is full or has no room at all.
  bool push(const Record& record) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (records_.empty() || head - tail_.load(std::memory_order_acquire) == records_.size()) {
      dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      return false;
    }
    records_[head % records_.size()] = record;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }
  /// Records held: pushed and not yet taken.
  std::size_t size() const noexcept {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_relaxed);
  }
  /// The reader's side: the i-th oldest record held, i < size(), left in place.
  const Record& peek(std::size_t i) const noexcept {
    return records_[(tail_.load(std::memory_order_relaxed) + i) % records_.size()];
  }
  /// The reader's side: moves the oldest record into `out`; false when none is held.
  bool take(Record& out) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    out = records_[tail % records_.size()];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }
  /// Records that found the ring full.
  std::size_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  // C++17's allocator honours over-aligned records (Eigen's fixed-size vectors) by itself.
  std::vector<Record> records_;
  std::atomic<std::size_t> head_{0}, tail_{0}, dropped_{0};
};

}  // namespace organsim::lockfree
