#include "sitepose/output/candump.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "sitepose/testing/files.hpp"

namespace sitepose::output {
namespace {

CanFrame platform_example_frame() {
  CanFrame f;
  f.id = 0x09F8011C;
  f.dlc = 8;
  f.data = {0x6A, 0x3C, 0x4B, 0x23, 0xD0, 0xF1, 0xC2, 0x04};
  return f;
}

TEST(Candump, FormatsThePlatformExample) {
  const auto line =
      format_candump_line({1'700'000'000'000'000'000LL, "can0", platform_example_frame()});
  ASSERT_TRUE(line.has_value());
  EXPECT_EQ(*line, "(1700000000.000000) can0 09F8011C#6A3C4B23D0F1C204");
}

TEST(Candump, FormatsMicrosecondsStandardIdsAndEmptyData) {
  CanFrame std_frame;
  std_frame.extended = false;
  std_frame.id = 0x123;
  std_frame.dlc = 2;
  std_frame.data[0] = 0xDE;
  std_frame.data[1] = 0xAD;
  // 999 ns below a microsecond are truncated, as candump prints them.
  EXPECT_EQ(*format_candump_line({1'000'001'999, "vcan1", std_frame}), "(1.000001) vcan1 123#DEAD");
  CanFrame empty;
  empty.id = 0x18FEF31C;
  EXPECT_EQ(*format_candump_line({5, "can0", empty}), "(0.000000) can0 18FEF31C#");
}

TEST(Candump, FormatRejectsBadRecords) {
  EXPECT_FALSE(format_candump_line({-1, "can0", platform_example_frame()}).has_value());
  EXPECT_FALSE(format_candump_line({0, "", platform_example_frame()}).has_value());
  EXPECT_FALSE(format_candump_line({0, "can 0", platform_example_frame()}).has_value());
  CanFrame wide = platform_example_frame();
  wide.extended = false;  // 0x09F8011C does not fit 11 bits
  EXPECT_FALSE(format_candump_line({0, "can0", wide}).has_value());
  CanFrame long_frame = platform_example_frame();
  long_frame.dlc = 9;
  EXPECT_FALSE(format_candump_line({0, "can0", long_frame}).has_value());
}

TEST(Candump, ParsesWhatItFormats) {
  const CandumpRecord r{1'700'000'123'456'789'000LL, "can0", platform_example_frame()};
  const auto parsed = parse_candump_line(*format_candump_line(r) + "\r\n");
  ASSERT_TRUE(parsed.has_value()) << parsed.error().message;
  EXPECT_EQ(*parsed, r);
  const auto std_frame = parse_candump_line("(12.500000) can1 7DF#0201");
  ASSERT_TRUE(std_frame.has_value());
  EXPECT_FALSE(std_frame->frame.extended);
  EXPECT_EQ(std_frame->frame.id, 0x7DFu);
  EXPECT_EQ(std_frame->frame.dlc, 2);
  EXPECT_EQ(std_frame->t_ns, 12'500'000'000LL);
  EXPECT_EQ(std_frame->interface, "can1");
  const auto lower = parse_candump_line("(0.000001) can0 09f8011c#6a3c");
  ASSERT_TRUE(lower.has_value());
  EXPECT_EQ(lower->frame.data[1], 0x3C);
}

TEST(Candump, ParseRejectsMalformedLinesSayingWhy) {
  const struct {
    const char* line;
    const char* why;
  } cases[] = {
      {"1700000000.000000 can0 09F8011C#00", "'('"},
      {"(1700000000.000000 can0 09F8011C#00", "')'"},
      {"(1700000000.0000 ) can0 09F8011C#00", "6 digits"},
      {"(1700000000.000000) can0", "interface"},
      {"(1700000000.000000) can0 09F8011C", "<id>#<data>"},
      {"(1700000000.000000) can0 9F8011C#00", "3 or 8 hex"},
      {"(1700000000.000000) can0 29F8011C#00", "width"},
      {"(1700000000.000000) can0 09F8011C##10011", "CAN FD"},
      {"(1700000000.000000) can0 09F8011C#R", "remote"},
      {"(1700000000.000000) can0 09F8011C#ABC", "2 hex digits"},
      {"(1700000000.000000) can0 09F8011C#000102030405060708", "0..8 bytes"},
      {"(1700000000.000000) can0 09F8011C#0G", "hexadecimal"},
  };
  for (const auto& c : cases) {
    const auto r = parse_candump_line(c.line);
    ASSERT_FALSE(r.has_value()) << c.line;
    EXPECT_EQ(r.error().code, ErrorCode::kParseError);
    EXPECT_NE(r.error().message.find(c.why), std::string::npos) << r.error().message;
  }
}

TEST(Candump, ReadsAFileAndNamesTheBadLine) {
  const sitepose::testing::TempDir tmp;
  const std::filesystem::path& dir = tmp.path();
  const std::string good = (dir / "good.log").string();
  {
    std::ofstream out(good);
    out << "(1700000000.000000) can0 09F8011C#6A3C4B23D0F1C204\n\n"
        << "(1700000000.100000) can0 18FEF31C#\n";
  }
  const auto records = read_candump_file(good);
  ASSERT_TRUE(records.has_value()) << records.error().message;
  ASSERT_EQ(records->size(), 2u);
  EXPECT_EQ((*records)[1].t_ns, 1'700'000'000'100'000'000LL);
  const std::string bad = (dir / "bad.log").string();
  {
    std::ofstream out(bad);
    out << "(1700000000.000000) can0 09F8011C#6A3C4B23D0F1C204\n"
        << "garbage\n";
  }
  const auto err = read_candump_file(bad);
  ASSERT_FALSE(err.has_value());
  EXPECT_NE(err.error().message.find(bad + ":2:"), std::string::npos) << err.error().message;
  const auto missing = read_candump_file((dir / "missing.log").string());
  ASSERT_FALSE(missing.has_value());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace sitepose::output
