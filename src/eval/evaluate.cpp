#include "sitepose/eval/evaluate.hpp"

#include <cmath>

#include <fmt/format.h>

#include "sitepose/io/json_file.hpp"

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

// Nine significant digits (the figures mean no more); NaN stays NaN, which
// the writer turns into null.
double sig9(double v) { return std::isfinite(v) ? std::stod(fmt::format("{:.9g}", v)) : v; }

io::Json stats_json(const ErrorStats& s) {
  return io::Json{{"count", s.count},         {"rmse", sig9(s.rmse)}, {"mean", sig9(s.mean)},
                  {"median", sig9(s.median)}, {"std", sig9(s.std)},   {"min", sig9(s.min)},
                  {"max", sig9(s.max)}};
}

io::Json rpe_json(const RpeResult& r) {
  io::Json out = io::Json::object();
  if (r.spec.kind == RpeGapKind::kTime) {
    out["delta_s"] = sig9(r.spec.delta_time_s);
    out["tolerance_s"] = sig9(r.spec.time_tolerance_s);
  } else {
    out["delta_frames"] = r.spec.delta_frames;
  }
  out["pairs"] = r.translation_m.count;
  out["translation_m"] = stats_json(r.translation_m);
  out["rotation_deg"] = stats_json(r.rotation_deg);
  return out;
}

io::Json vec_json(const Eigen::Vector3d& v) {
  return io::Json::array({sig9(v.x()), sig9(v.y()), sig9(v.z())});
}

io::Json pose_errors_json(const std::vector<PoseError>& errors) {
  io::Json poses = io::Json::array();
  for (const PoseError& p : errors) {
    poses.push_back({{"gt_index", p.gt_index},
                     {"est_index", p.est_index},
                     {"t_s", sig9(p.t_gt_s)},
                     {"p_gt_m", vec_json(p.p_gt_m)},
                     {"p_est_aligned_m", vec_json(p.p_est_aligned_m)},
                     {"error_m", sig9(p.error_m)}});
  }
  return poses;
}

}  // namespace

std::string to_json(const EvalResult& r, bool include_poses) {
  const Eigen::Quaterniond& q = r.T_gt_est.rotation();
  const io::Json alignment{
      {"T_gt_est_translation_m", vec_json(r.T_gt_est.translation())},
      {"T_gt_est_quaternion_xyzw", io::Json::array({sig9(q.x()), sig9(q.y()), sig9(q.z()), sig9(q.w())})}};
  io::Json out{{"gt_frames", r.gt_frames},
               {"est_poses", r.est_poses},
               {"associated", r.associated},
               {"coverage", sig9(r.coverage)},
               {"max_dt_s", sig9(r.max_dt_s)},
               {"time_offset_searched", r.time_offset_searched},
               {"time_offset_search_range_s", sig9(r.time_offset_search_range_s)},
               {"time_offset_s", sig9(r.time_offset_s)},
               {"alignment", alignment},
               {"ate_m", stats_json(r.ate_m)},
               {"rpe_time", rpe_json(r.rpe_time)},
               {"rpe_frames", rpe_json(r.rpe_frames)}};
  if (include_poses) out["poses"] = pose_errors_json(r.poses);
  return io::to_json_text(out);
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
