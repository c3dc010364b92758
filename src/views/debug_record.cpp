#include "sitepose/views/debug_record.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "sitepose/core/stopwatch.hpp"
#include "sitepose/io/text_file.hpp"

// frames.txt: a header line, then per frame
//   F seq t_ns state extracted inliers_pass1 inliers used_static mar masked_ratio
//     pixel pass1_known_static pass2_ran pass2_used pass2_rejected remasked
//     keyframes points keyframes_created tx ty tz qx qy qz qw
//   S <stage times, ms, in stage_times() order>
//   R <state reason>                       (only when there is one)
//   B instance class x y w h               (one per dynamic box)
//   O instance class raw state score pooled map_statistic|- points
//   K n (u v instance flags) x n           (all on one line)
// Class names have no spaces (FORMATS.md labels); one is replaced by '_'.

namespace sitepose::views {
namespace {

using dynamic::MotionState;

constexpr const char* kHeader = "# sitepose debug record 1";

std::string one_word(std::string s) {
  for (char& c : s) {
    if (c == ' ' || c == '\t' || c == '\n') c = '_';
  }
  return s.empty() ? std::string("-") : s;
}

void append(std::string& out, const char* format, auto... values) {
  char line[256];
  const int n = std::snprintf(line, sizeof line, format, values...);
  if (n > 0) out.append(line, std::min<std::size_t>(static_cast<std::size_t>(n), sizeof line - 1));
}

int state_index(MotionState state) { return static_cast<int>(state); }
MotionState state_from(int i) {
  return i == 1 ? MotionState::kStatic : i == 2 ? MotionState::kMoving : MotionState::kUnknown;
}

void append_frame_line(std::string& out, const slam::FrameReport& r) {
  const auto& c = r.pose.counters;
  const auto& t = r.pose.T_world_cam.translation();
  const auto& q = r.pose.T_world_cam.rotation();
  append(out, "F %lld %lld %d %d %d %d %d %.5f %.5f %d %d %d %d %d %d %zu %zu %d",
         static_cast<long long>(r.pose.seq), static_cast<long long>(r.pose.t_ns),
         static_cast<int>(r.pose.state), c.features_extracted, c.features_used_pass1, c.features_used,
         c.static_objects_unmasked, r.mar, r.masked_ratio, int{r.pixel_mask_used},
         int{r.pass1_with_known_static}, int{r.trace.pass2_ran}, int{r.trace.pass2_used},
         int{r.pass2_rejected}, r.remasked_by_map_check, r.trace.keyframes_in_map, r.trace.points_in_map,
         r.trace.keyframes_created);
  append(out, " %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  out += 'S';
  for (const auto& [name, ms] : stage_times(r.timings)) append(out, " %.3f", ms);
  out += '\n';
  if (!r.pose.state_reason.empty()) out += "R " + r.pose.state_reason + "\n";
  for (const auto& b : r.trace.boxes) {
    append(out, "B %u %s %d %d %d %d\n", unsigned{b.instance}, one_word(b.class_name).c_str(), b.box.x,
           b.box.y, b.box.width, b.box.height);
  }
  for (const auto& o : r.objects) {
    const auto& v = o.verdict;
    append(out, "O %u %s %d %d %.4g %.4g ", unsigned{v.instance}, one_word(v.class_name).c_str(),
           state_index(v.raw), state_index(v.state), v.score, v.pooled_statistic);
    if (v.map_statistic) {
      append(out, "%.4g", *v.map_statistic);
    } else {
      out += '-';
    }
    append(out, " %d\n", v.points);
  }
  append(out, "K %zu", r.trace.keypoints.size());
  for (const auto& k : r.trace.keypoints) {
    append(out, " %.1f %.1f %u %u", static_cast<double>(k.u_px), static_cast<double>(k.v_px),
           unsigned{k.instance}, unsigned{k.flags});
  }
  out += '\n';
}

}  // namespace

std::vector<std::pair<std::string, double>> stage_times(const slam::FrameTimings& t) {
  return {{"extract_left", t.extract_left_ms},
          {"extract_right", t.extract_right_ms},
          {"stereo_match", t.stereo_match_ms},
          {"prepare", t.prepare_ms},
          {"motion_model", t.motion_model_ms},
          {"local_map", t.local_map_ms},
          {"motion_ba", t.motion_ba_ms},
          {"mapping_inline", t.mapping_inline_ms},
          {"detect", t.detect_ms},
          {"mask", t.mask_ms},
          {"classify", t.classify_ms},
          {"pass2", t.pass2_ms},
          {"total", t.total_ms}};
}

Expected<std::unique_ptr<DebugRecordWriter>> DebugRecordWriter::open(const std::string& dir,
                                                                     const RunInfo& info,
                                                                     const std::string& config_yaml) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIoError, "cannot create " + dir + ": " + ec.message());
  std::ostringstream run;
  run << "version " << one_word(info.version) << "\nrevision " << one_word(info.revision) << "\nsequence "
      << one_word(info.sequence) << "\nscenario " << one_word(info.scenario) << "\nmode "
      << one_word(info.mode) << "\ndetector " << one_word(info.detector) << "\nwidth " << info.width
      << "\nheight " << info.height << "\nfps " << info.fps << "\n";
  const std::filesystem::path root(dir);
  SITEPOSE_TRY_STATUS(io::write_text_file(root / "run.txt", run.str()));
  SITEPOSE_TRY_STATUS(io::write_text_file(root / "config.yaml", config_yaml));
  const std::string frames = (root / "frames.txt").string();
  std::FILE* file = std::fopen(frames.c_str(), "w");
  if (file == nullptr)
    return make_error(ErrorCode::kIoError, "cannot write " + frames + ": " + std::strerror(errno));
  std::fprintf(file, "%s\n", kHeader);
  return std::unique_ptr<DebugRecordWriter>(new DebugRecordWriter(dir, file));
}

DebugRecordWriter::~DebugRecordWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

Status DebugRecordWriter::write(const slam::FrameReport& report) {
  const auto start = SteadyClock::now();
  buffer_.clear();
  append_frame_line(buffer_, report);
  if (file_ == nullptr || std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
    failed_ = true;
  write_ms_ += ms_since(start);
  if (failed_) return make_error(ErrorCode::kIoError, "cannot write " + dir_ + "/frames.txt");
  return ok_status();
}

Status DebugRecordWriter::close() {
  if (file_ == nullptr) return ok_status();
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (failed_ || !closed) return make_error(ErrorCode::kIoError, "cannot write " + dir_ + "/frames.txt");
  return ok_status();
}

namespace {

Error parse_error(const std::string& path, int line, const std::string& what) {
  return Error{ErrorCode::kInvalidArgument, path + ":" + std::to_string(line) + ": " + what};
}

bool parse_frame_line(std::istringstream& in, FrameRecord& f) {
  int state = 0;
  int flags[6] = {};
  double t[3];
  double q[4];
  in >> f.seq >> f.t_ns >> state >> f.counters.features_extracted >> f.counters.features_used_pass1 >>
      f.counters.features_used >> f.counters.static_objects_unmasked >> f.mar >> f.masked_ratio >> flags[0] >>
      flags[1] >> flags[2] >> flags[3] >> flags[4] >> f.remasked_by_map_check >> f.trace.keyframes_in_map >>
      f.trace.points_in_map >> f.trace.keyframes_created >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >>
      q[3];
  if (!in || state < 0 || state > 2) return false;
  f.state = static_cast<TrackingState>(state);
  f.pixel_mask_used = flags[0] != 0;
  f.pass1_with_known_static = flags[1] != 0;
  f.trace.pass2_ran = flags[2] != 0;
  f.trace.pass2_used = flags[3] != 0;
  f.pass2_rejected = flags[4] != 0;
  f.counters.masked_area_ratio = f.mar;
  f.T_world_cam =
      SE3(Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized(), Eigen::Vector3d(t[0], t[1], t[2]));
  return true;
}

bool parse_stage_line(std::istringstream& in, slam::FrameTimings& t) {
  for (double* ms : {&t.extract_left_ms, &t.extract_right_ms, &t.stereo_match_ms, &t.prepare_ms,
                     &t.motion_model_ms, &t.local_map_ms, &t.motion_ba_ms, &t.mapping_inline_ms, &t.detect_ms,
                     &t.mask_ms, &t.classify_ms, &t.pass2_ms, &t.total_ms}) {
    in >> *ms;
  }
  return static_cast<bool>(in);
}

bool parse_object_line(std::istringstream& in, dynamic::ObjectVerdict& v) {
  unsigned instance = 0;
  int raw = 0;
  int state = 0;
  std::string map_statistic;
  in >> instance >> v.class_name >> raw >> state >> v.score >> v.pooled_statistic >> map_statistic >>
      v.points;
  if (!in) return false;
  v.instance = static_cast<std::uint16_t>(instance);
  v.raw = state_from(raw);
  v.state = state_from(state);
  if (map_statistic != "-") v.map_statistic = std::strtod(map_statistic.c_str(), nullptr);
  return true;
}

// The keypoint line is the bulk of the record: parsed with strtod, not streams.
bool parse_keypoint_line(const std::string& line, std::vector<slam::KeypointTrace>& out) {
  const char* p = line.c_str() + 1;
  char* end = nullptr;
  const long n = std::strtol(p, &end, 10);
  if (end == p || n < 0) return false;
  p = end;
  out.resize(static_cast<std::size_t>(n));
  for (auto& k : out) {
    double v[4];
    for (double& x : v) {
      x = std::strtod(p, &end);
      if (end == p) return false;
      p = end;
    }
    k.u_px = static_cast<float>(v[0]);
    k.v_px = static_cast<float>(v[1]);
    k.instance = static_cast<std::uint16_t>(v[2]);
    k.flags = static_cast<std::uint8_t>(v[3]);
  }
  return true;
}

Status read_run_info(const std::filesystem::path& path, RunInfo& info) {
  std::ifstream in(path);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot read " + path.string());
  std::string key;
  std::string value;
  while (in >> key >> value) {
    if (value == "-") value.clear();
    if (key == "version") info.version = value;
    if (key == "revision") info.revision = value;
    if (key == "sequence") info.sequence = value;
    if (key == "scenario") info.scenario = value;
    if (key == "mode") info.mode = value;
    if (key == "detector") info.detector = value;
    if (key == "width") info.width = std::atoi(value.c_str());
    if (key == "height") info.height = std::atoi(value.c_str());
    if (key == "fps") info.fps = std::atof(value.c_str());
  }
  return ok_status();
}

}  // namespace

Expected<DebugRecord> read_debug_record(const std::string& dir) {
  DebugRecord record;
  const std::filesystem::path root(dir);
  SITEPOSE_TRY_STATUS(read_run_info(root / "run.txt", record.info));
  {
    std::ifstream config(root / "config.yaml");
    std::ostringstream text;
    text << config.rdbuf();
    record.config_yaml = text.str();
  }
  const std::string path = (root / "frames.txt").string();
  std::ifstream in(path);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot read " + path + " (not a --debug-out folder?)");
  std::string line;
  int number = 0;
  if (!std::getline(in, line) || line != kHeader)
    return Unexpected{parse_error(path, 1, "not a debug record")};
  ++number;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty()) continue;
    const char tag = line[0];
    if (tag != 'F' && record.frames.empty())
      return Unexpected{parse_error(path, number, "data before a frame")};
    std::istringstream fields(line.substr(1));
    bool ok = true;
    if (tag == 'F') {
      record.frames.emplace_back();
      ok = parse_frame_line(fields, record.frames.back());
    } else if (tag == 'S') {
      ok = parse_stage_line(fields, record.frames.back().timings);
    } else if (tag == 'R') {
      record.frames.back().state_reason = line.size() > 2 ? line.substr(2) : "";
    } else if (tag == 'B') {
      dynamic::ObjectBox b;
      unsigned instance = 0;
      fields >> instance >> b.class_name >> b.box.x >> b.box.y >> b.box.width >> b.box.height;
      b.instance = static_cast<std::uint16_t>(instance);
      ok = static_cast<bool>(fields);
      record.frames.back().trace.boxes.push_back(b);
    } else if (tag == 'O') {
      dynamic::ObjectVerdict v;
      ok = parse_object_line(fields, v);
      record.frames.back().objects.push_back(v);
    } else if (tag == 'K') {
      ok = parse_keypoint_line(line, record.frames.back().trace.keypoints);
    } else {
      ok = false;
    }
    if (!ok) return Unexpected{parse_error(path, number, std::string("cannot parse the '") + tag + "' line")};
  }
  return record;
}

}  // namespace sitepose::views
