#include "sitepose/placerec/keyframe_database.hpp"

#include <gtest/gtest.h>

#include <map>

#include "descriptors.hpp"

namespace sitepose::placerec {
namespace {

using testing::flip_bits;
using testing::random_descriptors;

std::vector<map::Descriptor> rows_of(const cv::Mat& d) {
  std::vector<map::Descriptor> out;
  for (int r = 0; r < d.rows; ++r) out.push_back(map::descriptor_from_row(d, r));
  return out;
}

struct Fixture {
  std::vector<cv::Mat> keyframes;
  std::shared_ptr<const Vocabulary> vocabulary;
};

// 30 keyframes of 300 random descriptors each; the vocabulary is trained
// on other random images, so the keyframes' words are not its clusters.
Fixture make_fixture() {
  Fixture f;
  std::mt19937 rng(21);
  std::vector<cv::Mat> training;
  for (int i = 0; i < 20; ++i) training.push_back(random_descriptors(300, rng));
  auto v = Vocabulary::train(training);
  EXPECT_TRUE(v.has_value());
  f.vocabulary = std::make_shared<const Vocabulary>(std::move(*v));
  for (int i = 0; i < 30; ++i) f.keyframes.push_back(random_descriptors(300, rng));
  return f;
}

const auto kNoCovisibility = [](map::KeyFrameId, int) { return std::vector<map::KeyFrameId>{}; };

TEST(KeyFrameDatabase, AKeyFrameQueriedWithItsOwnDescriptorsComesFirst) {
  const Fixture f = make_fixture();
  KeyFrameDatabase db(f.vocabulary);
  for (int i = 0; i < 30; ++i) db.add(i, rows_of(f.keyframes[i]));
  EXPECT_EQ(db.size(), 30U);
  std::mt19937 rng(5);
  for (int i = 0; i < 30; ++i) {
    const std::vector<ScoredKeyFrame> exact = db.score(f.vocabulary->transform(f.keyframes[i]));
    const auto groups = group_candidates(exact, kNoCovisibility);
    ASSERT_FALSE(groups.empty());
    EXPECT_EQ(groups.front().keyframe, i);
    EXPECT_NEAR(groups.front().group_score, 1.0, 1e-9);
    // A second view: 3 bits of every descriptor flipped, a third of them gone.
    const cv::Mat noisy = flip_bits(f.keyframes[i].rowRange(0, 200), 3, rng);
    const auto noisy_groups = group_candidates(db.score(f.vocabulary->transform(noisy)), kNoCovisibility);
    ASSERT_FALSE(noisy_groups.empty());
    EXPECT_EQ(noisy_groups.front().keyframe, i);
  }
}

TEST(KeyFrameDatabase, AnErasedKeyFrameIsNeverReturnedAgain) {
  const Fixture f = make_fixture();
  KeyFrameDatabase db(f.vocabulary);
  for (int i = 0; i < 30; ++i) db.add(i, rows_of(f.keyframes[i]));
  db.erase(7);
  db.erase(7);  // twice: nothing left to erase
  EXPECT_EQ(db.size(), 29U);
  EXPECT_FALSE(db.contains(7));
  for (const ScoredKeyFrame& s : db.score(f.vocabulary->transform(f.keyframes[7]))) EXPECT_NE(s.keyframe, 7);
  db.add(7, rows_of(f.keyframes[8]));  // re-added with other words: the old ones are gone
  const auto groups = group_candidates(db.score(f.vocabulary->transform(f.keyframes[8])), kNoCovisibility);
  ASSERT_GE(groups.size(), 1U);
  EXPECT_NEAR(groups.front().group_score, 1.0, 1e-9);
  db.clear();
  EXPECT_EQ(db.size(), 0U);
  EXPECT_TRUE(db.score(f.vocabulary->transform(f.keyframes[8])).empty());
}

// ORB-SLAM2's grouping: a keyframe's covisible neighbours add their scores
// to its group and the group's best keyframe stands for it; groups under
// 0.75 of the best group are dropped.
TEST(KeyFrameDatabase, GroupsScoresOverCovisibleKeyFrames) {
  const std::vector<ScoredKeyFrame> scored{{1, 50, 0.30}, {2, 50, 0.20}, {3, 50, 0.25}, {4, 50, 0.10}};
  const std::map<map::KeyFrameId, std::vector<map::KeyFrameId>> covisible{
      {1, {}}, {2, {3}}, {3, {2}}, {4, {9}}};
  const auto groups = group_candidates(scored, [&](map::KeyFrameId id, int) { return covisible.at(id); });
  // Groups: 1 -> 0.30 (1); 2 -> 0.45 (best 3); 3 -> 0.45 (3); 4 -> 0.10.
  // Kept: > 0.75 x 0.45 = 0.3375, once each: 3 only.
  ASSERT_EQ(groups.size(), 1U);
  EXPECT_EQ(groups[0].keyframe, 3);
  EXPECT_NEAR(groups[0].group_score, 0.45, 1e-12);
}

TEST(KeyFrameDatabase, KeepsOnlyKeyFramesSharingEnoughWords) {
  const BowVector query{{1, 0.2}, {2, 0.2}, {3, 0.2}, {4, 0.2}, {5, 0.2}};
  std::mt19937 rng(1);
  std::vector<cv::Mat> training{random_descriptors(50, rng)};
  auto v = Vocabulary::train(training, VocabularyParams{4, 3, 10, 1});
  ASSERT_TRUE(v.has_value());
  KeyFrameDatabase db(std::make_shared<const Vocabulary>(std::move(*v)));
  db.add(10, BowVector{{1, 0.2}, {2, 0.2}, {3, 0.2}, {4, 0.2}, {5, 0.2}});  // 5 shared
  db.add(11, BowVector{{1, 0.25}, {2, 0.25}, {3, 0.25}, {4, 0.25}});        // 4 = 0.8 x 5: not more
  db.add(12, BowVector{{1, 0.5}, {9, 0.5}});                                // 1
  const std::vector<ScoredKeyFrame> scored = db.score(query);
  ASSERT_EQ(scored.size(), 1U);
  EXPECT_EQ(scored[0].keyframe, 10);
  EXPECT_EQ(scored[0].shared_words, 5);
  EXPECT_NEAR(scored[0].score, 1.0, 1e-12);
}

}  // namespace
}  // namespace sitepose::placerec
