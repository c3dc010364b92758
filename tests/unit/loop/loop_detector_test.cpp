// Covisibility consistency of loop candidates (loop/loop_detector.hpp).

#include "sitepose/loop/loop_detector.hpp"

#include <gtest/gtest.h>

namespace sitepose::loop {
namespace {

CandidateGroup group(map::KeyFrameId candidate, std::set<map::KeyFrameId> neighbours) {
  neighbours.insert(candidate);
  return {candidate, neighbours};
}

TEST(LoopConsistency, NeedsTheSamePlaceOverThreeFurtherKeyFrames) {
  LoopConsistency consistency(3);
  // The candidate walks along the old trajectory with the new keyframes,
  // its group overlapping the previous one.
  EXPECT_TRUE(consistency.update({group(10, {9, 11})}).empty());                           // count 0
  EXPECT_TRUE(consistency.update({group(11, {10, 12})}).empty());                          // 1
  EXPECT_TRUE(consistency.update({group(12, {11, 13})}).empty());                          // 2
  EXPECT_EQ(consistency.update({group(13, {12, 14})}), std::vector<map::KeyFrameId>{13});  // 3
}

TEST(LoopConsistency, CandidatesThatJumpAroundAreNeverConsistent) {
  LoopConsistency consistency(3);
  for (map::KeyFrameId c : {10, 40, 70, 100, 130, 160}) {
    EXPECT_TRUE(consistency.update({group(c, {c - 1, c + 1})}).empty());
  }
}

TEST(LoopConsistency, AKeyFrameWithoutCandidatesBreaksTheChain) {
  LoopConsistency consistency(3);
  consistency.update({group(10, {11})});
  consistency.update({group(11, {12})});
  consistency.update({});
  EXPECT_EQ(consistency.groups(), 0U);
  EXPECT_TRUE(consistency.update({group(12, {13})}).empty());
  EXPECT_TRUE(consistency.update({group(13, {14})}).empty());
}

TEST(LoopConsistency, ResetForgetsEveryGroup) {
  LoopConsistency consistency(1);
  consistency.update({group(10, {11})});
  consistency.reset();
  EXPECT_TRUE(consistency.update({group(11, {12})}).empty());
  EXPECT_EQ(consistency.update({group(12, {13})}), std::vector<map::KeyFrameId>{12});
}

}  // namespace
}  // namespace sitepose::loop
