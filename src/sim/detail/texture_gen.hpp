#pragma once
// Procedural, seeded gray textures of a construction site. Every function is
// deterministic in its Rng. Scales are stated per function (metres/texel).

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "detail/rng.hpp"

namespace sitepose::sim::detail {

// Ground tiles (repeat-wrapped, power-of-two sizes), 8 mm per texel.
cv::Mat gravel_tile(Rng& rng, int size_px);
cv::Mat soil_tile(Rng& rng, int size_px);
cv::Mat asphalt_tile(Rng& rng, int size_px);
// Tyre tread imprint, 1 cm per texel: along the track x (length_px), across y.
cv::Mat tread_tile(Rng& rng, int length_px, int width_px, bool chevrons);
// Large-scale variation around 128 (multiplicative overlay), periodic.
cv::Mat macro_overlay(Rng& rng, int size_px, double amplitude);

// Luminance of a named paint (yellow, orange, red, white, green, blue, gray,
// black); -1 for an unknown name.
int paint_level(const std::string& name);
std::vector<std::string> paint_names();

// A face drawn in metres: x to the right, y down from the top edge.
class Canvas {
 public:
  Canvas(Rng& rng, double width_m, double height_m, double texels_per_m, int base_level,
         double noise_sigma = 6.0);
  cv::Mat& image() { return image_; }
  double texels_per_m() const { return tpm_; }

  cv::Point px(double x_m, double y_m) const;
  void rect(double x, double y, double w, double h, int level, bool filled = true, int thick_px = 1);
  void seams(double spacing_x_m, double spacing_y_m, int darken);
  void rivets(double spacing_m, double inset_m);
  void window(double x, double y, double w, double h);
  void text(const std::string& s, double x, double y_baseline, double height_m, int level);
  void hazard_stripes(double x, double y, double w, double h);
  void grille(double x, double y, double w, double h, double pitch_m);
  void corrugation(double pitch_m, int amplitude);
  void dirt(double amount, double bottom_bias);
  void circle(double x, double y, double r_m, int level, bool filled);

 private:
  Rng& rng_;
  cv::Mat image_;
  double tpm_;
};

}  // namespace sitepose::sim::detail
