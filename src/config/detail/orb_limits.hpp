#pragma once
// Accepted ranges of the ORB extraction settings, shared by sitepose.yaml
// and ORB-SLAM2 settings files so both reject the same values.

namespace sitepose::config::detail {

constexpr int kMinOrbFeatures = 50;       // fewer cannot keep a stereo pose
constexpr int kMaxOrbFeatures = 50000;    // far beyond real-time budgets
constexpr double kMaxScaleFactor = 2.0;   // ORB-SLAM2 uses 1.2; > 2 skips scales
constexpr int kMaxLevels = 16;
constexpr int kMaxFastThreshold = 255;    // FAST compares 8-bit intensities
constexpr double kMaxCloseDepthBaselines = 1000.0;

}  // namespace sitepose::config::detail
