#include "sitepose/eval/evaluate.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>

#include <fmt/format.h>

#include "test_trajectories.hpp"

namespace sitepose::eval {
namespace {

using testing::curvy_trajectory;
using testing::some_rigid_transform;
using testing::sparse_estimate;
using testing::transformed;

TEST(Evaluate, CoverageCountsAndStats) {
  const io::Trajectory gt = curvy_trajectory(200, 10.0);
  const io::Trajectory est = sparse_estimate(gt);
  const auto r = evaluate(gt, est, EvalOptions{});
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_EQ(r->gt_frames, 200u);
  EXPECT_EQ(r->est_poses, 150u);
  EXPECT_EQ(r->associated, 150u);
  EXPECT_DOUBLE_EQ(r->coverage, 0.75);
  EXPECT_FALSE(r->time_offset_searched);
  // Errors are 0 or 0.1 m along the camera x axis before alignment, in
  // about equal numbers; the alignment takes out their mean, leaving about
  // +-0.05 m (the camera yaws, so the bumps do not all point one way and a
  // little more remains).
  EXPECT_NEAR(r->ate_m.rmse, 0.05, 0.005);
  EXPECT_GT(r->ate_m.max, 0.05);
  EXPECT_LT(r->ate_m.max, 0.1);
  EXPECT_EQ(r->poses.size(), 150u);
  EXPECT_EQ(r->ate_m.count, 150u);
  // RPE 1 s: pairs exist only in the fully sampled second half and across.
  EXPECT_GT(r->rpe_time.translation_m.count, 50u);
  EXPECT_GT(r->rpe_frames.translation_m.count, 50u);
  EXPECT_NEAR(r->rpe_time.translation_m.max, 0.1, 1e-6);  // bump on one end only
}

TEST(Evaluate, ErrorsNameTheProblem) {
  const io::Trajectory gt = curvy_trajectory(50, 10.0);
  const auto empty_est = evaluate(gt, {}, EvalOptions{});
  ASSERT_FALSE(empty_est.has_value());
  EXPECT_NE(empty_est.error().message.find("estimated trajectory is empty"), std::string::npos);
  EXPECT_EQ(empty_est.error().exit_status(), 2);
  EXPECT_FALSE(evaluate({}, gt, EvalOptions{}).has_value());

  io::Trajectory far = gt;
  for (auto& p : far) p.t_s += 1000.0;
  const auto none = evaluate(gt, far, EvalOptions{});
  ASSERT_FALSE(none.has_value());
  EXPECT_EQ(none.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(none.error().message.find("only 0 estimated poses associate"), std::string::npos)
      << none.error().message;

  EvalOptions bad;
  bad.max_dt_s = 0.0;
  const auto bad_dt = evaluate(gt, gt, bad);
  ASSERT_FALSE(bad_dt.has_value());
  EXPECT_NE(bad_dt.error().message.find("max_dt_s"), std::string::npos);
}

TEST(Evaluate, JsonCarriesTheFigures) {
  const io::Trajectory gt = curvy_trajectory(200, 10.0);
  const auto r = evaluate(gt, sparse_estimate(gt), EvalOptions{});
  ASSERT_TRUE(r.has_value());
  const auto json = nlohmann::json::parse(to_json(*r));
  EXPECT_EQ(json.at("gt_frames").get<int>(), 200);
  EXPECT_EQ(json.at("associated").get<int>(), 150);
  EXPECT_DOUBLE_EQ(json.at("coverage").get<double>(), 0.75);
  EXPECT_FALSE(json.at("time_offset_searched").get<bool>());
  EXPECT_NEAR(json.at("ate_m").at("rmse").get<double>(), r->ate_m.rmse, 1e-8 * r->ate_m.rmse);
  EXPECT_FALSE(json.contains("poses"));
  const auto with_poses = nlohmann::json::parse(to_json(*r, true));
  ASSERT_EQ(with_poses.at("poses").size(), 150u);
  EXPECT_EQ(with_poses.at("poses").back().at("est_index").get<int>(), 149);
}

TEST(Evaluate, JsonWritesNullForMissingRpe) {
  // 5 poses over 0.4 s: no 1 s or 10-frame pairs.
  const io::Trajectory gt = curvy_trajectory(5, 10.0);
  const auto r = evaluate(gt, gt, EvalOptions{});
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->rpe_time.translation_m.count, 0u);
  const std::string text = to_json(*r);
  EXPECT_EQ(text.find("nan"), std::string::npos) << text;
  const auto json = nlohmann::json::parse(text);
  EXPECT_EQ(json.at("rpe_time").at("pairs").get<int>(), 0);
  EXPECT_TRUE(json.at("rpe_time").at("translation_m").at("rmse").is_null()) << text;
  EXPECT_NE(to_text(*r).find("ATE [m]"), std::string::npos);
}

}  // namespace
}  // namespace sitepose::eval
