// Built-in detector `stereo-geometric` (weight-free; see stereo_geometric.hpp).
// Config (YAML mapping): fx, fy, cx, cy, baseline_m (required: the rectified
// camera of the frames), and optionally any other field of
// StereoGeometricOptions by the same name. Class "object"; pixel masks from
// the same disparity pass; ids tracked by IoU.

#include "plugin_support.hpp"
#include "stereo_geometric.hpp"

namespace sitepose::detect::plugin {
namespace {

class StereoGeometricPlugin final : public PluginImpl {
 public:
  explicit StereoGeometricPlugin(const StereoGeometricOptions& options) : detector_(options) {}

  std::uint32_t capabilities() const override {
    return SP_DETECTOR_CAP_SEGMENTATION | SP_DETECTOR_CAP_TRACKS_IDS;
  }

  Expected<std::vector<sp_detection>> detect(const cv::Mat& left, const cv::Mat& right,
                                             std::int64_t, std::int64_t seq) override {
    SITEPOSE_TRY(auto objects, detector_.detect(left, right, seq));
    std::vector<sp_detection> out;
    out.reserve(objects.size());
    for (const auto& o : objects) {
      out.push_back(make_detection("object", static_cast<float>(o.score), o.box, o.instance));
    }
    return out;
  }

  Status segment(const cv::Mat&, const cv::Mat&, std::int64_t, std::int64_t seq,
                 const std::vector<sp_detection>& detections, cv::Mat& mask) override {
    for (const auto& d : detections) SITEPOSE_TRY_STATUS(detector_.paint(seq, d.instance, mask));
    return ok_status();
  }

 private:
  StereoGeometric detector_;
};

}  // namespace

Expected<std::unique_ptr<PluginImpl>> make_plugin(const YAML::Node& config) {
  OptionReader r(config, "stereo-geometric");
  StereoGeometricOptions o;
  SITEPOSE_TRY_STATUS(r.read("fx", o.fx, true));
  SITEPOSE_TRY_STATUS(r.read("fy", o.fy, true));
  SITEPOSE_TRY_STATUS(r.read("cx", o.cx, true));
  SITEPOSE_TRY_STATUS(r.read("cy", o.cy, true));
  SITEPOSE_TRY_STATUS(r.read("baseline_m", o.baseline_m, true));
  SITEPOSE_TRY_STATUS(r.read("scale", o.scale));
  SITEPOSE_TRY_STATUS(r.read("min_depth_m", o.min_depth_m));
  SITEPOSE_TRY_STATUS(r.read("max_range_m", o.max_range_m));
  SITEPOSE_TRY_STATUS(r.read("min_height_m", o.min_height_m));
  SITEPOSE_TRY_STATUS(r.read("grow_height_m", o.grow_height_m));
  SITEPOSE_TRY_STATUS(r.read("max_height_m", o.max_height_m));
  SITEPOSE_TRY_STATUS(r.read("max_foot_height_m", o.max_foot_height_m));
  SITEPOSE_TRY_STATUS(r.read("min_area_fraction", o.min_area_fraction));
  SITEPOSE_TRY_STATUS(r.read("min_seed_fraction", o.min_seed_fraction));
  SITEPOSE_TRY_STATUS(r.read("plane_inlier_m", o.plane_inlier_m));
  SITEPOSE_TRY_STATUS(r.read("max_plane_tilt_deg", o.max_plane_tilt_deg));
  SITEPOSE_TRY_STATUS(r.read("track_iou", o.track_iou));
  SITEPOSE_TRY_STATUS(r.read("seed", o.seed));
  SITEPOSE_TRY_STATUS(r.finish());
  SITEPOSE_TRY_STATUS(StereoGeometric::validate(o));
  return std::unique_ptr<PluginImpl>(new StereoGeometricPlugin(o));
}

}  // namespace sitepose::detect::plugin
