#include "sitepose/eval/association.hpp"

#include <gtest/gtest.h>

namespace sitepose::eval {
namespace {

io::Trajectory stamps(std::initializer_list<double> ts) {
  io::Trajectory traj;
  for (const double t : ts) traj.push_back({t, SE3()});
  return traj;
}

TEST(Association, NearestWithinMaxDt) {
  const io::Trajectory gt = stamps({0.0, 0.1, 0.2, 0.3, 0.4});
  // 0.115 is 0.015 from 0.1 (kept); 0.25 is 0.05 from both (dropped);
  // 0.39 -> 0.4; 0.7 is beyond the end (dropped).
  const io::Trajectory est = stamps({0.001, 0.115, 0.25, 0.39, 0.7});
  const auto pairs = associate(gt, est, 0.02);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[0].gt_index, 0u);
  EXPECT_EQ(pairs[0].est_index, 0u);
  EXPECT_NEAR(pairs[0].dt_s, -0.001, 1e-12);
  EXPECT_EQ(pairs[1].gt_index, 1u);
  EXPECT_EQ(pairs[1].est_index, 1u);
  EXPECT_NEAR(pairs[1].dt_s, -0.015, 1e-12);
  EXPECT_EQ(pairs[2].gt_index, 4u);
  EXPECT_EQ(pairs[2].est_index, 3u);
  // A tighter gate drops the 0.015 s pair.
  EXPECT_EQ(associate(gt, est, 0.012).size(), 2u);
  // A looser one takes 0.25 too (to 0.2, the earlier of two equal distances).
  const auto loose = associate(gt, est, 0.06);
  ASSERT_EQ(loose.size(), 4u);
  EXPECT_EQ(loose[2].gt_index, 2u);
  EXPECT_EQ(loose[2].est_index, 2u);
}

TEST(Association, OneToOneKeepsTheCloserEstimate) {
  const io::Trajectory gt = stamps({1.0, 2.0});
  // Both 1.005 and 0.99 are nearest to 1.0; only the closer (1.005) pairs.
  const io::Trajectory est = stamps({0.99, 1.005, 2.0});
  const auto pairs = associate(gt, est, 0.02);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].gt_index, 0u);
  EXPECT_EQ(pairs[0].est_index, 1u);
  EXPECT_EQ(pairs[1].gt_index, 1u);
  EXPECT_EQ(pairs[1].est_index, 2u);
}

TEST(Association, TimeOffsetShiftsTheEstimateClock) {
  const io::Trajectory gt = stamps({10.0, 10.5, 11.0});
  const io::Trajectory est = stamps({9.7, 10.2, 10.7});
  EXPECT_TRUE(associate(gt, est, 0.02).empty());
  const auto pairs = associate(gt, est, 0.02, 0.3);
  ASSERT_EQ(pairs.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(pairs[k].gt_index, k);
    EXPECT_EQ(pairs[k].est_index, k);
    EXPECT_NEAR(pairs[k].dt_s, 0.0, 1e-9);
  }
}

TEST(Association, EmptyInputsGiveNoPairs) {
  EXPECT_TRUE(associate({}, stamps({1.0}), 0.02).empty());
  EXPECT_TRUE(associate(stamps({1.0}), {}, 0.02).empty());
}

TEST(Association, CheckTimestampsRejectsNonIncreasing) {
  EXPECT_TRUE(check_timestamps(stamps({0.0, 0.1, 0.2}), "gt").has_value());
  const Status st = check_timestamps(stamps({0.0, 0.2, 0.2}), "gt");
  ASSERT_FALSE(st.has_value());
  EXPECT_EQ(st.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(st.error().message.find("pose 2"), std::string::npos) << st.error().message;
  EXPECT_FALSE(check_timestamps(stamps({0.0, std::nan("")}), "est").has_value());
}

}  // namespace
}  // namespace sitepose::eval
