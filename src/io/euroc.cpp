#include "sitepose/io/euroc.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <sstream>

#include "detail/text.hpp"
#include "sitepose/core/echo.hpp"

namespace sitepose::io {
namespace {

// Calibration files carry ~10 digits; further from a rotation is a broken file.
constexpr double kRotationTolerance = 1e-3;
// Rectified rows must coincide: a vertical offset of the right camera's
// projection above this fraction of fx * baseline means a non-horizontal pair.
constexpr double kVerticalOffsetTolerance = 1e-6;

int yaml_line(const YAML::Node& node) { return node.Mark().line + 1; }

// Reads `key` of `parent` as a flow/block sequence of exactly `count` numbers.
Expected<std::vector<double>> yaml_numbers(const std::string& path, const YAML::Node& parent,
                                           const std::string& key, std::size_t count,
                                           const std::string& meaning) {
  const YAML::Node node = parent[key];
  if (!node.IsDefined()) {
    return make_error(ErrorCode::kParseError, path + ": key '" + key + "' missing; expected " +
                                                  std::to_string(count) + " numbers " + meaning);
  }
  const std::string at =
      detail::where(path, static_cast<std::size_t>(yaml_line(node))) + "key '" + key + "': ";
  if (!node.IsSequence() || node.size() != count) {
    return make_error(
        ErrorCode::kParseError,
        at + "expected " + std::to_string(count) + " numbers " + meaning + ", got " +
            (node.IsSequence() ? std::to_string(node.size()) + " values" : std::string("no list")));
  }
  std::vector<double> values;
  for (std::size_t i = 0; i < count; ++i) {
    const std::optional<double> v = detail::parse_double(node[i].Scalar());
    if (!node[i].IsScalar() || !v) {
      return make_error(ErrorCode::kParseError, at + "element " + std::to_string(i + 1) + " '" +
                                                    echo_value(node[i].Scalar()) +
                                                    "' is not a finite number");
    }
    values.push_back(*v);
  }
  return values;
}

Expected<std::string> yaml_string(const std::string& path, const YAML::Node& root, const std::string& key) {
  const YAML::Node node = root[key];
  if (!node.IsDefined() || !node.IsScalar()) {
    return make_error(ErrorCode::kParseError, path + ": key '" + key + "' missing or not a word");
  }
  return node.Scalar();
}

Expected<EurocCameraSensor> parse_sensor(const std::string& path, const YAML::Node& root) {
  if (!root.IsMap()) return make_error(ErrorCode::kParseError, path + ": expected a YAML mapping");
  EurocCameraSensor s;
  SITEPOSE_TRY(const std::string model, yaml_string(path, root, "camera_model"));
  if (model != "pinhole") {
    return make_error(ErrorCode::kUnsupported, detail::where(path, yaml_line(root["camera_model"])) +
                                                   "camera_model '" + model +
                                                   "': only 'pinhole' is supported");
  }
  SITEPOSE_TRY(const std::string dist_model, yaml_string(path, root, "distortion_model"));
  if (dist_model != "radial-tangential") {
    return make_error(ErrorCode::kUnsupported, detail::where(path, yaml_line(root["distortion_model"])) +
                                                   "distortion_model '" + dist_model +
                                                   "': only 'radial-tangential' is supported");
  }
  SITEPOSE_TRY(const std::vector<double> k, yaml_numbers(path, root, "intrinsics", 4, "[fu, fv, cu, cv]"));
  SITEPOSE_TRY(const std::vector<double> d,
               yaml_numbers(path, root, "distortion_coefficients", 4, "[k1, k2, p1, p2]"));
  SITEPOSE_TRY(const std::vector<double> res, yaml_numbers(path, root, "resolution", 2, "[width, height]"));
  s.fu = k[0];
  s.fv = k[1];
  s.cu = k[2];
  s.cv = k[3];
  std::copy(d.begin(), d.end(), s.distortion.begin());
  const std::string k_at = detail::where(path, static_cast<std::size_t>(yaml_line(root["intrinsics"])));
  if (!(s.fu > 0.0) || !(s.fv > 0.0)) {
    return make_error(ErrorCode::kParseError, k_at + "key 'intrinsics': expected fu > 0 and fv > 0");
  }
  const std::string r_at = detail::where(path, static_cast<std::size_t>(yaml_line(root["resolution"])));
  if (res[0] != std::floor(res[0]) || res[1] != std::floor(res[1]) || !(res[0] > 0) || !(res[1] > 0) ||
      res[0] > 100000 || res[1] > 100000) {
    return make_error(ErrorCode::kParseError,
                      r_at + "key 'resolution': expected two positive integers [width, height]");
  }
  s.width = static_cast<int>(res[0]);
  s.height = static_cast<int>(res[1]);

  const YAML::Node t_bs = root["T_BS"];
  if (!t_bs.IsDefined() || !t_bs.IsMap()) {
    return make_error(ErrorCode::kParseError,
                      path + ": key 'T_BS' missing; expected {rows: 4, cols: 4, data: [16 numbers]}");
  }
  SITEPOSE_TRY(const std::vector<double> data, yaml_numbers(path, t_bs, "data", 16, "(T_BS, 4x4 row-major)"));
  const std::string t_at =
      detail::where(path, static_cast<std::size_t>(yaml_line(t_bs["data"]))) + "key 'T_BS': ";
  for (const char* dim : {"rows", "cols"}) {
    if (t_bs[dim].IsDefined() && t_bs[dim].Scalar() != "4") {
      return make_error(ErrorCode::kParseError,
                        t_at + "expected " + dim + ": 4, got '" + echo_value(t_bs[dim].Scalar()) + "'");
    }
  }
  Eigen::Matrix4d T;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) T(r, c) = data[static_cast<std::size_t>(r) * 4 + static_cast<std::size_t>(c)];
  }
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  const double orth_error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orth_error > kRotationTolerance || R.determinant() <= 0.0 ||
      T.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
    return make_error(ErrorCode::kParseError,
                      t_at + "expected a rigid transform (rotation block, last row 0 0 0 1)");
  }
  s.T_body_cam = SE3::from_matrix(T);
  return s;
}

cv::Mat camera_matrix(const EurocCameraSensor& s) {
  return (cv::Mat_<double>(3, 3) << s.fu, 0, s.cu, 0, s.fv, s.cv, 0, 0, 1);
}
cv::Mat distortion(const EurocCameraSensor& s) {
  return (cv::Mat_<double>(1, 4) << s.distortion[0], s.distortion[1], s.distortion[2], s.distortion[3]);
}
Eigen::Matrix3d to_eigen3(const cv::Mat& m) {
  Eigen::Matrix3d e;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) e(r, c) = m.at<double>(r, c);
  }
  return e;
}

}  // namespace

Expected<EurocCameraSensor> read_euroc_sensor_yaml(const std::string& path) {
  SITEPOSE_TRY(std::vector<std::string> lines, detail::read_lines(path));
  // OpenCV-style "%YAML:1.0" is not a valid YAML directive; blank it so
  // yaml-cpp parses the rest and reported lines still match the file.
  if (!lines.empty() && lines[0].rfind("%YAML", 0) == 0) lines[0].clear();
  std::string text;
  for (const std::string& l : lines) text += l + "\n";
  try {
    const YAML::Node root = YAML::Load(text);
    return parse_sensor(path, root);
  } catch (const YAML::Exception& e) {
    return make_error(ErrorCode::kParseError, detail::where(path, static_cast<std::size_t>(e.mark.line) + 1) +
                                                  "invalid YAML: " + e.msg);
  }
}

Expected<EurocRectification> make_euroc_rectification(const EurocCameraSensor& cam0,
                                                      const EurocCameraSensor& cam1) {
  if (cam0.width != cam1.width || cam0.height != cam1.height) {
    return make_error(ErrorCode::kInvalidArgument,
                      "cam0 resolution " + std::to_string(cam0.width) + "x" + std::to_string(cam0.height) +
                          " differs from cam1 " + std::to_string(cam1.width) + "x" +
                          std::to_string(cam1.height) + "; expected a stereo pair of equal size");
  }
  const cv::Size size(cam0.width, cam0.height);
  const SE3 T_cam1_cam0 = cam1.T_body_cam.inverse() * cam0.T_body_cam;
  const Eigen::Matrix3d R_e = T_cam1_cam0.rotation_matrix();
  cv::Mat R(3, 3, CV_64F), t(3, 1, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R.at<double>(r, c) = R_e(r, c);
    t.at<double>(r) = T_cam1_cam0.translation()(r);
  }
  const cv::Mat K0 = camera_matrix(cam0), D0 = distortion(cam0);
  const cv::Mat K1 = camera_matrix(cam1), D1 = distortion(cam1);
  cv::Mat R1, R2, P1, P2, Q;
  EurocRectification out;
  try {
    cv::stereoRectify(K0, D0, K1, D1, size, R, t, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0, size);
    const double fx = P1.at<double>(0, 0);
    const double baseline_m = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
    if (!(baseline_m > 0.0) ||
        std::abs(P2.at<double>(1, 3)) > kVerticalOffsetTolerance * fx * std::abs(baseline_m) + 1e-12) {
      std::ostringstream msg;
      msg << "cam0/cam1 T_BS put cam1 at " << T_cam1_cam0.inverse().translation().transpose()
          << " m in cam0; expected cam1 to the right of cam0 (+x), a horizontal pair";
      return make_error(ErrorCode::kInvalidArgument, msg.str());
    }
    out.camera.fx = fx;
    out.camera.fy = P1.at<double>(1, 1);
    out.camera.cx = P1.at<double>(0, 2);
    out.camera.cy = P1.at<double>(1, 2);
    out.camera.baseline_m = baseline_m;
    out.camera.width = size.width;
    out.camera.height = size.height;
    cv::initUndistortRectifyMap(K0, D0, R1, P1, size, CV_16SC2, out.map0_a, out.map0_b);
    cv::initUndistortRectifyMap(K1, D1, R2, P2, size, CV_16SC2, out.map1_a, out.map1_b);
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kInvalidArgument, std::string("stereo rectification failed: ") + e.what());
  }
  SITEPOSE_TRY_STATUS(out.camera.validate());
  // p_rect = R1 p_cam0, so T_cam0_rect rotates by R1^T.
  out.T_cam0_rect = SE3(Eigen::Matrix3d(to_eigen3(R1).transpose()), Eigen::Vector3d::Zero());
  out.T_cam1_rect_right = SE3(Eigen::Matrix3d(to_eigen3(R2).transpose()), Eigen::Vector3d::Zero());
  return out;
}

Expected<std::vector<EurocImageEntry>> read_euroc_image_list(const std::string& path) {
  std::vector<EurocImageEntry> entries;
  SITEPOSE_TRY_STATUS(detail::for_each_data_line(
      path, detail::DataLines::kSkipCommentsAndBlanks,
      [&](std::size_t line_no, std::string_view line) -> Status {
        const std::vector<std::string_view> f = detail::split_fields(line, ',');
        const std::optional<std::int64_t> t = f.empty() ? std::nullopt : detail::parse_int64(f[0]);
        if (f.size() != 2 || !t || f[1].empty()) {
          return make_error(ErrorCode::kParseError, detail::where(path, line_no) +
                                                        "expected 'timestamp_ns,filename', got '" +
                                                        echo_value(line) + "'");
        }
        if (!entries.empty() && *t <= entries.back().t_ns) {
          return detail::timestamp_not_increasing(detail::where(path, line_no), entries.back().t_ns, *t);
        }
        entries.push_back({*t, std::string(f[1])});
        return ok_status();
      }));
  return entries;
}

namespace {

// One "timestamp_ns, p_RS_R xyz, q_RS wxyz[, ...]" line; `at` is where(path, line).
Expected<EurocGtSample> parse_groundtruth_line(const std::string& at, std::string_view line) {
  const std::vector<std::string_view> f = detail::split_fields(line, ',');
  if (f.size() < 8) {
    return make_error(ErrorCode::kParseError, at +
                                                  "expected at least 8 fields (timestamp, p_RS_R xyz, "
                                                  "q_RS wxyz), got " +
                                                  std::to_string(f.size()));
  }
  const std::optional<std::int64_t> t = detail::parse_int64(f[0]);
  if (!t) {
    return make_error(ErrorCode::kParseError,
                      at + "field 1: expected a timestamp in ns, got '" + echo_value(f[0]) + "'");
  }
  double v[7];
  for (std::size_t k = 0; k < 7; ++k) {
    const std::optional<double> x = detail::parse_double(f[k + 1]);
    if (!x) {
      return make_error(ErrorCode::kParseError, at + "field " + std::to_string(k + 2) + " '" +
                                                    echo_value(f[k + 1]) + "' is not a finite number");
    }
    v[k] = *x;
  }
  const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
  if (std::abs(q.norm() - 1.0) > 1e-2) {
    return make_error(ErrorCode::kParseError,
                      at + "expected a unit quaternion q_RS (w x y z), norm is " + std::to_string(q.norm()));
  }
  return EurocGtSample{*t, SE3(q, Eigen::Vector3d(v[0], v[1], v[2]))};
}

}  // namespace

Expected<std::vector<EurocGtSample>> read_euroc_groundtruth(const std::string& path) {
  std::vector<EurocGtSample> samples;
  SITEPOSE_TRY_STATUS(detail::for_each_data_line(
      path, detail::DataLines::kSkipCommentsAndBlanks,
      [&](std::size_t line_no, std::string_view line) -> Status {
        const std::string at = detail::where(path, line_no);
        SITEPOSE_TRY(EurocGtSample sample, parse_groundtruth_line(at, line));
        if (!samples.empty() && sample.t_ns <= samples.back().t_ns) {
          return detail::timestamp_not_increasing(at, samples.back().t_ns, sample.t_ns);
        }
        samples.push_back(std::move(sample));
        return ok_status();
      }));
  return samples;
}

std::vector<std::optional<SE3>> euroc_gt_at_times(const std::vector<EurocGtSample>& samples,
                                                  const std::vector<std::int64_t>& times_ns,
                                                  const SE3& T_body_rect, std::int64_t max_gap_ns) {
  std::vector<std::optional<SE3>> out(times_ns.size());
  for (std::size_t i = 0; i < times_ns.size(); ++i) {
    const std::int64_t t = times_ns[i];
    const auto after = std::lower_bound(samples.begin(), samples.end(), t,
                                        [](const EurocGtSample& s, std::int64_t v) { return s.t_ns < v; });
    if (after == samples.end()) continue;
    if (after->t_ns == t) {
      out[i] = after->T_world_body * T_body_rect;
      continue;
    }
    if (after == samples.begin()) continue;
    const auto before = std::prev(after);
    if (after->t_ns - before->t_ns > max_gap_ns) continue;
    const double alpha =
        static_cast<double>(t - before->t_ns) / static_cast<double>(after->t_ns - before->t_ns);
    out[i] = interpolate(before->T_world_body, after->T_world_body, alpha) * T_body_rect;
  }
  return out;
}

}  // namespace sitepose::io
