#include "sitepose/views/report_html.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "sitepose/eval/evaluate.hpp"
#include "sitepose/io/json_file.hpp"
#include "sitepose/io/text_file.hpp"
#include "sitepose/views/frame_view.hpp"

// Charts are drawn here as SVG text (no plotting library, no script): a page
// that opens anywhere, offline, and diffs as text.

namespace sitepose::views {
namespace {

using dynamic::MotionState;

constexpr const char* kEstimateColour = "#2a9d3a";
constexpr const char* kGtColour = "#555555";
constexpr const char* kStaticColour = "#00a0e0";
constexpr const char* kMovingColour = "#e000e0";
constexpr const char* kUnknownColour = "#ffa000";
constexpr const char* kNoVerdictColour = "#bbbbbb";

std::string num(double v, int precision = 3) {
  if (!std::isfinite(v)) return "-";
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", precision, v);
  return text;
}

std::string escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

struct Series {
  std::string name;
  std::string colour;
  std::vector<std::pair<double, double>> points;  // NaN y = a gap
};

struct Range {
  double lo = 0.0;
  double hi = 1.0;
  double span() const { return hi - lo; }
};

Range range_of(const std::vector<Series>& series, bool x, bool from_zero) {
  double lo = from_zero ? 0.0 : INFINITY;
  double hi = -INFINITY;
  for (const auto& s : series) {
    for (const auto& [px, py] : s.points) {
      const double v = x ? px : py;
      if (!std::isfinite(v)) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (!std::isfinite(lo) || !std::isfinite(hi)) return {};
  if (hi - lo < 1e-12) hi = lo + 1.0;
  return {lo, hi};
}

// Axes with five ticks each, inside a w x h SVG with margins.
void axes(std::ostringstream& svg, int w, int h, const Range& xr, const Range& yr, const std::string& x_label,
          const std::string& y_label) {
  const int l = 60, r = 10, t = 10, b = 40;
  svg << "<line x1='" << l << "' y1='" << h - b << "' x2='" << w - r << "' y2='" << h - b
      << "' stroke='#333'/><line x1='" << l << "' y1='" << t << "' x2='" << l << "' y2='" << h - b
      << "' stroke='#333'/>";
  for (int i = 0; i <= 4; ++i) {
    const double fx = l + (w - l - r) * i / 4.0;
    const double fy = (h - b) - (h - b - t) * i / 4.0;
    svg << "<text x='" << fx << "' y='" << h - b + 14 << "' font-size='10' text-anchor='middle'>"
        << num(xr.lo + xr.span() * i / 4.0) << "</text>";
    svg << "<text x='" << l - 4 << "' y='" << fy + 3 << "' font-size='10' text-anchor='end'>"
        << num(yr.lo + yr.span() * i / 4.0) << "</text>";
    svg << "<line x1='" << l << "' y1='" << fy << "' x2='" << w - r << "' y2='" << fy << "' stroke='#eee'/>";
  }
  svg << "<text x='" << (l + w - r) / 2 << "' y='" << h - 6 << "' font-size='11' text-anchor='middle'>"
      << escape(x_label) << "</text>";
  svg << "<text x='12' y='" << (t + h - b) / 2
      << "' font-size='11' text-anchor='middle' transform='rotate(-90 12 " << (t + h - b) / 2 << ")'>"
      << escape(y_label) << "</text>";
}

std::string line_chart(const std::string& x_label, const std::string& y_label,
                       const std::vector<Series>& series, int w = 760, int h = 220) {
  const int l = 60, r = 10, t = 10, b = 40;
  const Range xr = range_of(series, true, false);
  const Range yr = range_of(series, false, true);
  std::ostringstream svg;
  svg << "<svg width='" << w << "' height='" << h << "' viewBox='0 0 " << w << ' ' << h << "'>";
  axes(svg, w, h, xr, yr, x_label, y_label);
  int legend_y = t + 12;
  for (const auto& s : series) {
    svg << "<path fill='none' stroke-width='1.5' stroke='" << s.colour << "' d='";
    bool pen_down = false;
    for (const auto& [x, y] : s.points) {
      if (!std::isfinite(y)) {
        pen_down = false;
        continue;
      }
      svg << (pen_down ? 'L' : 'M') << num(l + (x - xr.lo) / xr.span() * (w - l - r), 6) << ','
          << num((h - b) - (y - yr.lo) / yr.span() * (h - b - t), 6) << ' ';
      pen_down = true;
    }
    svg << "'/><text x='" << w - r - 4 << "' y='" << legend_y << "' font-size='11' text-anchor='end' fill='"
        << s.colour << "'>" << escape(s.name) << "</text>";
    legend_y += 14;
  }
  svg << "</svg>";
  return svg.str();
}

std::string histogram(const std::string& name, const std::vector<double>& samples, int w = 370, int h = 170) {
  const int l = 60, r = 10, t = 10, b = 40, bins = 20;
  const auto [min_it, max_it] = std::minmax_element(samples.begin(), samples.end());
  Range xr{*min_it, *max_it};
  if (xr.span() < 1e-9) xr.hi = xr.lo + 1.0;
  std::vector<int> counts(bins, 0);
  for (const double s : samples) {
    counts[std::min(bins - 1, static_cast<int>((s - xr.lo) / xr.span() * bins))]++;
  }
  const Range yr{0.0, static_cast<double>(std::max(1, *std::max_element(counts.begin(), counts.end())))};
  std::ostringstream svg;
  svg << "<figure class='hist'><svg width='" << w << "' height='" << h << "'>";
  axes(svg, w, h, xr, yr, name + " (ms)", "frames");
  const double bw = (w - l - r) / static_cast<double>(bins);
  for (int i = 0; i < bins; ++i) {
    const double bh = (h - b - t) * counts[i] / yr.hi;
    svg << "<rect x='" << num(l + i * bw, 6) << "' y='" << num(h - b - bh, 6) << "' width='" << num(bw - 1, 4)
        << "' height='" << num(bh, 6) << "' fill='#4a7bd0'/>";
  }
  std::vector<double> sorted = samples;
  std::sort(sorted.begin(), sorted.end());
  const double p50 = sorted[sorted.size() / 2];
  const double p99 = sorted[std::min(sorted.size() - 1, sorted.size() * 99 / 100)];
  svg << "</svg><figcaption>" << escape(name) << ": p50 " << num(p50) << " ms, p99 " << num(p99)
      << " ms</figcaption>"
      << "</figure>";
  return svg.str();
}

std::string top_view_svg(const std::vector<cv::Point2d>& est, const std::vector<cv::Point2d>& gt,
                         int size = 480) {
  std::vector<cv::Point2d> all(est);
  all.insert(all.end(), gt.begin(), gt.end());
  all.emplace_back(0.0, 0.0);
  const cv::Rect2d box = bounds_of(all);
  const double side = std::max({box.width, box.height, 1.0}) * 1.1;
  const double cx = box.x + box.width / 2.0;
  const double cy = box.y + box.height / 2.0;
  const double scale = size / side;
  auto path = [&](const std::vector<cv::Point2d>& track, const char* colour) {
    std::ostringstream d;
    d << "<path fill='none' stroke-width='2' stroke='" << colour << "' d='";
    for (std::size_t i = 0; i < track.size(); ++i) {
      d << (i == 0 ? 'M' : 'L') << num(size / 2.0 + (track[i].x - cx) * scale, 6) << ','
        << num(size / 2.0 - (track[i].y - cy) * scale, 6) << ' ';
    }
    d << "'/>";
    return d.str();
  };
  std::ostringstream svg;
  svg << "<svg width='" << size << "' height='" << size << "' style='background:#fafafa'>"
      << path(gt, kGtColour) << path(est, kEstimateColour) << "<text x='8' y='16' font-size='11' fill='"
      << kEstimateColour << "'>estimate</text><text x='8' y='30' font-size='11' fill='" << kGtColour
      << "'>ground truth</text><text x='8' y='" << size - 8 << "' font-size='11'>x right / z forward, "
      << num(side) << " m across</text></svg>";
  return svg.str();
}

struct Context {
  const DebugRecord& record;
  const GroundTruth* gt;
  std::optional<eval::EvalResult> evaluation;
  std::string evaluation_error;
};

double frame_time_s(const FrameRecord& f) { return static_cast<double>(f.t_ns) * 1e-9; }

void evaluate_run(Context& c) {
  io::Trajectory gt;
  for (std::size_t i = 0; c.gt != nullptr && i < c.gt->poses.size() && i < c.gt->times_s.size(); ++i) {
    if (c.gt->poses[i]) gt.push_back({c.gt->times_s[i], *c.gt->poses[i]});
  }
  if (gt.empty()) {
    c.evaluation_error = "no ground truth given (--gt)";
    return;
  }
  io::Trajectory est;
  for (const auto& f : c.record.frames) {
    if (f.state != TrackingState::kLost) est.push_back({frame_time_s(f), f.T_world_cam});
  }
  auto result = eval::evaluate(gt, est, eval::EvalOptions{});
  if (result) {
    c.evaluation = std::move(*result);
  } else {
    c.evaluation_error = result.error().message;
  }
}

std::string summary_section(const Context& c) {
  const auto& frames = c.record.frames;
  const auto ok = std::count_if(frames.begin(), frames.end(),
                                [](const auto& f) { return f.state == TrackingState::kOk; });
  const auto pixel =
      std::count_if(frames.begin(), frames.end(), [](const auto& f) { return f.pixel_mask_used; });
  double total_ms = 0.0;
  for (const auto& f : frames) total_ms += f.timings.total_ms;
  const auto& info = c.record.info;
  std::ostringstream s;
  s << "<table><tr><th>sequence</th><td>" << escape(info.sequence.empty() ? info.scenario : info.sequence)
    << "</td></tr><tr><th>mode / detector</th><td>" << escape(info.mode) << " / "
    << escape(info.detector.empty() ? "-" : info.detector) << "</td></tr><tr><th>images</th><td>"
    << info.width << " x " << info.height << " at " << num(info.fps) << " Hz</td></tr><tr><th>frames</th><td>"
    << frames.size() << ", tracked OK " << ok << " ("
    << num(frames.empty() ? 0.0 : 100.0 * ok / frames.size()) << " %)</td></tr>"
    << "<tr><th>mean frame time</th><td>" << num(frames.empty() ? 0.0 : total_ms / frames.size())
    << " ms</td></tr>"
    << "<tr><th>pixel-mask calls</th><td>" << pixel << "</td></tr><tr><th>map at the end</th><td>"
    << (frames.empty() ? 0 : frames.back().trace.keyframes_in_map) << " keyframes, "
    << (frames.empty() ? 0 : frames.back().trace.points_in_map) << " points</td></tr></table>";
  return s.str();
}

std::string accuracy_section(const Context& c) {
  if (!c.evaluation) return "<p>Accuracy not evaluated: " + escape(c.evaluation_error) + ".</p>";
  const eval::EvalResult& e = *c.evaluation;
  std::ostringstream s;
  s << "<table><tr><th></th><th>rmse</th><th>median</th><th>max</th></tr>"
    << "<tr><th>ATE (m)</th><td>" << num(e.ate_m.rmse, 4) << "</td><td>" << num(e.ate_m.median, 4)
    << "</td><td>" << num(e.ate_m.max, 4) << "</td></tr><tr><th>RPE 1 s (m)</th><td>"
    << num(e.rpe_time.translation_m.rmse, 4) << "</td><td>" << num(e.rpe_time.translation_m.median, 4)
    << "</td><td>" << num(e.rpe_time.translation_m.max, 4) << "</td></tr><tr><th>RPE 1 s (deg)</th><td>"
    << num(e.rpe_time.rotation_deg.rmse, 4) << "</td><td>" << num(e.rpe_time.rotation_deg.median, 4)
    << "</td><td>" << num(e.rpe_time.rotation_deg.max, 4) << "</td></tr><tr><th>RPE 10 frames (m)</th><td>"
    << num(e.rpe_frames.translation_m.rmse, 4) << "</td><td>" << num(e.rpe_frames.translation_m.median, 4)
    << "</td><td>" << num(e.rpe_frames.translation_m.max, 4)
    << "</td></tr></table><p>SE(3) alignment, no scale; coverage " << num(100.0 * e.coverage) << " % of "
    << e.gt_frames << " ground-truth frames.</p>";
  Series error{"ATE per frame", kEstimateColour, {}};
  for (const auto& p : e.poses) error.points.emplace_back(p.t_gt_s, p.error_m);
  s << line_chart("time (s)", "position error (m)", {error});
  return s.str();
}

std::string trajectory_section(const Context& c) {
  std::vector<cv::Point2d> est;
  std::vector<cv::Point2d> gt;
  if (c.evaluation) {
    // Both in the ground truth's world after the alignment.
    for (const auto& p : c.evaluation->poses) {
      est.emplace_back(p.p_est_aligned_m.x(), p.p_est_aligned_m.z());
      gt.emplace_back(p.p_gt_m.x(), p.p_gt_m.z());
    }
  } else {
    for (const auto& f : c.record.frames) {
      if (f.state != TrackingState::kLost)
        est.emplace_back(f.T_world_cam.translation().x(), f.T_world_cam.translation().z());
    }
  }
  return top_view_svg(est, gt) + "<p>Top view (x, z of the " +
         std::string(c.evaluation ? "ground truth's world, estimate aligned" : "first camera") + ").</p>";
}

std::string timing_section(const Context& c) {
  std::map<std::string, std::vector<double>> samples;
  std::vector<std::string> order;
  for (const auto& f : c.record.frames) {
    for (const auto& [name, ms] : stage_times(f.timings)) {
      if (samples.find(name) == samples.end()) order.push_back(name);
      samples[name].push_back(ms);
    }
  }
  std::ostringstream s;
  s << "<div class='grid'>";
  for (const auto& name : order) {
    const auto& values = samples[name];
    if (std::all_of(values.begin(), values.end(), [](double v) { return v == 0.0; })) continue;
    s << histogram(name, values);
  }
  s << "</div>";
  return s.str();
}

std::string masking_section(const Context& c) {
  Series mar{"mar (box union)", "#d04a4a", {}};
  Series masked{"masked pixels", "#4a7bd0", {}};
  Series pixel{"pixel mask requested (1)", "#222222", {}};
  int calls = 0;
  for (const auto& f : c.record.frames) {
    const double t = frame_time_s(f);
    mar.points.emplace_back(t, f.mar);
    masked.points.emplace_back(t, f.masked_ratio);
    pixel.points.emplace_back(t, f.pixel_mask_used ? 1.0 : NAN);
    calls += f.pixel_mask_used ? 1 : 0;
  }
  std::vector<Series> series{mar, masked};
  if (c.gt != nullptr && !c.gt->occlusion_ratio.empty()) {
    const std::vector<double>& occlusion = c.gt->occlusion_ratio;
    Series gt{"occlusion (ground truth)", kGtColour, {}};
    for (const auto& f : c.record.frames) {
      const auto seq = static_cast<std::size_t>(f.seq);
      if (seq < occlusion.size()) gt.points.emplace_back(frame_time_s(f), occlusion[seq]);
    }
    if (!gt.points.empty()) series.push_back(gt);
  }
  // Pixel-mask frames as dots on the 1 line.
  for (auto& p : pixel.points) {
    if (std::isfinite(p.second))
      series.push_back({"", "#222222", {{p.first - 0.01, 1.0}, {p.first + 0.01, 1.0}}});
  }
  std::ostringstream s;
  s << "<p>Pixel-mask calls: " << calls << " of " << c.record.frames.size()
    << " frames (marks on the 1 line).</p>" << line_chart("time (s)", "fraction of the image", series);
  return s.str();
}

std::string state_colour(MotionState state) {
  switch (state) {
    case MotionState::kStatic: return kStaticColour;
    case MotionState::kMoving: return kMovingColour;
    case MotionState::kUnknown: break;
  }
  return kUnknownColour;
}

// Per instance: its colour per frame index (empty = not in the frame).
using Timeline = std::map<std::uint16_t, std::map<std::size_t, std::string>>;

Timeline run_timeline(const DebugRecord& record) {
  Timeline rows;
  for (std::size_t i = 0; i < record.frames.size(); ++i) {
    const auto& f = record.frames[i];
    for (const auto& b : f.trace.boxes) rows[b.instance][i] = kNoVerdictColour;
    for (const auto& v : f.objects) rows[v.instance][i] = state_colour(v.state);
  }
  return rows;
}

Timeline gt_timeline(const DebugRecord& record, const GroundTruth& gt) {
  Timeline rows;
  for (std::size_t i = 0; i < record.frames.size(); ++i) {
    const auto it = gt.moving.find(record.frames[i].seq);
    if (it == gt.moving.end()) continue;
    for (const auto& [instance, moving] : it->second) {
      rows[instance][i] = !moving ? kNoVerdictColour : (*moving ? kMovingColour : kStaticColour);
    }
  }
  return rows;
}

std::string motion_section(const Context& c) {
  const Timeline run = run_timeline(c.record);
  const Timeline gt = c.gt != nullptr ? gt_timeline(c.record, *c.gt) : Timeline{};
  if (run.empty()) return "<p>No objects of the dynamic classes in this run.</p>";
  const int w = 760, l = 130, row = 14;
  const double fw = (w - l) / static_cast<double>(std::max<std::size_t>(1, c.record.frames.size()));
  std::ostringstream svg;
  int y = 4;
  auto draw_row = [&](const std::string& label, const std::map<std::size_t, std::string>& cells) {
    svg << "<text x='0' y='" << y + 11 << "' font-size='11'>" << escape(label) << "</text>";
    for (const auto& [i, colour] : cells) {
      svg << "<rect x='" << num(l + i * fw, 6) << "' y='" << y << "' width='" << num(std::max(fw, 1.0), 4)
          << "' height='" << row - 2 << "' fill='" << colour << "'/>";
    }
    y += row;
  };
  std::ostringstream rows;
  for (const auto& [instance, cells] : run) {
    draw_row("#" + std::to_string(instance) + " run", cells);
    if (const auto it = gt.find(instance); it != gt.end())
      draw_row("#" + std::to_string(instance) + " truth", it->second);
    y += 4;
  }
  std::ostringstream s;
  s << "<svg width='" << w << "' height='" << y + 4 << "'>" << svg.str() << "</svg><p class='legend'>"
    << "<span style='color:" << kStaticColour
    << "'>&#9632; static (unmasked)</span> <span style='color:" << kMovingColour
    << "'>&#9632; moving</span> <span style='color:" << kUnknownColour
    << "'>&#9632; unknown</span> <span style='color:" << kNoVerdictColour
    << "'>&#9632; masked without a verdict / truth unknown</span>; one column per frame ("
    << c.record.frames.size() << ").</p>";
  return s.str();
}

std::string map_section(const Context& c) {
  Series keyframes{"keyframes in map", "#4a7bd0", {}};
  Series points{"map points", "#d04a4a", {}};
  Series inliers{"inliers (final)", kEstimateColour, {}};
  for (const auto& f : c.record.frames) {
    keyframes.points.emplace_back(frame_time_s(f), static_cast<double>(f.trace.keyframes_in_map));
    points.points.emplace_back(frame_time_s(f), static_cast<double>(f.trace.points_in_map));
    inliers.points.emplace_back(frame_time_s(f), f.counters.features_used);
  }
  return line_chart("time (s)", "keyframes", {keyframes}) +
         line_chart("time (s)", "points / inliers", {points, inliers});
}

}  // namespace

const std::vector<std::string>& report_sections() {
  static const std::vector<std::string> sections{
      "summary", "accuracy", "trajectory", "timing", "masking", "motion-states", "map", "config", "build"};
  return sections;
}

Expected<std::vector<double>> read_occlusion_ratios(const std::string& meta_json_path) {
  SITEPOSE_TRY(const io::Json meta, io::read_json_file(meta_json_path));
  std::vector<double> values;
  if (!meta.is_object() || !meta.contains("occlusion_ratio")) return values;
  const io::Json& list = meta["occlusion_ratio"];
  const auto bad =
      make_error(ErrorCode::kParseError, meta_json_path + ": \"occlusion_ratio\" is not a list of numbers");
  if (!list.is_array()) return bad;
  for (const io::Json& v : list) {
    // The writer turns a NaN into null (io::to_json_text).
    if (v.is_null()) {
      values.push_back(std::numeric_limits<double>::quiet_NaN());
    } else if (v.is_number()) {
      values.push_back(v.get<double>());
    } else {
      return bad;
    }
  }
  return values;
}

Expected<GroundTruth> ground_truth_of(const io::Sequence& sequence) {
  GroundTruth gt;
  gt.poses = sequence.gt_poses();
  for (std::size_t i = 0; i < sequence.size(); ++i)
    gt.times_s.push_back(static_cast<double>(sequence.time_ns(i)) * 1e-9);
  for (const auto& b : sequence.boxes())
    gt.moving[b.frame][static_cast<std::uint16_t>(b.instance)] = b.moving;
  if (const auto meta = sequence.meta_json_path()) {
    SITEPOSE_TRY(gt.occlusion_ratio, read_occlusion_ratios(*meta));
  }
  return gt;
}

std::string render_report_html(const DebugRecord& record, const GroundTruth* gt,
                               const std::string& generator) {
  Context c{record, gt, std::nullopt, {}};
  evaluate_run(c);
  const std::vector<std::pair<std::string, std::string>> bodies{
      {"Summary", summary_section(c)},
      {"Accuracy (ATE / RPE)", accuracy_section(c)},
      {"Trajectory", trajectory_section(c)},
      {"Time per stage", timing_section(c)},
      {"Masking: mar, occlusion, pixel masks", masking_section(c)},
      {"Motion states per object", motion_section(c)},
      {"Keyframes and map size", map_section(c)},
      {"Configuration used", "<pre>" + escape(record.config_yaml) + "</pre>"},
      {"Build", "<p>run by sitepose " + escape(record.info.version) + " (" + escape(record.info.revision) +
                    "); report by " + escape(generator) + "</p>"}};
  std::ostringstream html;
  html << "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>sitepose run "
          "report</title><style>"
       << "body{font-family:sans-serif;margin:20px;max-width:820px;color:#222}h1{font-size:22px}"
       << "h2{font-size:17px;border-bottom:1px solid #ccc;margin-top:28px}table{border-collapse:collapse}"
       << "th,td{border:1px solid #ddd;padding:3px 8px;text-align:left;font-size:13px}"
       << "pre{background:#f4f4f4;padding:8px;font-size:11px;max-height:300px;overflow:auto}"
       << ".grid{display:flex;flex-wrap:wrap}.hist{margin:4px}figcaption{font-size:12px}"
       << "</style></head><body><h1>sitepose run report</h1>";
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    html << "<section id='" << report_sections()[i] << "'><h2>" << escape(bodies[i].first) << "</h2>"
         << bodies[i].second << "</section>";
  }
  html << "</body></html>\n";
  return html.str();
}

Expected<std::string> write_report(const DebugRecord& record, const GroundTruth* gt,
                                   const std::string& generator, const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIoError, "cannot create " + dir + ": " + ec.message());
  const std::string path = (std::filesystem::path(dir) / "report.html").string();
  SITEPOSE_TRY_STATUS(io::write_text_file(path, render_report_html(record, gt, generator)));
  return path;
}

}  // namespace sitepose::views
