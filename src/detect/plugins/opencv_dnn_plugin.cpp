// Built-in detector `opencv-dnn`: a network run by OpenCV's DNN module from
// Darknet, Caffe or TensorFlow model files (no ONNX: .onnx is refused).
// Output parsing: YOLO family only — every output blob is a 2D matrix with
// one row per candidate [cx, cy, w, h, objectness, class scores...], box
// values relative to the network input (what OpenCV's Darknet [yolo] /
// [region] layers give). A Caffe or TensorFlow model must end in that layout.
// Confidence = the best class score; boxes scaled to the image (no
// letterbox), then non-maximum suppression per class. Instance ids are
// unique per frame (1..n), not tracked.
//
// Config (YAML mapping):
//   model_weights: FILE      required (.weights, .caffemodel, .pb)
//   model_config: FILE       .cfg, .prototxt, .pbtxt (may be empty for .pb)
//   classes_file: FILE       class names, one per line; empty = class0, class1, ...
//   input_width_px: 416      network input size (multiples of 32 for YOLO)
//   input_height_px: 416
//   score_threshold: 0.3     candidates below are dropped before NMS
//   nms_iou: 0.45
// Images are gray; they are replicated to 3 channels, scaled by 1/255.

#include <algorithm>
#include <fstream>
#include <set>

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include "plugin_support.hpp"

namespace sitepose::detect::plugin {
namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

class OpencvDnnPlugin final : public PluginImpl {
 public:
  struct Options {
    std::string model_weights, model_config, classes_file;
    int input_width_px = 416, input_height_px = 416;
    double score_threshold = 0.3, nms_iou = 0.45;
  };

  // cv::dnn::Net is a shared handle without a move constructor: copies are cheap.
  OpencvDnnPlugin(Options options, const cv::dnn::Net& net, std::vector<std::string> classes)
      : options_(std::move(options)), net_(net), classes_(std::move(classes)) {
    outputs_ = net_.getUnconnectedOutLayersNames();
  }

  std::uint32_t capabilities() const override { return 0u; }

  Expected<std::vector<sp_detection>> detect(const cv::Mat& left, const cv::Mat&, std::int64_t,
                                             std::int64_t) override {
    cv::Mat bgr;
    cv::cvtColor(left, bgr, cv::COLOR_GRAY2BGR);
    const cv::Mat blob =
        cv::dnn::blobFromImage(bgr, 1.0 / 255.0, cv::Size(options_.input_width_px, options_.input_height_px),
                               cv::Scalar(), true, false, CV_32F);
    net_.setInput(blob);
    std::vector<cv::Mat> outs;
    net_.forward(outs, outputs_);

    std::vector<cv::Rect> boxes;
    std::vector<float> scores;
    std::vector<int> class_ids;
    for (const cv::Mat& out : outs) {
      if (out.dims != 2 || out.cols < 6 || out.type() != CV_32F) {
        return make_error(ErrorCode::kUnsupported,
                          "opencv-dnn: output is not YOLO-style (rows of [cx, cy, w, h, obj, "
                          "classes...]): dims " +
                              std::to_string(out.dims) + ", cols " + std::to_string(out.cols));
      }
      for (int r = 0; r < out.rows; ++r) {
        const float* row = out.ptr<float>(r);
        const cv::Mat class_scores(1, out.cols - 5, CV_32F, const_cast<float*>(row + 5));
        cv::Point best;
        double score = 0.0;
        cv::minMaxLoc(class_scores, nullptr, &score, nullptr, &best);
        if (!(score >= options_.score_threshold)) continue;
        const double w = row[2] * left.cols, h = row[3] * left.rows;
        const double x = row[0] * left.cols - w / 2, y = row[1] * left.rows - h / 2;
        boxes.emplace_back(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)),
                           static_cast<int>(std::lround(w)), static_cast<int>(std::lround(h)));
        scores.push_back(static_cast<float>(score));
        class_ids.push_back(best.x);
      }
    }
    // NMS per class (OpenCV 4.6 has no batched NMS).
    std::vector<int> keep;
    for (int c : std::set<int>(class_ids.begin(), class_ids.end())) {
      std::vector<cv::Rect> class_boxes;
      std::vector<float> class_scores;
      std::vector<int> index;
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        if (class_ids[i] != c) continue;
        class_boxes.push_back(boxes[i]);
        class_scores.push_back(scores[i]);
        index.push_back(static_cast<int>(i));
      }
      std::vector<int> kept;
      cv::dnn::NMSBoxes(class_boxes, class_scores, static_cast<float>(options_.score_threshold),
                        static_cast<float>(options_.nms_iou), kept);
      for (int k : kept) keep.push_back(index[static_cast<std::size_t>(k)]);
    }
    std::vector<sp_detection> result;
    std::uint16_t id = 0;
    for (int k : keep) {
      const auto i = static_cast<std::size_t>(k);
      const int c = class_ids[i];
      const std::string name = c < static_cast<int>(classes_.size()) ? classes_[static_cast<std::size_t>(c)]
                                                                     : "class" + std::to_string(c);
      if (id == 0xFFFF) break;
      result.push_back(make_detection(name, scores[i], boxes[i], ++id));
    }
    return result;
  }

  Status segment(const cv::Mat&, const cv::Mat&, std::int64_t, std::int64_t, const std::vector<sp_detection>&,
                 cv::Mat&) override {
    return make_error(ErrorCode::kUnsupported, "opencv-dnn: no segmentation");
  }

 private:
  Options options_;
  cv::dnn::Net net_;
  std::vector<std::string> classes_;
  std::vector<std::string> outputs_;
};

}  // namespace

Expected<std::unique_ptr<PluginImpl>> make_plugin(const YAML::Node& config) {
  OptionReader r(config, "opencv-dnn");
  OpencvDnnPlugin::Options o;
  SITEPOSE_TRY_STATUS(r.read("model_weights", o.model_weights, true));
  SITEPOSE_TRY_STATUS(r.read("model_config", o.model_config));
  SITEPOSE_TRY_STATUS(r.read("classes_file", o.classes_file));
  SITEPOSE_TRY_STATUS(r.read("input_width_px", o.input_width_px));
  SITEPOSE_TRY_STATUS(r.read("input_height_px", o.input_height_px));
  SITEPOSE_TRY_STATUS(r.read("score_threshold", o.score_threshold));
  SITEPOSE_TRY_STATUS(r.read("nms_iou", o.nms_iou));
  SITEPOSE_TRY_STATUS(r.finish());
  if (o.input_width_px < 1 || o.input_height_px < 1) {
    return r.fail("input_width_px and input_height_px must be >= 1");
  }
  SITEPOSE_TRY_STATUS(r.require_unit_interval("score_threshold", o.score_threshold));
  if (!(o.nms_iou > 0 && o.nms_iou <= 1)) return r.fail("nms_iou must be in (0, 1]");
  for (const std::string* f : {&o.model_weights, &o.model_config}) {
    if (ends_with(*f, ".onnx")) {
      return r.fail(*f + ": ONNX models are not supported (Darknet, Caffe or TensorFlow only)");
    }
  }
  const bool darknet = ends_with(o.model_weights, ".weights");
  const bool caffe = ends_with(o.model_weights, ".caffemodel");
  const bool tensorflow = ends_with(o.model_weights, ".pb");
  if (!darknet && !caffe && !tensorflow) {
    return r.fail("model_weights = " + o.model_weights +
                  ": expected a .weights (Darknet), .caffemodel (Caffe) or .pb (TensorFlow) file");
  }
  if ((darknet || caffe) && o.model_config.empty()) {
    return r.fail("model_config: required for Darknet (.cfg) and Caffe (.prototxt) models");
  }
  for (const std::string* f : {&o.model_weights, &o.model_config}) {
    if (!f->empty() && !std::ifstream(*f).good()) {
      return make_error(ErrorCode::kNotFound, "opencv-dnn: cannot open model file " + *f);
    }
  }
  std::vector<std::string> classes;
  if (!o.classes_file.empty()) {
    std::ifstream in(o.classes_file);
    if (!in) return make_error(ErrorCode::kNotFound, "opencv-dnn: cannot open " + o.classes_file);
    for (std::string line; std::getline(in, line);) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (!line.empty()) classes.push_back(line);
    }
  }
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNet(o.model_weights, o.model_config);
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kInvalidArgument, "opencv-dnn: cannot read model " + o.model_weights +
                                                       " / " + o.model_config + ": " + e.what());
  }
  if (net.empty()) {
    return make_error(ErrorCode::kInvalidArgument, "opencv-dnn: empty network from " + o.model_weights);
  }
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  return std::unique_ptr<PluginImpl>(new OpencvDnnPlugin(std::move(o), net, std::move(classes)));
}

}  // namespace sitepose::detect::plugin
