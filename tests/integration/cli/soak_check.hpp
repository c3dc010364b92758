#pragma once
// `sitepose bench soak` as a memory regression (issue 20), shared by the CI
// test and its longer sweep: the backforth scenario's first pass (from
// standing), then its second pass (periodic: it ends where it starts)
// looped through the daemon's pipeline in mode full; RSS at the end within
// 10 % of RSS after the warm-up, the map no larger than after the warm-up
// (a strip driven again is tracked against its keyframes, issue 19) but for
// kSoakKeyframeSlack, no frame dropped, a CSV row per sample and the PNG
// beside it.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "sitepose/testing/command.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::testing {

// Keyframes the map may gain after the warm-up (seamless loops: 0 measured).
inline constexpr int kSoakKeyframeSlack = 3;

// A soak of `frames` frames sampled every `sample_every`, the RSS reference
// after `warmup_frames`; its output is recorded as the property
// soak_output.
inline void expect_flat_rss_soak(int frames, int sample_every, int warmup_frames) {
  TempDir dir("soak");
  const std::string exe = SITEPOSE_SITEPOSE_EXE;
  ASSERT_EQ(run_command(exe + " sim --scenario backforth --frames 432 --width 320 --height 180 --out " +
                        (dir / "seq") + " > " + (dir / "sim.txt") + " 2>&1"),
            0)
      << read_text(dir / "sim.txt");
  const int status =
      run_command(exe + " bench soak --sequence " + (dir / "seq") + " --loop-from 216 --frames " +
                  std::to_string(frames) + " --sample-every " + std::to_string(sample_every) +
                  " --warmup-frames " + std::to_string(warmup_frames) + " --max-rss-growth 10 --csv " +
                  (dir / "soak.csv") + " > " + (dir / "soak.txt") + " 2>&1");
  const std::string out = read_text(dir / "soak.txt");
  EXPECT_EQ(status, 0) << out;
  const std::vector<std::string> rows = read_lines(dir / "soak.csv");
  const std::size_t samples = static_cast<std::size_t>((frames + sample_every - 1) / sample_every);
  ASSERT_EQ(rows.size(), 1 + samples) << out;  // header + a row per sample
  EXPECT_EQ(rows[0], "frames,rss_mb,keyframes,map_points,drops,track_errors,latency_p99_ms");
  EXPECT_EQ(rows.back().rfind(std::to_string(frames) + ",", 0), 0u) << rows.back();
  auto field = [](const std::string& row, int index) {
    std::size_t pos = 0;
    for (int f = 0; f < index; ++f) pos = row.find(',', pos) + 1;
    return row.substr(pos, row.find(',', pos) - pos);
  };
  int warm_keyframes = -1;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    // drops: the fifth field; the source waits for the pipeline (lossless).
    EXPECT_EQ(field(rows[i], 4), "0") << rows[i];
    if (warm_keyframes < 0 && std::stoi(field(rows[i], 0)) >= warmup_frames) {
      warm_keyframes = std::stoi(field(rows[i], 2));
    }
  }
  ASSERT_GE(warm_keyframes, 0) << out;
  EXPECT_LE(std::stoi(field(rows.back(), 2)), warm_keyframes + kSoakKeyframeSlack)
      << "the map grows on a strip driven again\n"
      << out;
  EXPECT_EQ(read_text(dir / "soak.png").substr(0, 4), "\x89PNG");
  ::testing::Test::RecordProperty("soak_output", out);
}

}  // namespace sitepose::testing
