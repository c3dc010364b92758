#include "sitepose/eval/evaluate.hpp"

#include <cmath>

#include <fmt/format.h>

#include "sitepose/eval/alignment.hpp"
#include "sitepose/eval/time_offset.hpp"

namespace sitepose::eval {
namespace {

Status check_options(const EvalOptions& o) {
  if (!std::isfinite(o.max_dt_s) || o.max_dt_s <= 0.0) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("max_dt_s = {}: must be a finite value > 0 (seconds)", o.max_dt_s));
  }
  if (!std::isfinite(o.time_offset_search_range_s) || o.time_offset_search_range_s < 0.0) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("time_offset_search_range_s = {}: must be >= 0 (0 = no search)",
                                  o.time_offset_search_range_s));
  }
  if (!std::isfinite(o.time_offset_s)) {
    return make_error(ErrorCode::kInvalidArgument, "time_offset_s: must be finite");
  }
  for (const RpeSpec* spec : {&o.rpe_time, &o.rpe_frames}) {
    if (spec->kind == RpeGapKind::kFrames && spec->delta_frames < 1) {
      return make_error(ErrorCode::kInvalidArgument,
                        fmt::format("RPE delta_frames = {}: must be >= 1", spec->delta_frames));
    }
    if (spec->kind == RpeGapKind::kTime &&
        !(spec->delta_time_s > 0.0 && spec->time_tolerance_s >= 0.0 &&
          spec->time_tolerance_s < spec->delta_time_s)) {
      return make_error(ErrorCode::kInvalidArgument,
                        fmt::format("RPE delta_time_s = {}, time_tolerance_s = {}: need "
                                    "delta > 0 and 0 <= tolerance < delta",
                                    spec->delta_time_s, spec->time_tolerance_s));
    }
  }
  return ok_status();
}

}  // namespace

Expected<EvalResult> evaluate(const io::Trajectory& gt, const io::Trajectory& est,
                              const EvalOptions& options) {
  SITEPOSE_TRY_STATUS(check_options(options));
  if (gt.empty()) {
    return make_error(ErrorCode::kInvalidArgument, "ground-truth trajectory is empty");
  }
  if (est.empty()) {
    return make_error(ErrorCode::kInvalidArgument, "estimated trajectory is empty");
  }
  SITEPOSE_TRY_STATUS(check_timestamps(gt, "ground-truth"));
  SITEPOSE_TRY_STATUS(check_timestamps(est, "estimated"));

  EvalResult r;
  r.gt_frames = gt.size();
  r.est_poses = est.size();
  r.max_dt_s = options.max_dt_s;
  r.time_offset_s = options.time_offset_s;
  if (options.time_offset_search_range_s > 0.0) {
    SITEPOSE_TRY(const TimeOffsetResult offset,
                 search_time_offset(gt, est, options.time_offset_search_range_s));
    r.time_offset_searched = true;
    r.time_offset_search_range_s = options.time_offset_search_range_s;
    r.time_offset_s = offset.time_offset_s;
  }

  const std::vector<AssociatedPair> pairs = associate(gt, est, options.max_dt_s, r.time_offset_s);
  if (pairs.size() < 3) {
    return make_error(
        ErrorCode::kInvalidArgument,
        fmt::format("only {} estimated poses associate with ground truth within {} s (time offset "
                    "{} s); at least 3 are needed. Ground truth spans {:.3f} .. {:.3f} s, the "
                    "estimate {:.3f} .. {:.3f} s",
                    pairs.size(), options.max_dt_s, r.time_offset_s, gt.front().t_s, gt.back().t_s,
                    est.front().t_s, est.back().t_s));
  }
  r.associated = pairs.size();
  r.coverage = static_cast<double>(pairs.size()) / static_cast<double>(gt.size());

  std::vector<Eigen::Vector3d> p_est;
  std::vector<Eigen::Vector3d> p_gt;
  p_est.reserve(pairs.size());
  p_gt.reserve(pairs.size());
  for (const auto& p : pairs) {
    p_est.push_back(est[p.est_index].T_world_cam.translation());
    p_gt.push_back(gt[p.gt_index].T_world_cam.translation());
  }
  SITEPOSE_TRY(r.T_gt_est, umeyama_se3(p_est, p_gt));

  std::vector<double> errors;
  errors.reserve(pairs.size());
  r.poses.reserve(pairs.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    PoseError pe;
    pe.gt_index = pairs[k].gt_index;
    pe.est_index = pairs[k].est_index;
    pe.t_gt_s = gt[pe.gt_index].t_s;
    pe.p_gt_m = p_gt[k];
    pe.p_est_aligned_m = r.T_gt_est * p_est[k];
    pe.error_m = (pe.p_est_aligned_m - pe.p_gt_m).norm();
    errors.push_back(pe.error_m);
    r.poses.push_back(pe);
  }
  r.ate_m = compute_stats(errors);
  r.rpe_time = compute_rpe(gt, est, pairs, options.rpe_time);
  r.rpe_frames = compute_rpe(gt, est, pairs, options.rpe_frames);
  return r;
}

namespace {

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  return fmt::format("{:.9g}", v);
}

std::string stats_json(const ErrorStats& s) {
  return fmt::format(
      R"({{"count": {}, "rmse": {}, "mean": {}, "median": {}, "std": {}, "min": {}, "max": {}}})",
      s.count, json_number(s.rmse), json_number(s.mean), json_number(s.median),
      json_number(s.std), json_number(s.min), json_number(s.max));
}

std::string rpe_json(const RpeResult& r) {
  const std::string gap =
      r.spec.kind == RpeGapKind::kTime
          ? fmt::format(R"("delta_s": {}, "tolerance_s": {})", json_number(r.spec.delta_time_s),
                        json_number(r.spec.time_tolerance_s))
          : fmt::format(R"("delta_frames": {})", r.spec.delta_frames);
  return fmt::format(R"({{{}, "pairs": {}, "translation_m": {}, "rotation_deg": {}}})", gap,
                     r.translation_m.count, stats_json(r.translation_m),
                     stats_json(r.rotation_deg));
}

std::string vec_json(const Eigen::Vector3d& v) {
  return fmt::format("[{}, {}, {}]", json_number(v.x()), json_number(v.y()), json_number(v.z()));
}

}  // namespace

std::string to_json(const EvalResult& r, bool include_poses) {
  const Eigen::Quaterniond& q = r.T_gt_est.rotation();
  std::string out = "{\n";
  out += fmt::format("  \"gt_frames\": {},\n", r.gt_frames);
  out += fmt::format("  \"est_poses\": {},\n", r.est_poses);
  out += fmt::format("  \"associated\": {},\n", r.associated);
  out += fmt::format("  \"coverage\": {},\n", json_number(r.coverage));
  out += fmt::format("  \"max_dt_s\": {},\n", json_number(r.max_dt_s));
  out += fmt::format("  \"time_offset_searched\": {},\n", r.time_offset_searched ? "true" : "false");
  out += fmt::format("  \"time_offset_search_range_s\": {},\n",
                     json_number(r.time_offset_search_range_s));
  out += fmt::format("  \"time_offset_s\": {},\n", json_number(r.time_offset_s));
  out += fmt::format(
      "  \"alignment\": {{\"T_gt_est_translation_m\": {}, \"T_gt_est_quaternion_xyzw\": [{}, {}, "
      "{}, {}]}},\n",
      vec_json(r.T_gt_est.translation()), json_number(q.x()), json_number(q.y()),
      json_number(q.z()), json_number(q.w()));
  out += fmt::format("  \"ate_m\": {},\n", stats_json(r.ate_m));
  out += fmt::format("  \"rpe_time\": {},\n", rpe_json(r.rpe_time));
  out += fmt::format("  \"rpe_frames\": {}", rpe_json(r.rpe_frames));
  if (include_poses) {
    out += ",\n  \"poses\": [";
    for (std::size_t i = 0; i < r.poses.size(); ++i) {
      const PoseError& p = r.poses[i];
      out += fmt::format(
          "{}\n    {{\"gt_index\": {}, \"est_index\": {}, \"t_s\": {}, \"p_gt_m\": {}, "
          "\"p_est_aligned_m\": {}, \"error_m\": {}}}",
          i == 0 ? "" : ",", p.gt_index, p.est_index, json_number(p.t_gt_s), vec_json(p.p_gt_m),
          vec_json(p.p_est_aligned_m), json_number(p.error_m));
    }
    out += "\n  ]";
  }
  out += "\n}\n";
  return out;
}

std::string to_text(const EvalResult& r) {
  std::string out;
  out += fmt::format("poses         {} estimated, {} ground truth, {} associated (max |dt| {} s)\n",
                     r.est_poses, r.gt_frames, r.associated, r.max_dt_s);
  out += fmt::format("coverage      {:.1f} % of ground-truth frames\n", 100.0 * r.coverage);
  if (r.time_offset_searched) {
    out += fmt::format("time offset   {:+.4f} s (searched in +-{} s; t_gt = t_est + offset)\n",
                       r.time_offset_s, r.time_offset_search_range_s);
  } else {
    out += fmt::format("time offset   {:+.4f} s (not searched)\n", r.time_offset_s);
  }
  out += fmt::format("ATE [m]       rmse {:.4f}  mean {:.4f}  median {:.4f}  std {:.4f}  max {:.4f}\n",
                     r.ate_m.rmse, r.ate_m.mean, r.ate_m.median, r.ate_m.std, r.ate_m.max);
  const auto rpe_line = [](const std::string& label, const RpeResult& rpe) {
    return fmt::format("{:<14}{} pairs  trans rmse {:.4f} m  mean {:.4f} m  rot rmse {:.4f} deg  "
                       "mean {:.4f} deg\n",
                       label, rpe.translation_m.count, rpe.translation_m.rmse,
                       rpe.translation_m.mean, rpe.rotation_deg.rmse, rpe.rotation_deg.mean);
  };
  out += rpe_line(fmt::format("RPE {:g} s", r.rpe_time.spec.delta_time_s), r.rpe_time);
  out += rpe_line(fmt::format("RPE {} fr", r.rpe_frames.spec.delta_frames), r.rpe_frames);
  return out;
}

}  // namespace sitepose::eval
