#include "sitepose/sim/sequence_writer.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

namespace sitepose::sim {
namespace {

namespace fs = std::filesystem;

std::string frame_name(int k) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06d.png", k);
  return buf;
}

std::string json_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

void write_3x4(std::ostream& out, const Eigen::Matrix<double, 3, 4>& M) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) out << (r || c ? " " : "") << M(r, c);
}

Status write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  out.close();
  if (!out) return make_error(ErrorCode::kIoError, "cannot write " + path.string());
  return ok_status();
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

Status prepare_dir(const fs::path& dir, bool force) {
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) {
      return make_error(ErrorCode::kInvalidArgument,
                        "output " + dir.string() + " exists and is not a folder");
    }
    if (!fs::is_empty(dir, ec)) {
      if (!force) {
        return make_error(
            ErrorCode::kInvalidArgument,
            "output folder " + dir.string() + " is not empty (use --force to replace the sequence in it)");
      }
      for (const char* name :
           {"image_0", "image_1", "labels", "calib.txt", "times.txt", "poses.txt", "meta.json"}) {
        fs::remove_all(dir / name, ec);
        if (ec)
          return make_error(ErrorCode::kIoError,
                            "cannot remove " + (dir / name).string() + ": " + ec.message());
      }
    }
  }
  for (const char* sub : {"image_0", "image_1", "labels/masks"}) {
    fs::create_directories(dir / sub, ec);
    if (ec)
      return make_error(ErrorCode::kIoError, "cannot create " + (dir / sub).string() + ": " + ec.message());
  }
  return ok_status();
}

}  // namespace

Expected<WriteSummary> write_sequence(const Simulator& sim, const std::string& dir_str,
                                      const WriteOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const fs::path dir(dir_str);
  SITEPOSE_TRY_STATUS(prepare_dir(dir, options.force));
  const StereoCamera& cam = sim.camera();
  const Scenario& sc = sim.scenario();

  std::ostringstream calib;
  calib << std::setprecision(12);
  calib << "P0: " << cam.fx << " 0 " << cam.cx << " 0 0 " << cam.fy << " " << cam.cy << " 0 0 0 1 0\n";
  calib << "P1: " << cam.fx << " 0 " << cam.cx << " " << -cam.fx * cam.baseline_m << " 0 " << cam.fy << " "
        << cam.cy << " 0 0 0 1 0\n";
  if (sim.distorted()) {
    const DistortionSpec& d = sc.realism.distortion;
    for (const char* key : {"D0: ", "D1: "})
      calib << key << d.k1 << " " << d.k2 << " " << d.p1 << " " << d.p2 << "\n";
  }
  SITEPOSE_TRY_STATUS(write_text(dir / "calib.txt", calib.str()));

  std::ostringstream times, poses, boxes, occlusion, machine_occlusion, gains;
  times << std::setprecision(12);
  poses << std::setprecision(12);
  boxes << "frame,instance,class,x,y,w,h,moving\n";
  // Articulated machines: one row per visible part, and part masks.
  std::ostringstream parts;
  parts << "frame,instance,part,name,x,y,w,h,moving\n";
  if (sim.has_articulated()) {
    std::error_code ec;
    fs::create_directories(dir / "labels" / "parts", ec);
    if (ec) return make_error(ErrorCode::kIoError, "cannot create " + (dir / "labels" / "parts").string());
  }
  WriteSummary summary;
  const int n = sim.frame_count();
  for (int k = 0; k < n; ++k) {
    const SimFrame f = sim.render(k);
    SITEPOSE_TRY_STATUS(write_png(dir / "image_0" / frame_name(k), f.left));
    SITEPOSE_TRY_STATUS(write_png(dir / "image_1" / frame_name(k), f.right));
    SITEPOSE_TRY_STATUS(write_png(dir / "labels" / "masks" / frame_name(k), f.instance_mask));
    times << f.t_s << "\n";
    write_3x4(poses, f.T_world_cam.matrix3x4());
    poses << "\n";
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
    if (sim.has_articulated()) {
      SITEPOSE_TRY_STATUS(write_png(dir / "labels" / "parts" / frame_name(k), f.part_mask));
    }
    occlusion << (k ? "," : "") << std::setprecision(5) << f.occlusion_ratio;
    machine_occlusion << (k ? "," : "") << std::setprecision(5) << f.machine_occlusion_ratio;
    gains << (k ? "," : "") << std::setprecision(5) << f.exposure_gain;
    summary.max_occlusion_ratio = std::max(summary.max_occlusion_ratio, f.occlusion_ratio);
    summary.mean_occlusion_ratio += f.occlusion_ratio / n;
    if (options.progress) options.progress(k + 1, n);
  }
  SITEPOSE_TRY_STATUS(write_text(dir / "times.txt", times.str()));
  SITEPOSE_TRY_STATUS(write_text(dir / "poses.txt", poses.str()));
  SITEPOSE_TRY_STATUS(write_text(dir / "labels" / "boxes.csv", boxes.str()));
  if (sim.has_articulated()) SITEPOSE_TRY_STATUS(write_text(dir / "labels" / "parts.csv", parts.str()));

  std::ostringstream meta;
  meta << std::setprecision(12);
  meta << "{\n  \"generator\": \"sitepose sim\",\n";
  meta << "  \"scenario\": \"" << json_escape(sc.name) << "\",\n";
  meta << "  \"description\": \"" << json_escape(sc.description) << "\",\n";
  meta << "  \"seed\": " << sc.seed << ",\n  \"fps\": " << sc.fps << ",\n  \"frames\": " << n << ",\n";
  meta << "  \"camera\": {\"width\": " << cam.width << ", \"height\": " << cam.height
       << ", \"fx\": " << cam.fx << ", \"fy\": " << cam.fy << ", \"cx\": " << cam.cx << ", \"cy\": " << cam.cy
       << ", \"baseline_m\": " << cam.baseline_m
       << ", \"rectified\": " << (sim.distorted() ? "false" : "true");
  if (sim.distorted()) {
    const DistortionSpec& d = sc.realism.distortion;
    meta << ", \"distortion\": {\"model\": \"plumb_bob\", \"k1\": " << d.k1 << ", \"k2\": " << d.k2
         << ", \"p1\": " << d.p1 << ", \"p2\": " << d.p2 << "}";
  }
  meta << "},\n";
  meta << "  \"world_frame\": \"left camera at frame 0 (x right, y down, z forward)\",\n";
  meta << "  \"T_site_world\": [";
  write_3x4(meta, sim.T_site_world().matrix3x4());
  meta << "],\n";
  meta << "  \"site_frame\": \"x along the ego lane, y left of +x, z up, ground z = 0\",\n";
  meta << "  \"moving\": \"1 when the object's site pose differs from the previous frame (frame 0: from "
          "frame 1)\",\n";
  meta << "  \"occlusion_ratio_definition\": \"fraction of left-image pixels on any labelled object, cones "
          "included\",\n";
  meta << "  \"occlusion_ratio\": [" << occlusion.str() << "],\n";
  meta << "  \"machine_occlusion_ratio\": [" << machine_occlusion.str() << "],\n";
  meta << "  \"exposure_gain\": [" << gains.str() << "]\n}\n";
  SITEPOSE_TRY_STATUS(write_text(dir / "meta.json", meta.str()));

  summary.frames = n;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace sitepose::sim
