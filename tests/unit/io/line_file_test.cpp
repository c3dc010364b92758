#include "sitepose/io/line_file.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "sitepose/testing/file_size_limit.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::io {
namespace {

using testing::TempDir;

using testing::read_text;

TEST(LineFile, TruncatesOrAppends) {
  TempDir dir;
  const std::string path = dir.write("log.txt", "old line\n");
  {
    auto file = LineFile::open(path, /*append=*/true);
    ASSERT_TRUE(file) << file.error().message;
    EXPECT_EQ(file->cut_at_open(), 0u);
    ASSERT_TRUE(file->write("a\nb\n"));
  }
  EXPECT_EQ(read_text(path), "old line\na\nb\n");
  {
    auto file = LineFile::open(path, /*append=*/false);
    ASSERT_TRUE(file) << file.error().message;
    ASSERT_TRUE(file->write("c\n"));
  }
  EXPECT_EQ(read_text(path), "c\n");
  auto missing = LineFile::open((dir / "no/such/dir/log.txt"), true);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kIoError);
  EXPECT_NE(missing.error().message.find("no/such/dir/log.txt: cannot open for writing"), std::string::npos)
      << missing.error().message;
}

// issue 20: a short write on a full disk stayed in the file and the next line
// was spliced onto it. Now the partial line is cut back and can be retried.
TEST(LineFile, ShortWriteOnAFullDiskIsCutBack) {
  TempDir dir;
  const std::string path = (dir / "traj.txt");
  auto file = LineFile::open(path, false);
  ASSERT_TRUE(file) << file.error().message;
  const std::string line = "0.100000000 1.0 2.0 3.0 0 0 0 1\n";  // 33 bytes
  {
    sitepose::testing::FileSizeLimit full(2 * line.size() + 10);  // room for 2 lines and 10 bytes
    ASSERT_TRUE(full.ok());
    ASSERT_TRUE(file->write(line));
    ASSERT_TRUE(file->write(line));
    const Status st = file->write(line);  // 10 bytes fit, then EFBIG
    ASSERT_FALSE(st);
    EXPECT_EQ(st.error().code, ErrorCode::kIoError);
    EXPECT_NE(st.error().message.find("cut off"), std::string::npos) << st.error().message;
    EXPECT_EQ(read_text(path), line + line);
    EXPECT_FALSE(file->write(line));  // still full: nothing written
    EXPECT_EQ(read_text(path), line + line);
  }
  ASSERT_TRUE(file->write(line));  // space returned: the same line again, whole
  ASSERT_TRUE(file->write("x\n"));
  EXPECT_EQ(read_text(path), line + line + line + "x\n");
}

TEST(LineFile, DevFullFailsWithTheErrnoText) {
  auto file = LineFile::open("/dev/full", false);
  ASSERT_TRUE(file) << file.error().message;
  const Status st = file->write("a\n");
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("/dev/full: write failed: No space left on device"), std::string::npos)
      << st.error().message;
}

TEST(LineFile, AppendCutsTheIncompleteLineOfACrash) {
  TempDir dir;
  const std::string path = dir.write("log.txt", "one\ntwo\nthr");
  {
    auto file = LineFile::open(path, true);
    ASSERT_TRUE(file) << file.error().message;
    EXPECT_EQ(file->cut_at_open(), 3u);
    ASSERT_TRUE(file->write("three\n"));
  }
  EXPECT_EQ(read_text(path), "one\ntwo\nthree\n");
  // Only a partial line: nothing whole to keep.
  const std::string partial = dir.write("partial.txt", "0.1 2 3");
  auto cut = LineFile::open(partial, true);
  ASSERT_TRUE(cut) << cut.error().message;
  EXPECT_EQ(cut->cut_at_open(), 7u);
  EXPECT_EQ(read_text(partial), "");
  // A file that is not lines (no line end in its last 4 KiB) is left alone.
  const std::string blob = dir.write("blob.bin", std::string(5000, 'x'));
  auto refused = LineFile::open(blob, true);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(read_text(blob).size(), 5000u);
}

}  // namespace
}  // namespace sitepose::io
