#include "sitepose/core/expected.hpp"

#include <gtest/gtest.h>

namespace sitepose {
namespace {

Expected<int> parse_positive(int x) {
  if (x <= 0) return make_error(ErrorCode::kInvalidArgument, "must be > 0");
  return x;
}

Expected<int> doubled(int x) {
  SITEPOSE_TRY(int v, parse_positive(x));
  return 2 * v;
}

TEST(Expected, ValueAndErrorPropagate) {
  EXPECT_EQ(*doubled(4), 8);
  const auto bad = doubled(-1);
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(bad.error().message, "must be > 0");
  EXPECT_EQ(bad.error().exit_status(), 2);
  EXPECT_EQ((Error{ErrorCode::kIoError, ""}.exit_status()), 1);
}

TEST(Expected, StatusDefaultsToOk) {
  Status s;
  EXPECT_TRUE(s.has_value());
  Status bad = make_error(ErrorCode::kNotFound, "x");
  EXPECT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace sitepose
