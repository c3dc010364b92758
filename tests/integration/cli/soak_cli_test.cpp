// `sitepose bench soak` as the short memory regression (issue 20): one
// back-and-forth pass of the backforth scenario (it ends where it starts)
// looped twice through the daemon's pipeline in mode full; RSS at the end
// within 10 % of RSS after the first loop (warm-up), no frame dropped, a CSV
// row per sample. (648 frames took 4 min on a heavily loaded 2-core machine:
// RSS +1.9 % after warm-up.)

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "sitepose/testing/command.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose {
namespace {

using testing::run_command;
using testing::TempDir;

TEST(BenchSoak, RssStaysFlatAfterWarmUpOnALoopedSequence) {
  TempDir dir("soak");
  const std::string exe = SITEPOSE_SITEPOSE_EXE;
  ASSERT_EQ(run_command(exe + " sim --scenario backforth --frames 216 --width 320 --height 180 --out " +
                        (dir / "seq") + " > " + (dir / "sim.txt") + " 2>&1"),
            0)
      << testing::read_text(dir / "sim.txt");
  const int status =
      run_command(exe + " bench soak --sequence " + (dir / "seq") +
                  " --frames 432 --sample-every 72 --warmup-frames 216 --max-rss-growth 10 --csv " +
                  (dir / "soak.csv") + " > " + (dir / "soak.txt") + " 2>&1");
  const std::string out = testing::read_text(dir / "soak.txt");
  EXPECT_EQ(status, 0) << out;
  const std::vector<std::string> rows = testing::read_lines(dir / "soak.csv");
  ASSERT_EQ(rows.size(), 7u) << out;  // header + a row every 72 frames
  EXPECT_EQ(rows[0], "frames,rss_mb,keyframes,map_points,drops,track_errors,latency_p99_ms");
  EXPECT_EQ(rows.back().rfind("432,", 0), 0u) << rows.back();
  for (std::size_t i = 1; i < rows.size(); ++i) {
    // drops: the fifth field; the source waits for the pipeline (lossless).
    std::size_t pos = 0;
    for (int field = 0; field < 4; ++field) pos = rows[i].find(',', pos) + 1;
    EXPECT_EQ(rows[i].substr(pos, rows[i].find(',', pos) - pos), "0") << rows[i];
  }
  RecordProperty("soak_output", out);
}

}  // namespace
}  // namespace sitepose
