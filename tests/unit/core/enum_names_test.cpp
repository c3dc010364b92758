#include "sitepose/core/enum_names.hpp"

#include <gtest/gtest.h>

#include <string>

namespace sitepose {
namespace {

enum class Colour { kRed, kGreen, kBlue };

constexpr auto kColourNames =
    enum_names<Colour>({{Colour::kRed, "red"}, {Colour::kGreen, "green"}, {Colour::kBlue, "blue"}}, "none");

// What makes a table that misses an enumerator fail to compile.
static_assert(detail::enumerator_count<Colour>() == 3);
static_assert(std::string_view(kColourNames.name(Colour::kGreen)) == "green");

TEST(EnumNames, NamesEveryEnumeratorAndOtherValuesByTheFallback) {
  EXPECT_STREQ(kColourNames.name(Colour::kRed), "red");
  EXPECT_STREQ(kColourNames.name(Colour::kBlue), "blue");
  EXPECT_STREQ(kColourNames.name(static_cast<Colour>(7)), "none");
}

TEST(EnumNames, ParsesExactNamesOnly) {
  EXPECT_EQ(kColourNames.parse("blue"), Colour::kBlue);
  EXPECT_EQ(kColourNames.parse("red"), Colour::kRed);
  EXPECT_FALSE(kColourNames.parse("Blue").has_value());
  EXPECT_FALSE(kColourNames.parse("").has_value());
}

TEST(EnumNames, JoinsTheNamesInDeclarationOrder) {
  EXPECT_EQ(kColourNames.joined(", "), "red, green, blue");
  EXPECT_EQ(kColourNames.joined("|"), "red|green|blue");
}

}  // namespace
}  // namespace sitepose
