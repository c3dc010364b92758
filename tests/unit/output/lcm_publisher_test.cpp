#include "sitepose/output/lcm_publisher.hpp"

#include <vector>

#include <gtest/gtest.h>

#include "sitepose/output/lcm_gnss_subscriber.hpp"

namespace sitepose::output {
namespace {

PoseEstimate pose_at(std::int64_t seq) {
  PoseEstimate p;
  p.seq = seq;
  p.t_ns = 1'000'000'000 + seq * 100'000'000;
  p.T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * seq, 0, 0));
  p.state = TrackingState::kOk;
  return p;
}

// Collects raw messages of one channel from a shared lcm::LCM.
struct Collector {
  std::vector<sitepose::pose_t> poses;
  std::vector<sitepose::health_t> health;
  void on_pose(const lcm::ReceiveBuffer* b, const std::string&, const sitepose::pose_t* m) {
    (void)b;
    poses.push_back(*m);
  }
  void on_health(const lcm::ReceiveBuffer*, const std::string&, const sitepose::health_t* m) {
    health.push_back(*m);
  }
};

void drain(lcm::LCM& lcm) {
  while (lcm.handleTimeout(0) > 0) {
  }
}

TEST(LcmOptions, ValidateNamesTheKey) {
  LcmOptions o;
  EXPECT_TRUE(o.validate().has_value());
  o.health_channel = "SITEPOSE_POSE";
  auto same = o.validate("output.lcm");
  ASSERT_FALSE(same.has_value());
  EXPECT_NE(same.error().message.find("output.lcm:"), std::string::npos);
  o = LcmOptions{};
  o.max_send_attempts = 0;
  auto attempts = o.validate();
  ASSERT_FALSE(attempts.has_value());
  EXPECT_NE(attempts.error().message.find("lcm.max_send_attempts = 0"), std::string::npos);
  o = LcmOptions{};
  o.pose_channel = "";
  EXPECT_FALSE(o.validate().has_value());
  EXPECT_FALSE(open_lcm("nosuchprovider://x").has_value());
}

TEST(LcmPublisher, PosesAndHealthArriveOverMemq) {
  auto lcm = open_lcm("memq://");
  ASSERT_TRUE(lcm.has_value()) << lcm.error().message;
  LcmOptions options;
  options.pose_channel = "TEST_POSE";
  options.health_channel = "TEST_HEALTH";
  Collector collector;
  (*lcm)->subscribe("TEST_POSE", &Collector::on_pose, &collector);
  (*lcm)->subscribe("TEST_HEALTH", &Collector::on_health, &collector);
  auto publisher = LcmPublisher::create(options, *lcm);
  ASSERT_TRUE(publisher.has_value()) << publisher.error().message;
  for (int i = 0; i < 20; ++i) {
    ASSERT_TRUE((*publisher)->publish_pose(pose_at(i), nullptr).has_value());
  }
  LcmHealth health;
  health.fps = 30.0;
  health.stages = {{"track", 1, 0, 20.0, 40.0}};
  ASSERT_TRUE((*publisher)->publish_health(health).has_value());
  drain(**lcm);
  ASSERT_EQ(collector.poses.size(), 20u);
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(collector.poses[i].seq, i);
    EXPECT_EQ(collector.poses[i].utime, pose_at(i).t_ns / 1000);
    EXPECT_DOUBLE_EQ(collector.poses[i].position[0], 0.1 * i);
  }
  ASSERT_EQ(collector.health.size(), 1u);
  EXPECT_EQ(collector.health[0].stage_names.at(0), "track");
  const LcmPublisherStats s = (*publisher)->stats();
  EXPECT_EQ(s.poses_published, 20);
  EXPECT_EQ(s.health_published, 1);
  EXPECT_EQ(s.send_failures, 0);
}

TEST(LcmPublisher, SendFailuresAreCountedRetriedAndBounded) {
  int calls = 0;
  int fail_next = 0;
  std::vector<std::string> channels;
  auto publisher = LcmPublisher::create_with_sender(
      LcmOptions{}, [&](const std::string& channel, const void*, unsigned size) {
        ++calls;
        EXPECT_GT(size, 0u);
        if (fail_next > 0) {
          --fail_next;
          return -1;
        }
        channels.push_back(channel);
        return 0;
      });
  ASSERT_TRUE(publisher.has_value());
  LcmPublisher& p = **publisher;

  fail_next = 2;  // two failures, third attempt succeeds
  EXPECT_TRUE(p.publish_pose(pose_at(1), nullptr).has_value());
  EXPECT_EQ(calls, 3);
  EXPECT_EQ(p.stats().send_failures, 2);
  EXPECT_EQ(p.stats().retries, 2);
  EXPECT_EQ(p.stats().poses_published, 1);
  EXPECT_FALSE(p.has_pending_pose());

  fail_next = 100;  // down: gives up after max_send_attempts, keeps the message
  auto failed = p.publish_pose(pose_at(2), nullptr);
  ASSERT_FALSE(failed.has_value());
  EXPECT_EQ(failed.error().code, ErrorCode::kIoError);
  EXPECT_NE(failed.error().message.find("SITEPOSE_POSE"), std::string::npos);
  EXPECT_EQ(calls, 6);
  EXPECT_EQ(p.stats().messages_failed, 1);
  EXPECT_TRUE(p.has_pending_pose());
  EXPECT_FALSE(p.retry_pose().has_value());
  EXPECT_EQ(calls, 9);
  // A failed health report is not kept and does not displace the pose.
  EXPECT_FALSE(p.publish_health(LcmHealth{}).has_value());
  EXPECT_EQ(calls, 12);
  EXPECT_TRUE(p.has_pending_pose());

  fail_next = 0;  // back: retry_pose sends the kept pose once
  EXPECT_TRUE(p.retry_pose().has_value());
  EXPECT_EQ(calls, 13);
  EXPECT_FALSE(p.has_pending_pose());
  EXPECT_TRUE(p.retry_pose().has_value());  // nothing pending: no send
  EXPECT_EQ(calls, 13);
  EXPECT_EQ(p.stats().poses_published, 2);
  EXPECT_EQ(p.stats().health_published, 0);
  EXPECT_EQ(p.stats().messages_failed, 3);
  EXPECT_EQ(p.stats().send_failures, 2 + 9);
  EXPECT_EQ(channels, (std::vector<std::string>{"SITEPOSE_POSE", "SITEPOSE_POSE"}));

  LcmOptions once;
  once.max_send_attempts = 1;
  int single_calls = 0;
  auto single = LcmPublisher::create_with_sender(once, [&](const std::string&, const void*, unsigned) {
    ++single_calls;
    return -1;
  });
  ASSERT_TRUE(single.has_value());
  EXPECT_FALSE((*single)->publish_health(LcmHealth{}).has_value());
  EXPECT_EQ(single_calls, 1);
  EXPECT_EQ((*single)->stats().retries, 0);
}

TEST(LcmGnssSubscriber, DeliversValidFixesAndCountsBadMessages) {
  auto lcm = open_lcm("memq://");
  ASSERT_TRUE(lcm.has_value());
  std::vector<geo::GnssFix> fixes;
  LcmOptions options;
  options.gnss_channel = "GNSS.FIX";  // '.' must match literally, not any char
  auto subscriber = LcmGnssSubscriber::create(options, *lcm,
                                              [&](const geo::GnssFix& f) { fixes.push_back(f); });
  ASSERT_TRUE(subscriber.has_value()) << subscriber.error().message;

  geo::GnssFix fix;
  fix.t_ns = 1'700'000'000'000'000'000;
  fix.position = {48.1, 11.5, 600.0};
  fix.quality = geo::GnssQuality::kRtkFixed;
  fix.num_satellites = 15;
  fix.hdop = 0.8;
  for (int i = 0; i < 3; ++i) {
    fix.t_ns += 200'000'000;
    const sitepose::gnss_fix_t m = to_lcm_gnss_fix(fix);
    (*lcm)->publish("GNSS.FIX", &m);
  }
  sitepose::gnss_fix_t bad = to_lcm_gnss_fix(fix);
  bad.quality = 9;
  (*lcm)->publish("GNSS.FIX", &bad);
  const char garbage[] = "not an lcm message";
  (*lcm)->publish("GNSS.FIX", garbage, sizeof(garbage));
  const sitepose::gnss_fix_t other = to_lcm_gnss_fix(fix);
  (*lcm)->publish("GNSSXFIX", &other);  // another channel: not ours

  int handled = 0;
  while (true) {
    auto r = (*subscriber)->handle(0);
    ASSERT_TRUE(r.has_value());
    if (!*r) break;
    ++handled;
  }
  EXPECT_GE(handled, 5);  // memq may drop the message nobody subscribed to
  EXPECT_LE(handled, 6);
  ASSERT_EQ(fixes.size(), 3u);
  EXPECT_EQ(fixes[2].t_ns, fix.t_ns);
  EXPECT_EQ(fixes[0].quality, geo::GnssQuality::kRtkFixed);
  EXPECT_EQ((*subscriber)->fixes_received(), 3);
  EXPECT_EQ((*subscriber)->messages_rejected(), 2);
  EXPECT_NE((*subscriber)->first_rejection().find("GNSS.FIX: gnss_fix_t"), std::string::npos)
      << (*subscriber)->first_rejection();
  EXPECT_GE((*subscriber)->fileno(), 0);
}

}  // namespace
}  // namespace sitepose::output
