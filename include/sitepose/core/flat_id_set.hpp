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

// One value per id: the ids in one array (what a lookup walks), the values
// in another of the same length.
template <typename Value>
class FlatIdTable {
 public:
  // Room for `expected` ids before the first growth.
  explicit FlatIdTable(std::size_t expected) {
    std::size_t capacity = 16;
    while (capacity < 2 * expected) capacity *= 2;  // load factor <= 1/2
    rehash(capacity);
  }

  // The id's value, value-initialised when the id is new; second: whether
  // it is new.
  std::pair<Value*, bool> try_emplace(std::int64_t id) {
    assert(id >= 0);
    if (2 * (size_ + 1) > ids_.size()) rehash(2 * ids_.size());
    const std::size_t i = slot_of(id);
    if (ids_[i] == id) return {&values_[i], false};
    ids_[i] = id;
    values_[i] = Value{};
    ++size_;
    return {&values_[i], true};
  }

  bool contains(std::int64_t id) const { return ids_[slot_of(id)] == id; }
  std::size_t size() const { return size_; }

  // f(id, value) for every id, in no particular order.
  template <typename F>
  void for_each(F&& f) const {
    for (std::size_t i = 0; i < ids_.size(); ++i) {
      if (ids_[i] != kEmptyId) f(ids_[i], values_[i]);
    }
  }

 private:
  static constexpr std::int64_t kEmptyId = -1;

  // The id's slot, or the empty one where it would go. Fibonacci hashing:
  // ids are consecutive integers, and the multiply spreads them over the
  // whole array instead of one run of slots.
  std::size_t slot_of(std::int64_t id) const {
    std::size_t i =
        static_cast<std::size_t>((static_cast<std::uint64_t>(id) * 0x9E3779B97F4A7C15ull) >> shift_);
    while (ids_[i] != kEmptyId && ids_[i] != id) i = (i + 1) & (ids_.size() - 1);
    return i;
  }

  void rehash(std::size_t capacity) {
    std::vector<std::int64_t> old_ids = std::move(ids_);
    std::vector<Value> old_values = std::move(values_);
    ids_.assign(capacity, kEmptyId);
    values_.assign(capacity, Value{});
    shift_ = 64;
    for (std::size_t c = capacity; c > 1; c /= 2) --shift_;
    for (std::size_t i = 0; i < old_ids.size(); ++i) {
      if (old_ids[i] != kEmptyId) {
        const std::size_t slot = slot_of(old_ids[i]);
        ids_[slot] = old_ids[i];
        values_[slot] = std::move(old_values[i]);
      }
    }
  }

  std::vector<std::int64_t> ids_;
  std::vector<Value> values_;
  int shift_ = 64;  // 64 - log2(capacity)
  std::size_t size_ = 0;
};

struct NoValue {};

}  // namespace detail

class FlatIdSet {
 public:
  explicit FlatIdSet(std::size_t expected = 0) : table_(expected) {}
  // Adds the id; true when it was not in the set yet.
  bool insert(std::int64_t id) { return table_.try_emplace(id).second; }
  bool contains(std::int64_t id) const { return table_.contains(id); }
  std::size_t size() const { return table_.size(); }

 private:
  detail::FlatIdTable<detail::NoValue> table_;
};

// How often each id was added.
class FlatIdCounter {
 public:
  explicit FlatIdCounter(std::size_t expected = 0) : table_(expected) {}
  void add(std::int64_t id, int n = 1) { *table_.try_emplace(id).first += n; }
  std::size_t size() const { return table_.size(); }
  // (id, count) of every id added, in no particular order.
  std::vector<std::pair<std::int64_t, int>> entries() const {
    std::vector<std::pair<std::int64_t, int>> out;
    out.reserve(table_.size());
    table_.for_each([&](std::int64_t id, int n) { out.emplace_back(id, n); });
    return out;
  }

 private:
  detail::FlatIdTable<int> table_;
};

}  // namespace sitepose
