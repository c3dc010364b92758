// The network variant: two arv-fake-gv-camera-0.8 processes (GigE Vision
// over UDP, discovery by broadcast) in a network namespace of their own, and
// the stereo source grabbing from them by device id. Discovery broadcasts on
// every interface, so everything runs in a fresh namespace (a forked child:
// unshare(CLONE_NEWNET)); without the privilege for that the test is
// skipped with the reason.
#include <gtest/gtest.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>

#include "sitepose/drivers/aravis/aravis_camera.hpp"
#include "sitepose/drivers/aravis/aravis_source.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::drivers::aravis {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kNoNamespace = 77;
constexpr int kPairsWanted = 20;

pid_t spawn_fake_camera(const char* address, const char* serial) {
  const pid_t pid = fork();
  if (pid == 0) {
    execlp("arv-fake-gv-camera-0.8", "arv-fake-gv-camera-0.8", "-i", address, "-s", serial,
           static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

// Runs in the child, inside the new namespace; writes one summary line.
int grab_in_namespace(const std::string& calibration, const std::string& summary_path) {
  if (unshare(CLONE_NEWNET) != 0) return kNoNamespace;
  if (std::system("ip link set lo up && ip addr add 127.0.0.2/8 dev lo") != 0) return 3;
  const pid_t gv1 = spawn_fake_camera("127.0.0.1", "GV01");
  const pid_t gv2 = spawn_fake_camera("127.0.0.2", "GV02");
  AravisSourceOptions o;
  o.left_id = "Aravis-Fake-GV01";
  o.right_id = "Aravis-Fake-GV02";
  o.calibration = calibration;
  o.camera.trigger = TriggerMode::kSoftware;  // free-running fakes differ by whole periods
  o.camera.frame_rate_hz = 10.0;
  o.camera.roi = Roi{0, 0, 512, 512};
  o.pair_tolerance_ms = 20.0;
  o.wait_for_camera_s = 10.0;  // the camera processes are starting
  std::ofstream summary(summary_path);
  int status = 0;
  {
    auto source = AravisSource::open(o, aravis_camera_opener());
    if (!source) {
      summary << "open: " << source.error().message << "\n";
      status = 4;
    } else {
      int pairs = 0;
      const Clock::time_point give_up = Clock::now() + std::chrono::seconds(20);
      while (pairs < kPairsWanted && Clock::now() < give_up) {
        auto event = (*source)->next({}, Clock::now() + std::chrono::seconds(1));
        if (!event) {
          summary << "next: " << event.error().message << "\n";
          break;
        }
        if (event->kind == pipeline::SourceEventKind::kFrame) ++pairs;
      }
      const AravisSourceStats s = (*source)->stats();
      summary << "pairs " << pairs << " unpaired " << s.pairing.unpaired_left + s.pairing.unpaired_right
              << " skipped_at_start " << s.pairing.skipped_at_start << " failed_buffers " << s.failed_buffers
              << " disconnects " << s.disconnects << "\n";
      status = pairs == kPairsWanted ? 0 : 5;
    }
  }
  kill(gv1, SIGTERM);
  kill(gv2, SIGTERM);
  waitpid(gv1, nullptr, 0);
  waitpid(gv2, nullptr, 0);
  return status;
}

TEST(AravisGigE, TwoFakeGvCamerasInANetworkNamespaceArePaired) {
  testing::TempDir dir("aravis-gige");
  const std::string calibration = dir.write("calib.txt",
                                            "P0: 400 0 256 0 0 400 256 0 0 0 1 0\n"
                                            "P1: 400 0 256 -48 0 400 256 0 0 0 1 0\n");
  const std::string summary = dir / "summary.txt";
  std::fflush(nullptr);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(grab_in_namespace(calibration, summary));
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  if (WEXITSTATUS(status) == kNoNamespace) {
    GTEST_SKIP() << "unshare(CLONE_NEWNET) not permitted here (needs root or CAP_SYS_ADMIN): the GigE fake "
                    "cameras need a network namespace of their own";
  }
  const std::string text = testing::read_text(summary);
  std::printf("[figures] GigE fake pair in a network namespace: %s", text.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 0) << text;
  // Free-running GigE cameras start apart (a camera not found at once is
  // retried after 0.25 s): a frame or two of the first may find no partner.
  // What must hold: every pair is made and no buffer fails.
  unsigned pairs = 0, unpaired = 0, skipped = 0, failed = 0;
  ASSERT_EQ(std::sscanf(text.c_str(), "pairs %u unpaired %u skipped_at_start %u failed_buffers %u", &pairs,
                        &unpaired, &skipped, &failed),
            4)
      << text;
  EXPECT_EQ(pairs, 20u) << text;
  EXPECT_LE(unpaired, 4u) << text;
  EXPECT_EQ(failed, 0u) << text;
}

}  // namespace
}  // namespace sitepose::drivers::aravis
