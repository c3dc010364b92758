// The static site: ground zones, tyre tracks and structures along the side
// the ego camera looks at. Lateral distance d > 0 is towards the view
// (y = view_sign * d).

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "detail/models.hpp"
#include "detail/texture_gen.hpp"

namespace sitepose::sim::detail {
namespace {

using Eigen::Vector3d;

constexpr double kGroundTpm = 125.0;   // 8 mm per texel: ~5.6 mm pixels at 3.5 m still blur little
constexpr double kOverlayTpm = 4.0;    // 25 cm per texel of large-scale variation
constexpr double kStructureTpm = 40.0; // 2.5 cm: about a pixel at 18 m

TexturePtr tex(const cv::Mat& img, TextureWrap wrap = TextureWrap::kClamp) {
  return std::make_shared<const Texture>(img, wrap);
}

float shade_of(const Vector3d& n) {
  const Vector3d sun = Vector3d(0.35, -0.55, 0.76).normalized();
  return static_cast<float>(0.6 + 0.45 * std::max(0.0, n.normalized().dot(sun)));
}

struct Ctx {
  Rng& rng;
  const BackgroundLayout& layout;
  Mesh& mesh;
  TexturePtr overlay;
  double y(double d) const { return layout.view_sign * d; }
};

// Horizontal ground rectangle over x in [x0, x1], lateral d in [d0, d1],
// at height z, textured with a repeating tile.
void ground_rect(Ctx& c, double x0, double x1, double d0, double d1, double z, const TexturePtr& tile,
                 double tpm, bool with_overlay) {
  Patch p;
  const double ya = c.y(d0), yb = c.y(d1);
  const double y_lo = std::min(ya, yb), y_hi = std::max(ya, yb);
  p.origin = Vector3d(x0, y_lo, z);
  p.axis_u = Vector3d(x1 - x0, 0, 0);
  p.axis_v = Vector3d(0, y_hi - y_lo, 0);
  p.texture = tile;
  p.tex_x0 = c.rng.uniform(0, tile->width());
  p.tex_y0 = c.rng.uniform(0, tile->height());
  p.tex_du = (x1 - x0) * tpm;
  p.tex_dv = (y_hi - y_lo) * tpm;
  if (with_overlay) {
    p.overlay = c.overlay;
    p.overlay_x0 = (x0 + 1000.0) * kOverlayTpm;
    p.overlay_y0 = (y_lo + 1000.0) * kOverlayTpm;
    p.overlay_du = (x1 - x0) * kOverlayTpm;
    p.overlay_dv = (y_hi - y_lo) * kOverlayTpm;
  }
  p.shade = 1.0f;
  c.mesh.patches.push_back(p);
}

// Vertical rectangle facing the camera side, x in [x0, x1] at lateral d,
// from z0 to z1, texture shown upright.
void facing_wall(Ctx& c, double x0, double x1, double d, double z0, double z1, const TexturePtr& t,
                 bool two_sided) {
  Patch p;
  // Viewer at smaller d looks towards +d: right-hand direction is -view_sign * x... computed
  // from the normal: the face must point towards d = 0.
  const Vector3d normal(0, -c.layout.view_sign, 0);
  const Vector3d up(0, 0, z1 - z0);
  Vector3d right(x1 - x0, 0, 0);
  Vector3d origin(x0, c.y(d), z0);
  if (right.cross(up).dot(normal) < 0) {
    right = -right;
    origin.x() = x1;
  }
  p.origin = origin;
  p.axis_u = right;
  p.axis_v = up;
  p.two_sided = two_sided;
  p.texture = t;
  p.tex_x0 = 0;
  p.tex_du = t->width();
  p.tex_y0 = t->height();
  p.tex_dv = -t->height();
  p.shade = shade_of(normal);
  c.mesh.patches.push_back(p);
}

// Closed box in the site frame, axis-aligned, all faces from `faces`
// (front = the face towards the camera).
void site_box(Ctx& c, double x0, double x1, double d0, double d1, double z0, double z1,
              const TexturePtr& front, const TexturePtr& side, const TexturePtr& top) {
  facing_wall(c, x0, x1, d0, z0, z1, front, false);
  // Ends (perpendicular to x), visible at oblique angles; and the roof.
  for (int e = 0; e < 2; ++e) {
    const double x = e == 0 ? x0 : x1;
    Patch p;
    const Vector3d normal(e == 0 ? -1 : 1, 0, 0);
    Vector3d right(0, c.y(d1) - c.y(d0), 0);
    Vector3d origin(x, c.y(d0), z0);
    const Vector3d up(0, 0, z1 - z0);
    if (right.cross(up).dot(normal) < 0) {
      right = -right;
      origin.y() = c.y(d1);
    }
    p.origin = origin;
    p.axis_u = right;
    p.axis_v = up;
    p.texture = side;
    p.tex_du = side->width();
    p.tex_y0 = side->height();
    p.tex_dv = -side->height();
    p.shade = shade_of(normal);
    c.mesh.patches.push_back(p);
  }
  Patch roof;
  roof.origin = Vector3d(x0, std::min(c.y(d0), c.y(d1)), z1);
  roof.axis_u = Vector3d(x1 - x0, 0, 0);
  roof.axis_v = Vector3d(0, std::abs(d1 - d0), 0);
  roof.texture = top;
  roof.tex_du = top->width();
  roof.tex_dv = top->height();
  roof.shade = 1.05f;
  c.mesh.patches.push_back(roof);
}

TexturePtr container_side(Rng& rng, double w, double h) {
  static const char* kNames[] = {"SEALINE", "CONTAINEX", "ALPHA BOX", "TRANSCON", "SITE STORE"};
  Canvas c(rng, w, h, kStructureTpm, rng.integer(60, 190), 6.0);
  c.corrugation(0.28, 22);
  c.rect(0, 0, w, 0.12, 60);
  c.rect(0, h - 0.15, w, 0.15, 50);
  c.text(kNames[rng.integer(0, 4)], w * 0.25, h * 0.45, 0.45, rng.chance(0.5) ? 240 : 25);
  c.text("MSKU " + std::to_string(rng.integer(100000, 999999)), w * 0.7, h * 0.22, 0.16, 235);
  c.dirt(0.25, 1.0);
  return tex(c.image());
}

TexturePtr office_face(Rng& rng, double w, double h) {
  Canvas c(rng, w, h, kStructureTpm, rng.integer(200, 235), 5.0);
  c.seams(0.0, 0.3, -60);
  for (double x = 0.5; x + 1.2 < w; x += 1.9) c.window(x, 0.7, 1.1, 1.0);
  c.rect(w - 1.3, 0.4, 0.9, h - 0.4, 120);
  c.rect(w - 1.25, 0.45, 0.8, h - 0.45, 90, false, 2);
  c.text("SITE OFFICE", 0.4, 0.5, 0.3, 30);
  c.rect(0.3, h - 0.35, w - 0.6, 0.08, 70);
  return tex(c.image());
}

TexturePtr hoarding_panel(Rng& rng, double w, double h) {
  static const char* kText[] = {"SAFETY FIRST", "HARD HATS", "NO ENTRY", "KEEP CLEAR", "SITE 14",
                                "HI-VIS ONLY", "SPEED 10"};
  const int base = rng.chance(0.5) ? rng.integer(190, 230) : rng.integer(60, 110);
  Canvas c(rng, w, h, kStructureTpm, base, 6.0);
  for (double x = 0.0; x < w; x += 2.4) c.rect(x, 0, 0.08, h, base > 150 ? 70 : 200);
  const double bx = rng.uniform(0.3, std::max(0.4, w - 4.0));
  c.rect(bx, 0.25, std::min(3.8, w - bx), 0.9, base > 150 ? 40 : 225);
  c.text(kText[rng.integer(0, 6)], bx + 0.15, 0.85, 0.45, base > 150 ? 230 : 30);
  c.hazard_stripes(0, h - 0.25, w, 0.25);
  c.dirt(0.3, 1.0);
  return tex(c.image());
}

TexturePtr facade(Rng& rng, double w, double h) {
  const int base = rng.integer(110, 200);
  Canvas c(rng, w, h, 25.0, base, 8.0);
  const double floor_h = 3.2;
  for (double y = 0.6; y + 1.8 < h; y += floor_h) {
    c.rect(0, y + 2.3, w, 0.25, base - 40);
    for (double x = 0.8; x + 1.4 < w; x += 2.6) {
      c.rect(x - 0.1, y + 0.3 - 0.1, 1.6, 1.9, 235);
      c.rect(x, y + 0.3, 1.4, 1.7, rng.integer(30, 90));
      if (rng.chance(0.4)) c.rect(x, y + 0.3, 1.4, rng.uniform(0.3, 1.2), rng.integer(150, 220));
      c.rect(x + 0.68, y + 0.3, 0.05, 1.7, 220);
    }
  }
  c.text(rng.chance(0.5) ? "LOGISTIK" : "HOTEL", w * 0.1, 1.4, 1.0, 240);
  c.dirt(0.05, 0.8);
  return tex(c.image());
}

TexturePtr plain(Rng& rng, double w, double h, int level, double tpm) {
  Canvas c(rng, w, h, tpm, level, 8.0);
  c.seams(1.0, 0.0, 10);
  c.dirt(0.2, 0.5);
  return tex(c.image());
}

// Soil pile: a low irregular cone of triangles with the soil tile.
void soil_pile(Ctx& c, const TexturePtr& soil, double x, double d, double radius, double height) {
  const int sides = 9;
  const Vector3d apex(x + c.rng.uniform(-0.5, 0.5), c.y(d), height);
  std::vector<Vector3d> ring;
  for (int i = 0; i < sides; ++i) {
    const double a = 2.0 * std::numbers::pi * i / sides;
    const double r = radius * c.rng.uniform(0.8, 1.15);
    ring.emplace_back(x + r * std::cos(a), c.y(d) + r * std::sin(a), 0.0);
  }
  for (int i = 0; i < sides; ++i) {
    Patch p;
    p.shape = Shape::kTriangle;
    p.origin = ring[static_cast<size_t>(i)];
    p.axis_u = ring[static_cast<size_t>((i + 1) % sides)] - p.origin;
    p.axis_v = apex - p.origin;
    if (p.axis_u.cross(p.axis_v).z() < 0) {
      p.origin = ring[static_cast<size_t>((i + 1) % sides)];
      p.axis_u = ring[static_cast<size_t>(i)] - p.origin;
      p.axis_v = apex - p.origin;
    }
    p.texture = soil;
    p.tex_x0 = c.rng.uniform(0, 512);
    p.tex_y0 = c.rng.uniform(0, 512);
    p.tex_du = p.axis_u.norm() * kGroundTpm * 0.5;
    p.tex_dv = p.axis_v.norm() * kGroundTpm * 0.5;
    p.shade = shade_of(p.axis_u.cross(p.axis_v));
    c.mesh.patches.push_back(p);
  }
}

}  // namespace

Mesh make_background(Rng& rng, const BackgroundLayout& layout) {
  Mesh mesh;
  Ctx c{rng, layout, mesh, tex(macro_overlay(rng, 512, 22.0), TextureWrap::kRepeat)};
  const TexturePtr asphalt = tex(asphalt_tile(rng, 1024), TextureWrap::kRepeat);
  const TexturePtr gravel = tex(gravel_tile(rng, 1024), TextureWrap::kRepeat);
  const TexturePtr soil = tex(soil_tile(rng, 1024), TextureWrap::kRepeat);
  const TexturePtr soil2 = tex(soil_tile(rng, 1024), TextureWrap::kRepeat);
  const double xa = layout.x_min_m - 160.0;
  const double xb = layout.x_max_m + 160.0;

  // Ground zones by lateral distance: fresh asphalt under the ego roller,
  // a gravel strip, the soil haul road the other machines use, soil beyond.
  ground_rect(c, xa, xb, -40.0, 3.5, 0.0, asphalt, kGroundTpm, true);
  ground_rect(c, xa, xb, 3.5, 9.5, 0.0, gravel, kGroundTpm, true);
  ground_rect(c, xa, xb, 9.5, 15.5, 0.0, soil, kGroundTpm, true);
  ground_rect(c, xa, xb, 15.5, 400.0, 0.0, soil2, kGroundTpm, true);

  if (layout.tyre_tracks) {
    const TexturePtr lugs = tex(tread_tile(rng, 256, 64, true), TextureWrap::kRepeat);
    const TexturePtr drum = tex(tread_tile(rng, 256, 64, false), TextureWrap::kRepeat);
    // Truck ruts (pairs 2.05 m apart) on the haul road, roller drum prints on the gravel.
    for (double d : {10.6, 12.65, 13.4}) {
      for (double x = xa; x < xb; x += rng.uniform(25.0, 60.0)) {
        const double len = rng.uniform(12.0, 40.0);
        ground_rect(c, x, x + len, d, d + 0.45, 0.004, lugs, 100.0, false);
      }
    }
    for (double d : {4.6, 7.1}) {
      for (double x = xa; x < xb; x += rng.uniform(20.0, 50.0)) {
        const double len = rng.uniform(10.0, 30.0);
        ground_rect(c, x, x + len, d, d + 2.1, 0.004, drum, 100.0, false);
      }
    }
  }

  // Hoarding along the site boundary with gaps, then containers, offices and
  // piles, then a row of building faces that closes the view.
  const double fence_d = layout.structures_min_m;
  for (double x = xa + 100.0; x < xb - 100.0;) {
    const double w = rng.uniform(8.0, 20.0);
    facing_wall(c, x, x + w, fence_d + rng.uniform(-0.5, 0.5), 0.0, 1.9, hoarding_panel(rng, w, 1.9), true);
    x += w + (rng.chance(0.35) ? rng.uniform(2.0, 6.0) : 0.05);
  }
  const double mid_lo = fence_d + 5.0;
  const double mid_hi = std::max(mid_lo + 2.0, 0.6 * layout.structures_max_m);
  for (double x = xa + 100.0; x < xb - 100.0;) {
    const double d = rng.uniform(mid_lo, mid_hi);
    const int kind = rng.integer(0, 3);
    if (kind <= 1) {  // containers, sometimes stacked
      const double w = 12.2, h = 2.6, depth = 2.44;
      const int levels = rng.chance(0.5) ? 2 : 1;
      for (int l = 0; l < levels; ++l) {
        site_box(c, x, x + w, d, d + depth, l * h, (l + 1) * h, container_side(rng, w, h),
                 plain(rng, depth, h, 120, kStructureTpm), plain(rng, w, depth, 130, 10.0));
      }
      x += w + rng.uniform(1.0, 8.0);
    } else if (kind == 2) {  // site office, two storeys
      const double w = 6.0, h = 2.8, depth = 2.5;
      for (int l = 0; l < 2; ++l) {
        site_box(c, x, x + w, d, d + depth, l * h, (l + 1) * h, office_face(rng, w, h),
                 plain(rng, depth, h, 210, kStructureTpm), plain(rng, w, depth, 150, 10.0));
      }
      x += w + rng.uniform(2.0, 8.0);
    } else {  // soil pile
      const double r = rng.uniform(4.0, 7.0);
      soil_pile(c, soil, x + r, d + r, r, rng.uniform(2.0, 4.0));
      x += 2 * r + rng.uniform(1.0, 6.0);
    }
  }
  for (double x = xa + 60.0; x < xb - 60.0;) {
    const double w = rng.uniform(15.0, 35.0);
    const double h = rng.uniform(10.0, 24.0);
    const double d = rng.uniform(0.8, 1.0) * layout.structures_max_m;
    site_box(c, x, x + w, d, d + 12.0, 0.0, h, facade(rng, w, h), facade(rng, 12.0, h),
             plain(rng, w, 12.0, 100, 2.0));
    x += w + rng.uniform(0.5, 4.0);
  }
  return mesh;
}

}  // namespace sitepose::sim::detail
