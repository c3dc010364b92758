#include "sitepose/core/echo.hpp"

#include <gtest/gtest.h>

namespace sitepose {
namespace {

TEST(EchoValue, ShortValuesAsTheyAre) {
  EXPECT_EQ(echo_value(""), "");
  EXPECT_EQ(echo_value("fullest"), "fullest");
  EXPECT_EQ(echo_value(std::string(kMaxEchoChars, 'x')), std::string(kMaxEchoChars, 'x'));
}

TEST(EchoValue, LongValuesCutAndControlCharactersEscaped) {
  EXPECT_EQ(echo_value(std::string(10'000'000, 'x')), std::string(kMaxEchoChars, 'x') + "... (10000000 bytes)");
  EXPECT_EQ(echo_value("a\nb\tc\x01"), "a\\nb\\tc\\x01");
  EXPECT_EQ(echo_value("root:x:0:0\nuser:x:1000", 12), "root:x:0:0\\n... (22 bytes)");
}

}  // namespace
}  // namespace sitepose
