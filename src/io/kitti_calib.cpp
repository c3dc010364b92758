#include "sitepose/io/kitti_calib.hpp"

#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>

#include "detail/text.hpp"
#include "sitepose/core/echo.hpp"

namespace sitepose::io {
namespace {

using Projection = std::array<double, 12>;  // row-major 3x4

struct KeyedLine {
  Projection p{};
  std::size_t line_no = 0;
};

// Rectified intrinsics of P0 and P1 must agree to the digits KITTI writes.
constexpr double kIntrinsicsRelTolerance = 1e-6;

bool nearly_equal(double a, double b, double scale) {
  return std::abs(a - b) <= kIntrinsicsRelTolerance * std::max(1.0, std::abs(scale));
}

}  // namespace

Expected<StereoCamera> read_kitti_calib(const std::string& path) {
  SITEPOSE_TRY(const std::vector<std::string> lines, detail::read_lines(path));
  std::map<std::string, std::size_t> seen_keys;
  std::optional<KeyedLine> p0;
  std::optional<KeyedLine> p1;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::size_t line_no = i + 1;
    if (detail::is_blank(lines[i])) continue;
    const std::string_view line = lines[i];
    const std::size_t colon = line.find(':');
    const std::string key(detail::trim(line.substr(0, colon == std::string_view::npos ? 0 : colon)));
    if (colon == std::string_view::npos || key.empty() ||
        key.find_first_of(" \t") != std::string::npos) {
      return make_error(ErrorCode::kParseError,
                        detail::where(path, line_no) + "expected 'KEY: numbers' (e.g. 'P0: fx 0 cx 0 ...'), got '" +
                            echo_value(lines[i]) + "'");
    }
    if (const auto [it, inserted] = seen_keys.emplace(key, line_no); !inserted) {
      return make_error(ErrorCode::kParseError,
                        detail::where(path, line_no) + "key '" + key + "' repeated (first on line " +
                            std::to_string(it->second) + ")");
    }
    if (key != "P0" && key != "P1") continue;  // P2, P3, Tr, ...: not ours
    SITEPOSE_TRY(const std::vector<double> v,
                 detail::parse_number_line(path, line_no, line.substr(colon + 1), 12));
    KeyedLine parsed;
    std::copy(v.begin(), v.end(), parsed.p.begin());
    parsed.line_no = line_no;
    (key == "P0" ? p0 : p1) = parsed;
  }
  if (!p0 || !p1) {
    return make_error(ErrorCode::kParseError,
                      path + ": expected lines 'P0: 12 numbers' and 'P1: 12 numbers', missing " +
                          (p0 ? "P1" : p1 ? "P0" : "P0 and P1"));
  }
  const Projection& a = p0->p;
  const Projection& b = p1->p;
  const auto bad = [&](std::size_t line_no, const std::string& what) {
    return make_error(ErrorCode::kParseError, detail::where(path, line_no) + what);
  };
  // Row-major indices: [0]=fx [2]=cx [3]=tx*fx [5]=fy [6]=cy [7]=ty*fy, row 3 = 8..11.
  const double fx = a[0];
  if (!(fx > 0.0) || !(a[5] > 0.0)) return bad(p0->line_no, "expected fx > 0 and fy > 0 in P0");
  for (const KeyedLine* kl : {&*p0, &*p1}) {
    const Projection& p = kl->p;
    if (p[1] != 0.0 || p[4] != 0.0 || p[8] != 0.0 || p[9] != 0.0 || p[10] != 1.0 || p[11] != 0.0) {
      return bad(kl->line_no,
                 "expected a rectified projection 'fx 0 cx tx  0 fy cy 0  0 0 1 0' (zero skew, last row 0 0 1 0)");
    }
  }
  if (a[3] != 0.0 || a[7] != 0.0) {
    return bad(p0->line_no, "expected P0 of the reference (left) camera with zero translation (P0[0][3] = P0[1][3] = 0)");
  }
  if (!nearly_equal(a[0], b[0], fx) || !nearly_equal(a[2], b[2], fx) ||
      !nearly_equal(a[5], b[5], fx) || !nearly_equal(a[6], b[6], fx) || b[7] != 0.0) {
    return bad(p1->line_no,
               "expected P1 with the same fx, fy, cx, cy as P0 and P1[1][3] = 0 (a rectified horizontal pair)");
  }
  StereoCamera camera;
  camera.fx = a[0];
  camera.fy = a[5];
  camera.cx = a[2];
  camera.cy = a[6];
  camera.baseline_m = -b[3] / fx;
  if (!(camera.baseline_m > 0.0)) {
    std::ostringstream msg;
    msg << "expected P1[0][3] = -fx * baseline < 0 (right camera at +x), got baseline " << camera.baseline_m << " m";
    return bad(p1->line_no, msg.str());
  }
  return camera;
}

}  // namespace sitepose::io
