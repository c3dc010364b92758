#include "sitepose/sim/sequence_writer.hpp"

#include <unistd.h>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "sitepose/io/json_file.hpp"
#include "sitepose/io/text_file.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::sim {
namespace {

namespace fs = std::filesystem;

std::string frame_name(int k) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06d.png", k);
  return buf;
}

void write_3x4(std::ostream& out, const Eigen::Matrix<double, 3, 4>& M) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) out << (r || c ? " " : "") << M(r, c);
}

Status write_png(const fs::path& path, const cv::Mat& img) {
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), img, {cv::IMWRITE_PNG_COMPRESSION, 1});
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kIoError, "cannot write " + path.string() + ": " + e.what());
  }
  if (!ok) return make_error(ErrorCode::kIoError, "cannot write " + path.string());
  return ok_status();
}

constexpr const char* kSequenceEntries[] = {"image_0",   "image_1",   "labels",        "calib.txt",
                                            "times.txt", "poses.txt", "poses_tum.txt", "meta.json"};

// The output folder is checked before any rendering; the sequence is written
// into a hidden folder beside it and moved in only when complete, so an
// interrupted or failed run never leaves a half sequence under `dir`.
Status check_output_dir(const fs::path& dir, bool force) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return ok_status();
  if (!fs::is_directory(dir, ec)) {
    return make_error(ErrorCode::kInvalidArgument, "output " + dir.string() + " exists and is not a folder");
  }
  if (!fs::is_empty(dir, ec) && !force) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "output folder " + dir.string() + " is not empty (use --force to replace the sequence in it)");
  }
  return ok_status();
}

Expected<fs::path> make_staging_dir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir.parent_path(), ec);
  if (ec)
    return make_error(ErrorCode::kIoError,
                      "cannot create " + dir.parent_path().string() + ": " + ec.message());
  const fs::path staging =
      dir.parent_path() / ("." + dir.filename().string() + ".partial-" + std::to_string(::getpid()));
  fs::remove_all(staging, ec);
  for (const char* sub : {"image_0", "image_1", "labels/masks"}) {
    fs::create_directories(staging / sub, ec);
    if (ec)
      return make_error(ErrorCode::kIoError,
                        "cannot create " + (staging / sub).string() + ": " + ec.message());
  }
  return staging;
}

// Moves the finished sequence from `staging` to `dir`: a rename of the
// folder when `dir` is absent or empty, else (--force) the old sequence's
// entries are removed and the new ones renamed in; other files stay.
Status publish(const fs::path& staging, const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec) && fs::is_empty(dir, ec)) fs::remove(dir, ec);
  if (!fs::exists(dir, ec)) {
    fs::rename(staging, dir, ec);
    if (ec)
      return make_error(ErrorCode::kIoError,
                        "cannot rename " + staging.string() + " to " + dir.string() + ": " + ec.message());
    return ok_status();
  }
  for (const char* name : kSequenceEntries) {
    fs::remove_all(dir / name, ec);
    if (ec)
      return make_error(ErrorCode::kIoError, "cannot remove " + (dir / name).string() + ": " + ec.message());
    fs::rename(staging / name, dir / name, ec);
    if (ec)
      return make_error(ErrorCode::kIoError, "cannot move " + (staging / name).string() + " into " +
                                                 dir.string() + ": " + ec.message());
  }
  fs::remove_all(staging, ec);
  return ok_status();
}

std::string calib_text(const Simulator& sim) {
  const StereoCamera& cam = sim.camera();
  std::ostringstream calib;
  calib << std::setprecision(12);
  calib << "P0: " << cam.fx << " 0 " << cam.cx << " 0 0 " << cam.fy << " " << cam.cy << " 0 0 0 1 0\n";
  calib << "P1: " << cam.fx << " 0 " << cam.cx << " " << -cam.fx * cam.baseline_m << " 0 " << cam.fy << " "
        << cam.cy << " 0 0 0 1 0\n";
  if (sim.distorted()) {
    const DistortionSpec& d = sim.scenario().realism.distortion;
    for (const char* key : {"D0: ", "D1: "})
      calib << key << d.k1 << " " << d.k2 << " " << d.p1 << " " << d.p2 << "\n";
  }
  return calib.str();
}

// The per-frame texts and figures, filled while rendering.
struct FrameTables {
  std::ostringstream times, poses, boxes;
  std::ostringstream parts;  // articulated machines: one row per visible part
  io::Trajectory truth;      // the same poses, TUM
  io::Json occlusion = io::Json::array();
  io::Json machine_occlusion = io::Json::array();
  io::Json gains = io::Json::array();

  FrameTables() {
    times << std::setprecision(12);
    poses << std::setprecision(12);
    boxes << "frame,instance,class,x,y,w,h,moving\n";
    parts << "frame,instance,part,name,x,y,w,h,moving\n";
  }

  void add(int k, const SimFrame& f) {
    times << f.t_s << "\n";
    write_3x4(poses, f.T_world_cam.matrix3x4());
    poses << "\n";
    truth.push_back({f.t_s, f.T_world_cam});
    for (const ObjectTruth& o : f.objects) {
      if (!o.visible) continue;
      boxes << k << "," << o.instance << "," << o.class_name << "," << o.box.x << "," << o.box.y << ","
            << o.box.width << "," << o.box.height << "," << (o.moving ? 1 : 0) << "\n";
      for (const PartTruth& p : o.parts) {
        if (!p.visible) continue;
        parts << k << "," << o.instance << "," << static_cast<int>(p.part) << "," << p.name << "," << p.box.x
              << "," << p.box.y << "," << p.box.width << "," << p.box.height << "," << (p.moving ? 1 : 0)
              << "\n";
      }
    }
    occlusion.push_back(f.occlusion_ratio);
    machine_occlusion.push_back(f.machine_occlusion_ratio);
    gains.push_back(f.exposure_gain);
  }
};

std::string meta_json(const Simulator& sim, int frames, bool partial, const FrameTables& tables) {
  const StereoCamera& cam = sim.camera();
  const Scenario& sc = sim.scenario();
  io::Json camera{{"width", cam.width},
                  {"height", cam.height},
                  {"fx", cam.fx},
                  {"fy", cam.fy},
                  {"cx", cam.cx},
                  {"cy", cam.cy},
                  {"baseline_m", cam.baseline_m},
                  {"rectified", !sim.distorted()}};
  if (sim.distorted()) {
    const DistortionSpec& d = sc.realism.distortion;
    camera["distortion"] = {{"model", "plumb_bob"}, {"k1", d.k1}, {"k2", d.k2}, {"p1", d.p1}, {"p2", d.p2}};
  }
  const Eigen::Matrix<double, 3, 4> T = sim.T_site_world().matrix3x4();
  io::Json T_site_world = io::Json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T_site_world.push_back(T(r, c));
  io::Json meta{
      {"generator", "sitepose sim"},
      {"scenario", sc.name},
      {"description", sc.description},
      {"seed", sc.seed},
      {"fps", sc.fps},
      {"frames", frames},
      {"partial", partial},
      {"camera", camera},
      {"world_frame", "left camera at frame 0 (x right, y down, z forward)"},
      {"T_site_world", T_site_world},
      {"T_site_world_layout", "row-major 3x4 [R | t]"},
      {"site_frame", "x along the ego lane, y left of +x, z up, ground z = 0"},
      {"moving", "1 when the object's site pose differs from the previous frame (frame 0: from frame 1)"},
      {"occlusion_ratio_definition", "fraction of left-image pixels on any labelled object, cones included"},
      {"occlusion_ratio", tables.occlusion},
      {"machine_occlusion_ratio", tables.machine_occlusion},
      {"exposure_gain", tables.gains}};
  return io::to_json_text(meta);
}

Expected<WriteSummary> write_into(const Simulator& sim, const fs::path& dir, const WriteOptions& options) {
  SITEPOSE_TRY_STATUS(io::write_text_file(dir / "calib.txt", calib_text(sim)));
  if (sim.has_articulated()) {
    std::error_code ec;
    fs::create_directories(dir / "labels" / "parts", ec);
    if (ec) return make_error(ErrorCode::kIoError, "cannot create " + (dir / "labels" / "parts").string());
  }
  FrameTables tables;
  WriteSummary summary;
  const int n = sim.frame_count();
  for (int k = 0; k < n; ++k) {
    if (options.stop && options.stop()) {
      summary.partial = true;
      break;
    }
    const SimFrame f = sim.render(k);
    SITEPOSE_TRY_STATUS(write_png(dir / "image_0" / frame_name(k), f.left));
    SITEPOSE_TRY_STATUS(write_png(dir / "image_1" / frame_name(k), f.right));
    SITEPOSE_TRY_STATUS(write_png(dir / "labels" / "masks" / frame_name(k), f.instance_mask));
    if (sim.has_articulated()) {
      SITEPOSE_TRY_STATUS(write_png(dir / "labels" / "parts" / frame_name(k), f.part_mask));
    }
    tables.add(k, f);
    summary.frames = k + 1;
    summary.max_occlusion_ratio = std::max(summary.max_occlusion_ratio, f.occlusion_ratio);
    summary.mean_occlusion_ratio += f.occlusion_ratio;
    if (options.progress) options.progress(k + 1, n);
  }
  if (summary.frames > 0) summary.mean_occlusion_ratio /= summary.frames;
  SITEPOSE_TRY_STATUS(io::write_text_file(dir / "times.txt", tables.times.str()));
  SITEPOSE_TRY_STATUS(io::write_text_file(dir / "poses.txt", tables.poses.str()));
  SITEPOSE_TRY_STATUS(io::write_tum_trajectory((dir / "poses_tum.txt").string(), tables.truth));
  SITEPOSE_TRY_STATUS(io::write_text_file(dir / "labels" / "boxes.csv", tables.boxes.str()));
  if (sim.has_articulated())
    SITEPOSE_TRY_STATUS(io::write_text_file(dir / "labels" / "parts.csv", tables.parts.str()));
  SITEPOSE_TRY_STATUS(
      io::write_text_file(dir / "meta.json", meta_json(sim, summary.frames, summary.partial, tables)));
  return summary;
}

}  // namespace

Status check_sequence_output(const std::string& dir, bool force) {
  return check_output_dir(fs::path(dir), force);
}

Expected<WriteSummary> write_sequence(const Simulator& sim, const std::string& dir_str,
                                      const WriteOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  fs::path dir = fs::absolute(fs::path(dir_str)).lexically_normal();
  if (!dir.has_filename()) dir = dir.parent_path();
  SITEPOSE_TRY_STATUS(check_output_dir(dir, options.force));
  SITEPOSE_TRY(const fs::path staging, make_staging_dir(dir));
  auto written = write_into(sim, staging, options);
  if (written) {
    if (auto st = publish(staging, dir); !st) written = make_error(st.error().code, st.error().message);
  }
  if (!written) {
    std::error_code ec;
    fs::remove_all(staging, ec);
    return written;
  }
  written->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return written;
}

}  // namespace sitepose::sim
