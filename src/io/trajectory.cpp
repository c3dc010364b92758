#include "sitepose/io/trajectory.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iomanip>
#include <memory>
#include <optional>
#include <sstream>

#include "detail/text.hpp"
#include "sitepose/core/enum_names.hpp"
#include "sitepose/io/euroc.hpp"

namespace sitepose::io {
namespace {

// Files store a few digits only; a rotation block or quaternion further from
// orthonormal / unit than this is not a pose but a broken line.
constexpr double kRotationTolerance = 1e-2;

Expected<SE3> pose_from_kitti_row(const std::string& path, std::size_t line_no,
                                  const std::vector<double>& v) {
  Eigen::Matrix<double, 3, 4> T;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) T(r, c) = v[static_cast<std::size_t>(r) * 4 + static_cast<std::size_t>(c)];
  }
  const Eigen::Matrix3d R = T.leftCols<3>();
  const double orth_error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orth_error > kRotationTolerance || R.determinant() <= 0.0) {
    std::ostringstream msg;
    msg << detail::where(path, line_no)
        << "expected a rotation in the first 3 columns (R^T R = I, det = +1); max |R^T R - I| = "
        << orth_error << ", det = " << R.determinant();
    return make_error(ErrorCode::kParseError, msg.str());
  }
  return SE3::from_matrix3x4(T);
}

bool pose_is_finite(const SE3& pose) {
  return pose.translation().allFinite() && pose.rotation().coeffs().allFinite();
}

// Checked before the file is opened, so a refused trajectory leaves no partial file behind.
Status check_all_finite(const std::string& path, const Trajectory& trajectory) {
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    if (!std::isfinite(trajectory[i].t_s) || !pose_is_finite(trajectory[i].T_world_cam)) {
      return make_error(ErrorCode::kInvalidArgument,
                        path + ": refusing to write pose " + std::to_string(i) + ": non-finite time or pose");
    }
  }
  return ok_status();
}

// fclose-checked FILE handle so a full disk is reported, not ignored.
struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f != nullptr) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

Expected<FilePtr> open_for_writing(const std::string& path) {
  FilePtr file(std::fopen(path.c_str(), "w"));
  if (!file) {
    return make_error(ErrorCode::kIoError, path + ": cannot open for writing: " + std::strerror(errno));
  }
  return file;
}

Status finish_writing(const std::string& path, FilePtr file) {
  const bool write_failed = std::ferror(file.get()) != 0;
  const int close_rc = std::fclose(file.release());
  if (write_failed || close_rc != 0) {
    return make_error(ErrorCode::kIoError, path + ": write failed: " + std::strerror(errno));
  }
  return ok_status();
}

}  // namespace

Expected<Trajectory> read_tum_trajectory(const std::string& path) {
  Trajectory trajectory;
  SITEPOSE_TRY_STATUS(detail::for_each_data_line(
      path, detail::DataLines::kSkipCommentsAndBlanks,
      [&](std::size_t line_no, std::string_view line) -> Status {
        SITEPOSE_TRY(const std::vector<double> v, detail::parse_number_line(path, line_no, line, 8));
        const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // w, x, y, z
        if (std::abs(q.norm() - 1.0) > kRotationTolerance) {
          std::ostringstream msg;
          msg << detail::where(path, line_no) << "expected a unit quaternion (qx qy qz qw), norm is "
              << q.norm();
          return make_error(ErrorCode::kParseError, msg.str());
        }
        if (!trajectory.empty() && !(v[0] > trajectory.back().t_s)) {
          std::ostringstream msg;
          msg.precision(9);
          msg << std::fixed << detail::where(path, line_no) << "expected a time after "
              << trajectory.back().t_s << " s, got " << v[0] << " s (times must increase)";
          return make_error(ErrorCode::kParseError, msg.str());
        }
        trajectory.push_back({v[0], SE3(q, Eigen::Vector3d(v[1], v[2], v[3]))});
        return ok_status();
      }));
  return trajectory;
}

Status write_tum_trajectory(const std::string& path, const Trajectory& trajectory) {
  SITEPOSE_TRY_STATUS(check_all_finite(path, trajectory));
  SITEPOSE_TRY(FilePtr file, open_for_writing(path));
  std::fprintf(file.get(), "# t x y z qx qy qz qw (T_world_cam of the left camera)\n");
  for (const StampedPose& p : trajectory) {
    const Eigen::Vector3d& t = p.T_world_cam.translation();
    const Eigen::Quaterniond& q = p.T_world_cam.rotation();
    std::fprintf(file.get(), "%.9f %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", p.t_s, t.x(), t.y(), t.z(), q.x(),
                 q.y(), q.z(), q.w());
  }
  return finish_writing(path, std::move(file));
}

Expected<std::vector<SE3>> read_kitti_poses(const std::string& path) {
  std::vector<SE3> poses;
  SITEPOSE_TRY_STATUS(detail::for_each_data_line(
      path, detail::DataLines::kEveryLineToContentEnd,
      [&](std::size_t line_no, std::string_view line) -> Status {
        SITEPOSE_TRY(const std::vector<double> v, detail::parse_number_line(path, line_no, line, 12));
        SITEPOSE_TRY(SE3 pose, pose_from_kitti_row(path, line_no, v));
        poses.push_back(pose);
        return ok_status();
      }));
  return poses;
}

Status write_kitti_poses(const std::string& path, const std::vector<SE3>& poses) {
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!pose_is_finite(poses[i])) {
      return make_error(ErrorCode::kInvalidArgument,
                        path + ": refusing to write pose " + std::to_string(i) + ": non-finite");
    }
  }
  SITEPOSE_TRY(FilePtr file, open_for_writing(path));
  for (const SE3& pose : poses) {
    const Eigen::Matrix<double, 3, 4> T = pose.matrix3x4();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) {
        std::fprintf(file.get(), (r == 0 && c == 0) ? "%.9g" : " %.9g", T(r, c));
      }
    }
    std::fprintf(file.get(), "\n");
  }
  return finish_writing(path, std::move(file));
}

Expected<std::vector<double>> read_times(const std::string& path) {
  std::vector<double> times;
  std::int64_t last_ns = 0;
  SITEPOSE_TRY_STATUS(detail::for_each_data_line(
      path, detail::DataLines::kEveryLineToContentEnd,
      [&](std::size_t line_no, std::string_view line) -> Status {
        SITEPOSE_TRY(const std::vector<double> v, detail::parse_number_line(path, line_no, line, 1));
        const double t_s = v[0];
        // Frames are stamped in int64 ns: the time must convert without overflow.
        if (!(t_s >= 0.0 && t_s <= kMaxTimeS)) {
          std::ostringstream msg;
          msg << detail::where(path, line_no) << "expected a time in 0.." << kMaxTimeS
              << " s (from the start of the recording or the Unix epoch), got " << t_s << " s";
          return make_error(ErrorCode::kParseError, msg.str());
        }
        const std::int64_t t_ns = std::llround(t_s * 1e9);
        if (!times.empty() && !(t_ns > last_ns)) {
          std::ostringstream msg;
          msg.precision(9);
          msg << std::fixed << detail::where(path, line_no) << "expected a time after " << times.back()
              << " s, got " << std::setprecision(t_s > times.back() ? 12 : 9) << t_s
              << " s (times must increase by at least 1 ns)";
          return make_error(ErrorCode::kParseError, msg.str());
        }
        times.push_back(t_s);
        last_ns = t_ns;
        return ok_status();
      }));
  return times;
}

Expected<Trajectory> read_kitti_trajectory(const std::string& poses_path, const std::string& times_path) {
  SITEPOSE_TRY(const std::vector<SE3> poses, read_kitti_poses(poses_path));
  SITEPOSE_TRY(const std::vector<double> times, read_times(times_path));
  if (poses.size() != times.size()) {
    return make_error(ErrorCode::kInvalidArgument,
                      poses_path + " has " + std::to_string(poses.size()) + " poses but " + times_path +
                          " has " + std::to_string(times.size()) + " times; expected one time per pose");
  }
  Trajectory trajectory;
  trajectory.reserve(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) trajectory.push_back({times[i], poses[i]});
  return trajectory;
}

constexpr auto kTrajectoryFormatNames = enum_names<TrajectoryFormat>({{TrajectoryFormat::kTum, "tum"},
                                                                      {TrajectoryFormat::kKitti, "kitti"},
                                                                      {TrajectoryFormat::kEuroc, "euroc"}});

const char* to_string(TrajectoryFormat format) { return kTrajectoryFormatNames.name(format); }

Expected<TrajectoryFormat> parse_trajectory_format(const std::string& name) {
  if (const std::optional<TrajectoryFormat> format = kTrajectoryFormatNames.parse(name)) return *format;
  std::string message = "'";  // appended, not "'" + ...: GCC 12 warns falsely (-Wrestrict) on that
  message.append(name, 0, 40).append("' is not one of ").append(kTrajectoryFormatNames.joined(", "));
  return make_error(ErrorCode::kInvalidArgument, message);
}

std::string kitti_times_path(const std::string& path) { return path + ".times.txt"; }

namespace {

Status write_times(const std::string& path, const Trajectory& trajectory) {
  SITEPOSE_TRY(FilePtr file, open_for_writing(path));
  for (const StampedPose& p : trajectory) std::fprintf(file.get(), "%.9f\n", p.t_s);
  return finish_writing(path, std::move(file));
}

Status write_euroc_trajectory(const std::string& path, const Trajectory& trajectory) {
  SITEPOSE_TRY_STATUS(check_all_finite(path, trajectory));
  SITEPOSE_TRY(FilePtr file, open_for_writing(path));
  std::fprintf(
      file.get(),
      "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []\n");
  for (const StampedPose& p : trajectory) {
    const Eigen::Vector3d& t = p.T_world_cam.translation();
    const Eigen::Quaterniond& q = p.T_world_cam.rotation();
    std::fprintf(file.get(), "%lld,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", std::llround(p.t_s * 1e9), t.x(),
                 t.y(), t.z(), q.w(), q.x(), q.y(), q.z());
  }
  return finish_writing(path, std::move(file));
}

}  // namespace

Status write_trajectory(const std::string& path, const Trajectory& trajectory, TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum: return write_tum_trajectory(path, trajectory);
    case TrajectoryFormat::kEuroc: return write_euroc_trajectory(path, trajectory);
    case TrajectoryFormat::kKitti: {
      std::vector<SE3> poses;
      for (const StampedPose& p : trajectory) poses.push_back(p.T_world_cam);
      SITEPOSE_TRY_STATUS(write_kitti_poses(path, poses));
      return write_times(kitti_times_path(path), trajectory);
    }
  }
  return make_error(ErrorCode::kInvalidArgument, "unknown trajectory format");
}

Expected<TrajectoryFormat> detect_trajectory_format(const std::string& path) {
  std::optional<TrajectoryFormat> format;
  Status seen = detail::for_each_data_line(
      path, detail::DataLines::kSkipCommentsAndBlanks,
      [&](std::size_t line_no, std::string_view line) -> Status {
        if (format) return ok_status();
        if (line.find(',') != std::string_view::npos) {
          format = TrajectoryFormat::kEuroc;
        } else if (const std::size_t n = detail::split_whitespace(line).size(); n == 12 || n == 8) {
          format = n == 12 ? TrajectoryFormat::kKitti : TrajectoryFormat::kTum;
        } else {
          return make_error(ErrorCode::kParseError,
                            detail::where(path, line_no) + "expected a trajectory line: " +
                                "8 numbers (TUM), 12 (KITTI) or a EuRoC CSV row, got " + std::to_string(n) +
                                " fields");
        }
        return ok_status();
      });
  if (!seen) return make_error(seen.error().code, seen.error().message);
  if (!format) return make_error(ErrorCode::kInvalidArgument, path + " holds no poses");
  return *format;
}

Expected<Trajectory> read_trajectory(const std::string& path, const std::string& times_path) {
  SITEPOSE_TRY(const TrajectoryFormat format, detect_trajectory_format(path));
  switch (format) {
    case TrajectoryFormat::kTum: return read_tum_trajectory(path);
    case TrajectoryFormat::kKitti:
      return read_kitti_trajectory(path, times_path.empty() ? kitti_times_path(path) : times_path);
    case TrajectoryFormat::kEuroc: {
      SITEPOSE_TRY(const std::vector<EurocGtSample> samples, read_euroc_groundtruth(path));
      Trajectory trajectory;
      for (const EurocGtSample& s : samples)
        trajectory.push_back({static_cast<double>(s.t_ns) * 1e-9, s.T_world_body});
      return trajectory;
    }
  }
  return make_error(ErrorCode::kInvalidArgument, "unknown trajectory format");
}

}  // namespace sitepose::io
