#pragma once
// Sets and counters of non-negative 64-bit ids (map point and keyframe ids)
// for per-frame work over many ids with many repeats:
// - the tracker's local map visits every point of ~50 keyframes (about
//   100 000 slots, a few thousand distinct points): FlatIdSet;
// - the keyframes sharing a frame's points count every observation of
//   ~700 points (about 15 000, under a hundred distinct keyframes):
//   FlatIdCounter.
// Open addressing with linear probing in one array, so a lookup touches one
// or two cache lines and an insert allocates nothing until the table grows;
// std::unordered_set allocated a node per id and chased a pointer per
// lookup (2 of the 3.5 ms of the local-map listing on `parallel`, 960x540),
// std::map a node per keyframe and a tree walk per observation.
// Ids must be >= 0 (a negative id is the empty mark). Not thread-safe: one
// owner.

#include <cassert>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace sitepose {
namespace detail {

inline constexpr std::int64_t kEmptyId = -1;

// A power of two at least twice `expected` (load factor <= 1/2).
inline std::size_t flat_capacity_for(std::size_t expected) {
  std::size_t capacity = 16;
  while (capacity < 2 * expected) capacity *= 2;
  return capacity;
}

// log2 of a power of two.
inline int flat_bits(std::size_t capacity) {
  int bits = 0;
  while ((std::size_t{1} << bits) < capacity) ++bits;
  return bits;
}

// Fibonacci hashing onto `bits` bits: ids are consecutive integers, and the
// multiply spreads them over the whole array instead of one run of slots.
inline std::size_t flat_slot_of(std::int64_t id, int bits) {
  return static_cast<std::size_t>((static_cast<std::uint64_t>(id) * 0x9E3779B97F4A7C15ull) >> (64 - bits));
}

}  // namespace detail

class FlatIdSet {
 public:
  // Room for `expected` ids before the first growth.
  explicit FlatIdSet(std::size_t expected = 0) { rehash(detail::flat_capacity_for(expected)); }

  // Adds the id; true when it was not in the set yet.
  bool insert(std::int64_t id) {
    assert(id >= 0);
    if (2 * (size_ + 1) > slots_.size()) rehash(2 * slots_.size());
    std::size_t i = detail::flat_slot_of(id, bits_);
    while (slots_[i] != detail::kEmptyId) {
      if (slots_[i] == id) return false;
      i = (i + 1) & mask_;
    }
    slots_[i] = id;
    ++size_;
    return true;
  }

  bool contains(std::int64_t id) const {
    std::size_t i = detail::flat_slot_of(id, bits_);
    while (slots_[i] != detail::kEmptyId) {
      if (slots_[i] == id) return true;
      i = (i + 1) & mask_;
    }
    return false;
  }

  std::size_t size() const { return size_; }

 private:
  void rehash(std::size_t capacity) {
    std::vector<std::int64_t> old = std::move(slots_);
    slots_.assign(capacity, detail::kEmptyId);
    mask_ = capacity - 1;
    bits_ = detail::flat_bits(capacity);
    size_ = 0;
    for (std::int64_t id : old) {
      if (id != detail::kEmptyId) insert(id);
    }
  }

  std::vector<std::int64_t> slots_;
  std::size_t mask_ = 0;
  int bits_ = 0;
  std::size_t size_ = 0;
};

// How often each id was added; entries() in no particular order.
class FlatIdCounter {
 public:
  explicit FlatIdCounter(std::size_t expected = 0) { rehash(detail::flat_capacity_for(expected)); }

  void add(std::int64_t id, int n = 1) {
    assert(id >= 0);
    if (2 * (size_ + 1) > slots_.size()) rehash(2 * slots_.size());
    std::size_t i = detail::flat_slot_of(id, bits_);
    while (slots_[i].first != detail::kEmptyId) {
      if (slots_[i].first == id) {
        slots_[i].second += n;
        return;
      }
      i = (i + 1) & mask_;
    }
    slots_[i] = {id, n};
    ++size_;
  }

  std::size_t size() const { return size_; }

  // (id, count) of every id added.
  std::vector<std::pair<std::int64_t, int>> entries() const {
    std::vector<std::pair<std::int64_t, int>> out;
    out.reserve(size_);
    for (const auto& slot : slots_) {
      if (slot.first != detail::kEmptyId) out.push_back(slot);
    }
    return out;
  }

 private:
  void rehash(std::size_t capacity) {
    std::vector<std::pair<std::int64_t, int>> old = std::move(slots_);
    slots_.assign(capacity, {detail::kEmptyId, 0});
    mask_ = capacity - 1;
    bits_ = detail::flat_bits(capacity);
    size_ = 0;
    for (const auto& [id, n] : old) {
      if (id != detail::kEmptyId) add(id, n);
    }
  }

  std::vector<std::pair<std::int64_t, int>> slots_;
  std::size_t mask_ = 0;
  int bits_ = 0;
  std::size_t size_ = 0;
};

}  // namespace sitepose
