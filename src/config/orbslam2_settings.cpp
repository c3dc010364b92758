// ORB-SLAM2 stereo settings (cv::FileStorage YAML). ORB-SLAM2 reads these
// inline with fSettings["Camera.fx"] and silently gets 0 for a missing key;
// here every key is checked and named.

#include "sitepose/config/orbslam2_settings.hpp"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "detail/file_head.hpp"
#include "detail/orb_limits.hpp"
#include "sitepose/config/yaml_reader.hpp"

namespace sitepose::config {

namespace {

constexpr const char* kDistortionKeys[] = {"Camera.k1", "Camera.k2", "Camera.p1", "Camera.p2", "Camera.k3"};

// Reads the keys of one file and collects every problem, like YamlReader.
class SettingsReader {
 public:
  SettingsReader(const cv::FileStorage& fs, std::string source)
      : root_(fs.root()), source_(std::move(source)) {}

  bool number(const char* key, double& out) {
    const std::optional<cv::FileNode> found = required(key);
    if (!found) return false;
    const cv::FileNode& node = *found;
    if (!node.isReal() && !node.isInt()) {
      wrong(key, node, "expected a number");
      return false;
    }
    const double value = static_cast<double>(node);
    if (!std::isfinite(value)) {
      wrong(key, node, "expected a finite number");
      return false;
    }
    out = value;
    return true;
  }

  bool integer(const char* key, int& out) {
    const std::optional<cv::FileNode> found = required(key);
    if (!found) return false;
    if (!found->isInt()) {
      wrong(key, *found, "expected an integer");
      return false;
    }
    out = static_cast<int>(*found);
    return true;
  }

  bool optional_number(const char* key, double& out) {
    if (!has(key)) {
      used_.emplace_back(key);
      return false;
    }
    return number(key, out);
  }

  // Checks a value already read against [low, high] (inclusive or not).
  template <typename T>
  bool check(const char* key, T value, bool ok, const std::string& expectation) {
    if (!ok) {
      problems_.push_back(source_ + ": " + key + " = " + detail::number_text(value) + ": " + expectation);
    }
    return ok;
  }

  void problem(const std::string& text) { problems_.push_back(source_ + ": " + text); }

  bool has(const char* key) const {
    const cv::FileNode node = root_[key];
    return !node.empty() && !node.isNone();
  }

  std::vector<std::string> unused_keys() const {
    std::vector<std::string> out;
    for (auto it = root_.begin(); it != root_.end(); ++it) {
      const std::string name = (*it).name();
      if (std::find(used_.begin(), used_.end(), name) == used_.end()) out.push_back(name);
    }
    return out;
  }

  const std::vector<std::string>& problems() const { return problems_; }

 private:
  // The key's node, or nullopt (reported as missing) when it is absent.
  std::optional<cv::FileNode> required(const char* key) {
    used_.emplace_back(key);
    cv::FileNode node = root_[key];
    if (node.empty() || node.isNone()) {
      missing(key);
      return std::nullopt;
    }
    return node;
  }

  void missing(const char* key) { problems_.push_back(source_ + ": " + key + ": missing (required key)"); }

  void wrong(const char* key, const cv::FileNode& node, const std::string& expectation) {
    problems_.push_back(source_ + ": " + key + " = " + describe(node) + ": " + expectation);
  }

  static std::string describe(const cv::FileNode& node) {
    if (node.isString()) {
      // Built in place: GCC 12 warns falsely (-Wrestrict) on "\"" + s.
      std::string text = static_cast<std::string>(node);
      text.insert(text.begin(), '"');
      text.push_back('"');
      return text;
    }
    if (node.isSeq()) return "(a sequence)";
    if (node.isMap()) return "(a mapping)";
    if (node.isReal()) return detail::number_text(static_cast<double>(node));
    return "(a value of another type)";
  }

  cv::FileNode root_;
  std::string source_;
  std::vector<std::string> used_;
  std::vector<std::string> problems_;
};

// EuRoC-style files rectify on the fly; sitepose needs rectified input.
Status refuse_rectification_maps(const SettingsReader& r, const std::string& source) {
  for (const char* key : {"LEFT.K", "LEFT.P", "LEFT.R", "RIGHT.K", "RIGHT.P", "RIGHT.R"}) {
    if (r.has(key)) {
      return make_error(ErrorCode::kUnsupported,
                        source + ": " + key +
                            ": rectification maps are not supported; rectify the images first "
                            "and give the rectified Camera.* values");
    }
  }
  return ok_status();
}

// Camera.* and ThDepth into s; returns Camera.bf (baseline_m is set from it
// once every key is known to be valid).
double read_camera(SettingsReader& r, OrbSlam2Settings& s) {
  StereoCamera& cam = s.camera;
  double bf = 0.0;
  if (r.number("Camera.fx", cam.fx)) r.check("Camera.fx", cam.fx, cam.fx > 0.0, "must be > 0");
  if (r.number("Camera.fy", cam.fy)) r.check("Camera.fy", cam.fy, cam.fy > 0.0, "must be > 0");
  const bool have_cx = r.number("Camera.cx", cam.cx);
  const bool have_cy = r.number("Camera.cy", cam.cy);
  const bool have_w = r.integer("Camera.width", cam.width) &&
                      r.check("Camera.width", cam.width, cam.width > 0, "must be > 0");
  const bool have_h = r.integer("Camera.height", cam.height) &&
                      r.check("Camera.height", cam.height, cam.height > 0, "must be > 0");
  if (have_cx && have_w) {
    r.check("Camera.cx", cam.cx, cam.cx >= 0.0 && cam.cx < cam.width,
            "must be inside the image (0 <= cx < Camera.width = " + std::to_string(cam.width) + ")");
  }
  if (have_cy && have_h) {
    r.check("Camera.cy", cam.cy, cam.cy >= 0.0 && cam.cy < cam.height,
            "must be inside the image (0 <= cy < Camera.height = " + std::to_string(cam.height) + ")");
  }
  if (r.number("Camera.bf", bf)) r.check("Camera.bf", bf, bf > 0.0, "must be > 0 (fx * baseline)");
  if (r.number("Camera.fps", s.fps_hz)) {
    r.check("Camera.fps", s.fps_hz, s.fps_hz > 0.0 && s.fps_hz <= 1000.0, "must be in (0, 1000]");
  }
  for (const char* key : kDistortionKeys) {
    double k = 0.0;
    if (r.optional_number(key, k)) {
      r.check(key, k, k == 0.0, "must be 0: sitepose takes rectified images without distortion");
    }
  }
  if (r.has("Camera.RGB")) {
    int rgb = 0;
    if (r.integer("Camera.RGB", rgb) &&
        r.check("Camera.RGB", rgb, rgb == 0 || rgb == 1, "must be 0 (BGR) or 1 (RGB)")) {
      s.rgb = rgb == 1;
    }
  }
  if (r.number("ThDepth", s.close_depth_baselines)) {
    r.check("ThDepth", s.close_depth_baselines,
            s.close_depth_baselines > 0.0 && s.close_depth_baselines <= detail::kMaxCloseDepthBaselines,
            "must be in (0, " + detail::number_text(detail::kMaxCloseDepthBaselines) + "] (baselines)");
  }
  return bf;
}

void read_orb_extractor(SettingsReader& r, OrbConfig& orb) {
  if (r.integer("ORBextractor.nFeatures", orb.n_features)) {
    r.check("ORBextractor.nFeatures", orb.n_features,
            orb.n_features >= detail::kMinOrbFeatures && orb.n_features <= detail::kMaxOrbFeatures,
            "must be in [" + std::to_string(detail::kMinOrbFeatures) + ", " +
                std::to_string(detail::kMaxOrbFeatures) + "]");
  }
  if (r.number("ORBextractor.scaleFactor", orb.scale_factor)) {
    r.check("ORBextractor.scaleFactor", orb.scale_factor,
            orb.scale_factor > 1.0 && orb.scale_factor <= detail::kMaxScaleFactor,
            "must be in (1, " + detail::number_text(detail::kMaxScaleFactor) + "]");
  }
  if (r.integer("ORBextractor.nLevels", orb.n_levels)) {
    r.check("ORBextractor.nLevels", orb.n_levels, orb.n_levels >= 1 && orb.n_levels <= detail::kMaxLevels,
            "must be in [1, " + std::to_string(detail::kMaxLevels) + "]");
  }
  const std::string fast_range = "must be in [1, " + std::to_string(detail::kMaxFastThreshold) + "]";
  const bool have_ini =
      r.integer("ORBextractor.iniThFAST", orb.ini_fast_threshold) &&
      r.check("ORBextractor.iniThFAST", orb.ini_fast_threshold,
              orb.ini_fast_threshold >= 1 && orb.ini_fast_threshold <= detail::kMaxFastThreshold, fast_range);
  const bool have_min =
      r.integer("ORBextractor.minThFAST", orb.min_fast_threshold) &&
      r.check("ORBextractor.minThFAST", orb.min_fast_threshold,
              orb.min_fast_threshold >= 1 && orb.min_fast_threshold <= detail::kMaxFastThreshold, fast_range);
  if (have_ini && have_min) {
    r.check("ORBextractor.minThFAST", orb.min_fast_threshold,
            orb.min_fast_threshold <= orb.ini_fast_threshold,
            "must be <= ORBextractor.iniThFAST (" + std::to_string(orb.ini_fast_threshold) + ")");
  }
}

Expected<OrbSlam2Settings> read_settings(const cv::FileStorage& fs, const std::string& source) {
  SettingsReader r(fs, source);
  SITEPOSE_TRY_STATUS(refuse_rectification_maps(r, source));
  OrbSlam2Settings s;
  const double bf = read_camera(r, s);
  read_orb_extractor(r, s.orb);

  if (!r.problems().empty()) {
    std::string message;
    for (const std::string& p : r.problems()) message += (message.empty() ? "" : "\n") + p;
    return make_error(ErrorCode::kInvalidArgument, message);
  }
  StereoCamera& cam = s.camera;
  cam.baseline_m = bf / cam.fx;
  if (const Status valid = cam.validate(); !valid) {
    return make_error(ErrorCode::kInvalidArgument, source + ": " + valid.error().message);
  }
  s.ignored_keys = r.unused_keys();
  return s;
}

// OpenCV 4.6 puts the parser's "(line): what" in Exception::func and the
// function name in ::err; take whichever carries the line.
std::string describe_cv_error(const cv::Exception& e, const std::string& source) {
  for (const std::string* part : {&e.func, &e.err}) {
    const auto close = part->find("): ");
    if (!part->empty() && (*part)[0] == '(' && close != std::string::npos) {
      return source + ":" + part->substr(1, close - 1) +
             ": malformed ORB-SLAM2 settings file: " + part->substr(close + 3);
    }
  }
  std::string text = source + ": malformed ORB-SLAM2 settings file: " + e.err;
  if (e.code == cv::Error::StsBadArg) text += " (the first line must be %YAML:1.0)";
  return text;
}

// OpenCV's YAML reader never returns on some texts with more than one
// document marker ("%YAML:1.0\n----d\n----\ns" spins in
// cv::FileStorage, found by fuzz_orbslam2_settings). A settings file is one
// mapping: at most one line starting with "---", and that line is "---".
Status check_document_markers(const std::string& text, const std::string& source) {
  std::istringstream lines(text);
  std::string line;
  int markers = 0;
  for (int number = 1; std::getline(lines, line); ++number) {
    if (line.rfind("---", 0) != 0) continue;
    const bool plain = line.find_first_not_of(" \t\r", 3) == std::string::npos;
    if (!plain || ++markers > 1) {
      return make_error(ErrorCode::kParseError,
                        source + ":" + std::to_string(number) +
                            ": malformed ORB-SLAM2 settings file: one mapping expected, with at most one "
                            "document start line \"---\"");
    }
  }
  return ok_status();
}

Expected<OrbSlam2Settings> read_text(const std::string& text, const std::string& source) {
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    return make_error(ErrorCode::kParseError,
                      source + ": empty file (expected ORB-SLAM2 settings starting with %YAML:1.0)");
  }
  SITEPOSE_TRY_STATUS(check_document_markers(text, source));
  try {
    cv::FileStorage fs(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) {
      return make_error(ErrorCode::kParseError, source + ": cannot read as an OpenCV FileStorage YAML file");
    }
    if (!fs.root().isMap()) {
      return make_error(ErrorCode::kInvalidArgument,
                        source +
                            ": expected a mapping of Camera.*, ThDepth and ORBextractor.* "
                            "keys at the top level");
    }
    return read_settings(fs, source);
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kParseError, describe_cv_error(e, source));
  }
}

}  // namespace

Expected<OrbSlam2Settings> load_orbslam2_settings(const std::string& path) {
  // Read the text here so a missing file is kNotFound, not an OpenCV error;
  // a path that siteposed's settings name may be anything (a folder,
  // /dev/zero): read at most the config files' limit.
  SITEPOSE_TRY(const std::string text,
               detail::read_file_head(path, kMaxYamlBytes, "ORB-SLAM2 settings file", ""));
  if (text.size() > kMaxYamlBytes) {
    return make_error(ErrorCode::kInvalidArgument, "ORB-SLAM2 settings file " + path + ": larger than " +
                                                       std::to_string(kMaxYamlBytes) + " bytes");
  }
  return read_text(text, path);
}

Expected<OrbSlam2Settings> load_orbslam2_settings_from_string(const std::string& text,
                                                              const std::string& source_name) {
  return read_text(text, source_name);
}

void apply_orbslam2_settings(const OrbSlam2Settings& settings, SiteposeConfig& config) {
  config.camera.stereo = settings.camera;
  config.camera.channel_order = settings.rgb ? ChannelOrder::kRgb : ChannelOrder::kBgr;
  const int grid_cell_px = config.orb.grid_cell_px;
  config.orb = settings.orb;
  config.orb.grid_cell_px = grid_cell_px;
  config.tracking.close_depth_baselines = settings.close_depth_baselines;
  config.tracking.keyframe_max_interval_frames = std::max(1, static_cast<int>(std::lround(settings.fps_hz)));
}

}  // namespace sitepose::config
