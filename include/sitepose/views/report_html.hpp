#pragma once
// `sitepose report`: one self-contained HTML page per run (inline SVG, no
// script, nothing fetched): accuracy (ATE/RPE) with its figures, the
// trajectory's top view, per-stage timing histograms, mar and occlusion
// over time with the pixel-mask calls, the motion-state timeline per object
// (ground truth beside it where known), keyframes and map size over time,
// the configuration and the build. Section ids are ReportSections().

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/views/debug_record.hpp"

namespace sitepose::views {

// Ground truth of the frames a run tracked, where known.
struct GroundTruth {
  std::vector<std::optional<SE3>> poses;  // per sequence frame (record seq)
  std::vector<double> times_s;            // per sequence frame
  // Per sequence frame: instance -> moving (nullopt = unknown).
  std::map<std::int64_t, std::map<std::uint16_t, std::optional<bool>>> moving;
  std::vector<double> occlusion_ratio;  // per sequence frame; empty when unknown
};

// From a sitepose sequence (poses.txt, labels/boxes.csv, meta.json); an
// error when its meta.json does not parse.
Expected<GroundTruth> ground_truth_of(const io::Sequence& sequence);

// The page's sections, in order: HTML ids (<section id="...">).
const std::vector<std::string>& report_sections();

// The per-frame occlusion ratio of a simulated sequence's meta.json
// ("occlusion_ratio": [...], null for NaN); empty when absent, kNotFound /
// kParseError naming the file when it cannot be read or is not a list of
// numbers.
Expected<std::vector<double>> read_occlusion_ratios(const std::string& meta_json_path);

// The page for `record`; `gt` null when there is none. `generator`: the
// version line of the program writing it.
std::string render_report_html(const DebugRecord& record, const GroundTruth* gt,
                               const std::string& generator);

// Writes DIR/report.html (creating DIR); returns its path.
Expected<std::string> write_report(const DebugRecord& record, const GroundTruth* gt,
                                   const std::string& generator, const std::string& dir);

}  // namespace sitepose::views
