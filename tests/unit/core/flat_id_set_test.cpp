#include "sitepose/core/flat_id_set.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

namespace sitepose {
namespace {

// Ids as the map hands them out (consecutive, from 0) and scattered ones,
// with repeats, through several growths from the smallest table.
std::vector<std::int64_t> ids_with_repeats() {
  std::vector<std::int64_t> ids;
  for (std::int64_t id = 0; id < 3000; ++id) ids.push_back(id);
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<std::int64_t> any(0, std::int64_t{1} << 62);
  for (int i = 0; i < 2000; ++i) ids.push_back(any(rng));
  std::uniform_int_distribution<std::size_t> pick(0, ids.size() - 1);
  for (int i = 0; i < 5000; ++i) ids.push_back(ids[pick(rng)]);
  std::shuffle(ids.begin(), ids.end(), rng);
  return ids;
}

TEST(FlatIdSet, InsertSaysWhetherTheIdIsNewAsStdSetDoes) {
  FlatIdSet flat;
  std::set<std::int64_t> reference;
  for (std::int64_t id : ids_with_repeats()) {
    ASSERT_EQ(flat.insert(id), reference.insert(id).second) << id;
  }
  EXPECT_EQ(flat.size(), reference.size());
  for (std::int64_t id : reference) EXPECT_TRUE(flat.contains(id)) << id;
  for (std::int64_t id = 3000; id < 3100; ++id) EXPECT_EQ(flat.contains(id), reference.count(id) == 1) << id;
}

TEST(FlatIdSet, LargestIdAndZeroAreOrdinaryIds) {
  FlatIdSet flat(1);
  const std::int64_t largest = INT64_MAX;
  EXPECT_TRUE(flat.insert(0));
  EXPECT_TRUE(flat.insert(largest));
  EXPECT_FALSE(flat.insert(0));
  EXPECT_FALSE(flat.insert(largest));
  EXPECT_EQ(flat.size(), 2u);
}

TEST(FlatIdCounter, CountsAsStdMapDoes) {
  FlatIdCounter flat;
  std::map<std::int64_t, int> reference;
  for (std::int64_t id : ids_with_repeats()) {
    flat.add(id);
    ++reference[id];
  }
  flat.add(5, 10);
  reference[5] += 10;
  std::vector<std::pair<std::int64_t, int>> entries = flat.entries();
  std::sort(entries.begin(), entries.end());
  const std::vector<std::pair<std::int64_t, int>> expected(reference.begin(), reference.end());
  EXPECT_EQ(entries, expected);
  EXPECT_EQ(flat.size(), reference.size());
}

TEST(FlatIdCounter, EmptyCounterHasNoEntries) {
  const FlatIdCounter flat;
  EXPECT_TRUE(flat.entries().empty());
  EXPECT_EQ(flat.size(), 0u);
}

}  // namespace
}  // namespace sitepose
