#include "detail/texture_gen.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace sitepose::sim::detail {
namespace {

// Smooth periodic noise in [-1, 1]: a random grid of `cells` x `cells`
// values, tiled 3x3, upsampled bicubically and cropped so it wraps exactly.
cv::Mat periodic_noise(Rng& rng, int size_px, int cells) {
  cv::Mat grid(cells, cells, CV_32FC1);
  for (int r = 0; r < cells; ++r)
    for (int c = 0; c < cells; ++c) grid.at<float>(r, c) = static_cast<float>(rng.uniform(-1, 1));
  cv::Mat tiled;
  cv::repeat(grid, 3, 3, tiled);
  cv::Mat big;
  cv::resize(tiled, big, cv::Size(3 * size_px, 3 * size_px), 0, 0, cv::INTER_CUBIC);
  return big(cv::Rect(size_px, size_px, size_px, size_px)).clone();
}

// Periodic noise on two scales around `mean` (a float field, not clipped):
// coarse_cells with coarse_amplitude, then fine_cells with fine_amplitude.
cv::Mat two_scale_noise(Rng& rng, int size_px, int coarse_cells, double coarse_amplitude, double mean,
                        int fine_cells, double fine_amplitude) {
  cv::Mat f = periodic_noise(rng, size_px, coarse_cells) * coarse_amplitude + mean;
  f += periodic_noise(rng, size_px, fine_cells) * fine_amplitude;
  return f;
}

void add_fine_noise(Rng& rng, cv::Mat& f32, double sigma) {
  for (int r = 0; r < f32.rows; ++r) {
    float* p = f32.ptr<float>(r);
    for (int c = 0; c < f32.cols; ++c) p[c] += static_cast<float>(sigma * rng.normal_fast());
  }
}

cv::Mat to_u8(const cv::Mat& f32) {
  cv::Mat out;
  f32.convertTo(out, CV_8UC1);
  return out;
}

// Calls draw(offset) for the copies of a shape of radius r at `c` that
// touch a wrapped tile of the given size.
template <typename Draw>
void wrapped(const cv::Size& size, cv::Point c, int r, Draw draw) {
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const cv::Point o(dx * size.width, dy * size.height);
      const cv::Point q = c + o;
      if (q.x + r < 0 || q.y + r < 0 || q.x - r >= size.width || q.y - r >= size.height) continue;
      draw(o);
    }
  }
}

void stones(Rng& rng, cv::Mat& img, int count, double r_min, double r_max, int lo, int hi, double shadow) {
  for (int i = 0; i < count; ++i) {
    const cv::Point c(rng.integer(0, img.cols - 1), rng.integer(0, img.rows - 1));
    const double r = rng.uniform(r_min, r_max);
    const cv::Size axes(std::max(1, static_cast<int>(r)),
                        std::max(1, static_cast<int>(r * rng.uniform(0.5, 1.0))));
    const double angle = rng.uniform(0, 180);
    const int level = rng.integer(lo, hi);
    const int shadow_level = static_cast<int>(level * shadow);
    wrapped(img.size(), c, static_cast<int>(r) + 3, [&](cv::Point o) {
      cv::ellipse(img, c + o + cv::Point(1, 2), axes, angle, 0, 360, shadow_level, -1, cv::LINE_8);
      cv::ellipse(img, c + o, axes, angle, 0, 360, level, -1, cv::LINE_8);
      if (axes.width >= 3)
        cv::circle(img, c + o - cv::Point(axes.width / 3, axes.height / 3), std::max(1, axes.height / 3),
                   std::min(255, level + 35), -1, cv::LINE_8);
    });
  }
}

}  // namespace

cv::Mat gravel_tile(Rng& rng, int size_px) {
  cv::Mat f = two_scale_noise(rng, size_px, 8, 18.0, 110.0, 64, 12.0);
  add_fine_noise(rng, f, 9.0);
  cv::Mat img = to_u8(f);
  const int n = size_px * size_px / 60;
  stones(rng, img, n, 1.2, 4.5, 45, 215, 0.45);
  stones(rng, img, n / 20, 4.0, 8.0, 70, 200, 0.4);
  return img;
}

cv::Mat soil_tile(Rng& rng, int size_px) {
  cv::Mat f = two_scale_noise(rng, size_px, 6, 22.0, 105.0, 48, 14.0);
  add_fine_noise(rng, f, 10.0);
  cv::Mat img = to_u8(f);
  // Clods: small irregular polygons, lit from the top left.
  const int n = size_px * size_px / 260;
  for (int i = 0; i < n; ++i) {
    const cv::Point c(rng.integer(0, size_px - 1), rng.integer(0, size_px - 1));
    const double r = rng.uniform(2.0, 7.0);
    std::vector<cv::Point> poly;
    const int k = rng.integer(4, 6);
    for (int j = 0; j < k; ++j) {
      const double a = 6.2831853 * j / k + rng.uniform(-0.3, 0.3);
      const double rr = r * rng.uniform(0.6, 1.2);
      poly.emplace_back(static_cast<int>(rr * std::cos(a)), static_cast<int>(rr * std::sin(a)));
    }
    const int level = rng.integer(60, 175);
    const int shadow_level = level / 2;  // integer halving, as the images were made
    wrapped(img.size(), c, static_cast<int>(r * 1.3) + 3, [&](cv::Point o) {
      std::vector<cv::Point> shadow_poly, body;
      for (const auto& p : poly) {
        shadow_poly.push_back(p + c + o + cv::Point(2, 2));
        body.push_back(p + c + o);
      }
      cv::fillConvexPoly(img, shadow_poly, shadow_level, cv::LINE_8);
      cv::fillConvexPoly(img, body, level, cv::LINE_8);
    });
  }
  stones(rng, img, size_px * size_px / 400, 1.0, 2.5, 140, 230, 0.5);
  // Drying cracks.
  for (int i = 0; i < size_px / 16; ++i) {
    cv::Point p(rng.integer(0, size_px - 1), rng.integer(0, size_px - 1));
    double a = rng.uniform(0, 6.283);
    for (int j = 0; j < 12; ++j) {
      a += rng.uniform(-0.7, 0.7);
      const cv::Point q = p + cv::Point(static_cast<int>(9 * std::cos(a)), static_cast<int>(9 * std::sin(a)));
      wrapped(img.size(), p, 12, [&](cv::Point o) { cv::line(img, p + o, q + o, 45, 1, cv::LINE_8); });
      p = q;
    }
  }
  return img;
}

cv::Mat asphalt_tile(Rng& rng, int size_px) {
  cv::Mat f = periodic_noise(rng, size_px, 10) * 10.0 + 78.0;
  add_fine_noise(rng, f, 16.0);
  cv::Mat img = to_u8(f);
  stones(rng, img, size_px * size_px / 45, 0.8, 2.2, 35, 175, 0.5);
  // Repair patches and cracks.
  for (int i = 0; i < 3; ++i) {
    const int w = rng.integer(size_px / 10, size_px / 4);
    const int h = rng.integer(size_px / 12, size_px / 5);
    const cv::Point c(rng.integer(0, size_px - 1), rng.integer(0, size_px - 1));
    const int d = rng.integer(-25, -10);
    wrapped(img.size(), c, std::max(w, h), [&](cv::Point o) {
      const cv::Rect r(c.x + o.x, c.y + o.y, w, h);
      const cv::Rect clipped = r & cv::Rect(0, 0, size_px, size_px);
      if (clipped.area() == 0) return;
      cv::Mat roi = img(clipped);
      roi += cv::Scalar(d);
      cv::rectangle(img, r, 40, 2, cv::LINE_8);
    });
  }
  return img;
}

cv::Mat tread_tile(Rng& rng, int length_px, int width_px, bool chevrons) {
  cv::Mat f(width_px, length_px, CV_32FC1, cv::Scalar(88.0));
  add_fine_noise(rng, f, 10.0);
  cv::Mat img = to_u8(f);
  if (chevrons) {
    // Lug imprints: a V every 14 texels, darker grooves with a lit edge.
    for (int x = 0; x < length_px; x += 16) {
      const int mid = width_px / 2;
      for (int side = -1; side <= 1; side += 2) {
        const cv::Point a(x, mid + side * 3);
        const cv::Point b(x + 9, mid + side * (width_px / 2 - 3));
        cv::line(img, a, b, 40, 4, cv::LINE_8);
        cv::line(img, a + cv::Point(3, 0), b + cv::Point(3, 0), 150, 1, cv::LINE_8);
      }
    }
  } else {
    // Smooth drum imprint: pressed, lighter, few marks.
    img += cv::Scalar(30);
  }
  stones(rng, img, length_px * width_px / 120, 0.8, 2.0, 50, 200, 0.5);
  return img;
}

cv::Mat macro_overlay(Rng& rng, int size_px, double amplitude) {
  return to_u8(two_scale_noise(rng, size_px, 12, amplitude, 128.0, 48, amplitude * 0.4));
}

int paint_level(const std::string& name) {
  if (name == "yellow") return 205;
  if (name == "orange") return 165;
  if (name == "red") return 110;
  if (name == "white") return 230;
  if (name == "green") return 95;
  if (name == "blue") return 75;
  if (name == "gray") return 140;
  if (name == "black") return 45;
  return -1;
}

std::vector<std::string> paint_names() {
  return {"yellow", "orange", "red", "white", "green", "blue", "gray", "black"};
}

Canvas::Canvas(Rng& rng, double width_m, double height_m, double texels_per_m, int base_level,
               double noise_sigma)
    : rng_(rng), tpm_(texels_per_m) {
  const int w = std::max(4, static_cast<int>(std::lround(width_m * texels_per_m)));
  const int h = std::max(4, static_cast<int>(std::lround(height_m * texels_per_m)));
  cv::Mat f(h, w, CV_32FC1, cv::Scalar(base_level));
  add_fine_noise(rng, f, noise_sigma);
  image_ = to_u8(f);
}

cv::Point Canvas::px(double x_m, double y_m) const {
  return {static_cast<int>(std::lround(x_m * tpm_)), static_cast<int>(std::lround(y_m * tpm_))};
}

void Canvas::rect(double x, double y, double w, double h, int level, bool filled, int thick_px) {
  cv::rectangle(image_, px(x, y), px(x + w, y + h), level, filled ? -1 : thick_px, cv::LINE_8);
}

void Canvas::seams(double sx, double sy, int darken) {
  const double width_m = image_.cols / tpm_;
  const double height_m = image_.rows / tpm_;
  for (double x = sx; sx > 0 && x < width_m; x += sx) {
    cv::line(image_, px(x, 0), px(x, height_m), cv::Scalar(std::max(0, 80 - darken)), 2);
  }
  for (double y = sy; sy > 0 && y < height_m; y += sy) {
    cv::line(image_, px(0, y), px(width_m, y), cv::Scalar(std::max(0, 80 - darken)), 2);
  }
}

void Canvas::rivets(double spacing_m, double inset_m) {
  const double width_m = image_.cols / tpm_;
  const double height_m = image_.rows / tpm_;
  const int r = std::max(1, static_cast<int>(0.015 * tpm_));
  for (double x = inset_m; x < width_m - inset_m * 0.5; x += spacing_m) {
    for (double y : {inset_m, height_m - inset_m}) {
      cv::circle(image_, px(x, y), r + 1, 40, -1);
      cv::circle(image_, px(x, y), r, 220, -1);
    }
  }
}

void Canvas::window(double x, double y, double w, double h) {
  rect(x - 0.04, y - 0.04, w + 0.08, h + 0.08, 35);  // rubber seal
  const cv::Rect r(px(x, y), px(x + w, y + h));
  // Dark glass with a diagonal sky reflection and something inside.
  for (int row = r.y; row < r.y + r.height && row < image_.rows; ++row) {
    uchar* p = image_.ptr<uchar>(row);
    for (int col = std::max(0, r.x); col < std::min(image_.cols, r.x + r.width); ++col) {
      const int diag = (col - r.x) + (row - r.y);
      const bool reflect = diag > r.height * 0.5 && diag < r.height * 0.9;  // one sky streak
      p[col] = static_cast<uchar>(reflect ? 150 + rng_.integer(0, 20) : 55 + rng_.integer(0, 12));
    }
  }
  // Seat / operator silhouette and a wiper.
  if (rng_.chance(0.7)) {
    circle(x + w * rng_.uniform(0.3, 0.7), y + h * 0.45, std::min(w, h) * 0.12, 30, true);
  }
  cv::line(image_, px(x + w * 0.2, y + h * 0.95), px(x + w * 0.6, y + h * 0.5), 20, 2);
}

void Canvas::text(const std::string& s, double x, double y_baseline, double height_m, int level) {
  const double scale = height_m * tpm_ / 22.0;  // Hershey simplex cap height ~22 px at scale 1
  const int thick = std::max(1, static_cast<int>(scale * 2.2));
  cv::putText(image_, s, px(x, y_baseline), cv::FONT_HERSHEY_SIMPLEX, scale, level, thick, cv::LINE_8);
}

void Canvas::hazard_stripes(double x, double y, double w, double h) {
  const cv::Rect r(px(x, y), px(x + w, y + h));
  const int period = std::max(4, static_cast<int>(0.2 * tpm_));
  for (int row = std::max(0, r.y); row < std::min(image_.rows, r.y + r.height); ++row) {
    uchar* p = image_.ptr<uchar>(row);
    for (int col = std::max(0, r.x); col < std::min(image_.cols, r.x + r.width); ++col) {
      p[col] = ((col + row) / period) % 2 ? 40 : 215;
    }
  }
}

void Canvas::grille(double x, double y, double w, double h, double pitch_m) {
  rect(x, y, w, h, 50);
  for (double yy = y + pitch_m * 0.5; yy < y + h; yy += pitch_m) {
    cv::line(image_, px(x + 0.03, yy), px(x + w - 0.03, yy), 175,
             std::max(1, static_cast<int>(pitch_m * tpm_ * 0.35)));
  }
}

void Canvas::corrugation(double pitch_m, int amplitude) {
  const int period = std::max(4, static_cast<int>(pitch_m * tpm_));
  for (int row = 0; row < image_.rows; ++row) {
    uchar* p = image_.ptr<uchar>(row);
    for (int col = 0; col < image_.cols; ++col) {
      const int phase = col % period;
      const int delta = phase < period / 4 ? amplitude : (phase < period / 2 ? -amplitude : 0);
      p[col] = cv::saturate_cast<uchar>(p[col] + delta);
    }
  }
}

void Canvas::dirt(double amount, double bottom_bias) {
  const int n = static_cast<int>(amount * image_.cols * image_.rows / 150.0);
  for (int i = 0; i < n; ++i) {
    const double y_frac = std::pow(rng_.uniform(), 1.0 / (1.0 + bottom_bias * 3.0));
    const cv::Point c(rng_.integer(0, image_.cols - 1), static_cast<int>(y_frac * (image_.rows - 1)));
    const int r = rng_.integer(1, std::max(2, static_cast<int>(0.03 * tpm_)));
    const int level = rng_.integer(50, 110);
    cv::circle(image_, c, r, level, -1, cv::LINE_8);
  }
}

void Canvas::circle(double x, double y, double r_m, int level, bool filled) {
  cv::circle(image_, px(x, y), std::max(1, static_cast<int>(r_m * tpm_)), level, filled ? -1 : 2, cv::LINE_8);
}

}  // namespace sitepose::sim::detail
