// The GenICam feature file the Aravis source applies (feature_file.hpp):
// steps in order with their lines, comments and blank lines skipped, and
// what is refused, named by file and line. The shipped files parse.
#include "sitepose/drivers/aravis/feature_file.hpp"

#include <gtest/gtest.h>

#include <filesystem>

#include "sitepose/testing/files.hpp"

namespace sitepose::drivers::aravis {
namespace {

TEST(FeatureFile, StepsKeepTheirOrderValuesAndLines) {
  auto file = parse_feature_file(
      "# comment\n\nUserSetSelector=Default\n  UserSetLoad  \r\nExposureTime = 800.5 # us\nPtpEnable=true\n",
      "cam.features");
  ASSERT_TRUE(file) << file.error().message;
  EXPECT_EQ(file->path, "cam.features");
  ASSERT_EQ(file->steps.size(), 4u);
  EXPECT_EQ(file->steps[0].text(), "UserSetSelector=Default");
  EXPECT_EQ(file->steps[0].line, 3);
  EXPECT_FALSE(file->steps[1].value.has_value()) << "a command";
  EXPECT_EQ(file->steps[1].text(), "UserSetLoad");
  EXPECT_EQ(file->steps[2].name, "ExposureTime");
  EXPECT_EQ(file->steps[2].value, "800.5");
  EXPECT_EQ(file->steps[3].line, 6);
  auto empty = parse_feature_file("", "e");
  ASSERT_TRUE(empty);
  EXPECT_TRUE(empty->steps.empty());
}

TEST(FeatureFile, RefusesWhatTheCameraCouldNotReadNamingTheLine) {
  for (const auto& [text, line, why] :
       {std::tuple{"Gain=1\n2Gain=3\n", ":2:", "feature name"},
        std::tuple{"Gain=\n", ":1:", "value of one word"},
        std::tuple{"DeviceUserID=left cam\n", ":1:", "value of one word"},
        std::tuple{"DeviceUserID='x'\n", ":1:", "no spaces or quotes"},
        std::tuple{"=5\n", ":1:", "feature name"}, std::tuple{"A\nB C\n", ":2:", "feature name"}}) {
    auto file = parse_feature_file(text, "f.features");
    ASSERT_FALSE(file) << text;
    EXPECT_EQ(file.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(file.error().message.find(std::string("f.features") + line), std::string::npos)
        << file.error().message;
    EXPECT_NE(file.error().message.find(why), std::string::npos) << file.error().message;
  }
}

TEST(FeatureFile, ReadsAFileAndRefusesAbsentOnesAndFolders) {
  testing::TempDir dir;
  auto read = read_feature_file(dir.write("a.features", "Width=640\n"));
  ASSERT_TRUE(read) << read.error().message;
  EXPECT_EQ(read->steps.size(), 1u);
  auto absent = read_feature_file(dir / "none.features");
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().code, ErrorCode::kNotFound);
  auto folder = read_feature_file(dir.path().string());
  ASSERT_FALSE(folder);
  EXPECT_NE(folder.error().message.find("is a folder"), std::string::npos) << folder.error().message;
}

TEST(FeatureFile, TheShippedFilesParse) {
  int files = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(SITEPOSE_SOURCE_DIR "/firmware-config/genicam")) {
    if (entry.path().extension() != ".features") continue;
    auto file = read_feature_file(entry.path().string());
    ASSERT_TRUE(file) << file.error().message;
    EXPECT_FALSE(file->steps.empty()) << entry.path();
    ++files;
  }
  EXPECT_EQ(files, 3);
}

}  // namespace
}  // namespace sitepose::drivers::aravis
