#include "detail/models.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "detail/texture_gen.hpp"

namespace sitepose::sim::detail {
namespace {

using Eigen::Vector3d;

// Sun in model/site frames: from the front-right, high, so that faces turned
// different ways differ in brightness (edges of boxes become image edges).
float face_shade(const Vector3d& normal) {
  const Vector3d sun = Vector3d(0.35, -0.55, 0.76).normalized();
  return static_cast<float>(0.6 + 0.45 * std::max(0.0, normal.normalized().dot(sun)));
}

TexturePtr tex(const cv::Mat& img, TextureWrap wrap = TextureWrap::kClamp) {
  return std::make_shared<const Texture>(img, wrap);
}

// Patch showing the whole texture upright: s to the viewer's right, t up.
Patch face(const Vector3d& origin, const Vector3d& right, const Vector3d& up, TexturePtr t) {
  Patch p;
  p.origin = origin;
  p.axis_u = right;
  p.axis_v = up;
  p.texture = std::move(t);
  p.tex_x0 = 0.0;
  p.tex_du = p.texture->width();
  p.tex_y0 = p.texture->height();
  p.tex_dv = -p.texture->height();
  p.shade = face_shade(right.cross(up));
  return p;
}

// Faces of a box: front (+x), back (-x), left (+y), right (-y), top (+z).
// The bottom is never seen from above ground and is left out.
struct BoxTextures {
  TexturePtr front, back, left, right, top;
};

// Box spanned by R * (size.x, 0, 0), R * (0, size.y, 0), R * (0, 0, size.z)
// from `corner` (its min corner in the box's own axes).
void add_box(Mesh& mesh, const Vector3d& corner, const Vector3d& size, const BoxTextures& t,
             const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity()) {
  const Vector3d ex = R.col(0) * size.x();
  const Vector3d ey = R.col(1) * size.y();
  const Vector3d ez = R.col(2) * size.z();
  mesh.patches.push_back(face(corner, ex, ez, t.right));            // -y: right = +x
  mesh.patches.push_back(face(corner + ey + ex, -ex, ez, t.left));  // +y: right = -x
  mesh.patches.push_back(face(corner + ex, ey, ez, t.front));       // +x: right = +y
  mesh.patches.push_back(face(corner + ey, -ey, ez, t.back));       // -x: right = -y
  Patch top = face(corner + ez, ex, ey, t.top);
  mesh.patches.push_back(top);
}

void add_box(Mesh& mesh, const Vector3d& lo, const Vector3d& hi, const TexturePtr& all) {
  add_box(mesh, lo, hi - lo, BoxTextures{all, all, all, all, all});
}

// Cylinder with its axis along y (wheels, drums): `sides` rectangles and two
// end discs.
void add_cylinder(Mesh& mesh, const Vector3d& centre, double radius, double width, int sides,
                  const TexturePtr& tread, const TexturePtr& hub) {
  const Vector3d half_w(0.0, width * 0.5, 0.0);
  for (int i = 0; i < sides; ++i) {
    const double a0 = 2.0 * std::numbers::pi * i / sides;
    const double a1 = 2.0 * std::numbers::pi * (i + 1) / sides;
    const Vector3d p0 = centre + radius * Vector3d(std::cos(a0), 0.0, std::sin(a0));
    const Vector3d p1 = centre + radius * Vector3d(std::cos(a1), 0.0, std::sin(a1));
    Patch p;
    p.origin = p0 - half_w;
    p.axis_u = p1 - p0;
    p.axis_v = 2.0 * half_w;
    const Vector3d outward = (0.5 * (p0 + p1) - centre).normalized();
    if (p.axis_u.cross(p.axis_v).dot(outward) < 0.0) {
      p.origin = p1 - half_w;
      p.axis_u = p0 - p1;
    }
    p.texture = tread;
    p.tex_x0 = tread->width() * static_cast<double>(i) / sides;
    p.tex_du = tread->width() / static_cast<double>(sides);
    p.tex_y0 = 0.0;
    p.tex_dv = tread->height();
    p.shade = face_shade(outward);
    mesh.patches.push_back(p);
  }
  for (int side = -1; side <= 1; side += 2) {
    Patch cap;
    cap.shape = Shape::kEllipse;
    cap.origin = centre + side * half_w;
    cap.axis_u = side > 0 ? Vector3d(0, 0, radius) : Vector3d(radius, 0, 0);
    cap.axis_v = side > 0 ? Vector3d(radius, 0, 0) : Vector3d(0, 0, radius);
    cap.texture = hub;
    cap.tex_x0 = hub->width() * 0.5;
    cap.tex_du = hub->width() * 0.5;
    cap.tex_y0 = hub->height() * 0.5;
    cap.tex_dv = hub->height() * 0.5;
    cap.shade = face_shade(Vector3d(0, side, 0));
    mesh.patches.push_back(cap);
  }
}

// --- textures of machine parts (100 texels per metre unless said) ---
constexpr double kMachineTpm = 100.0;

TexturePtr painted_panel(Rng& rng, double w, double h, int paint, double dirt, const std::string& label,
                         bool stripes, bool grille) {
  Canvas c(rng, w, h, kMachineTpm, paint, 5.0);
  c.seams(std::max(0.6, w / std::max(1, static_cast<int>(w / 1.1))), h > 1.2 ? h * 0.5 : 0.0, 20);
  c.rivets(0.25, 0.06);
  if (grille && w > 1.2 && h > 0.6) c.grille(w * 0.55, h * 0.2, std::min(1.2, w * 0.35), h * 0.55, 0.06);
  if (!label.empty() && w > 1.0 && h > 0.4) {
    const double th = std::min(0.32, h * 0.28);
    c.rect(0.12, h * 0.25 - 0.05, std::min(w * 0.5, label.size() * th * 0.8 + 0.2), th + 0.12, 40);
    c.text(label, 0.2, h * 0.25 + th, th, paint > 150 ? 235 : 230);
    c.text(std::to_string(rng.integer(100, 999)), w * 0.15, h * 0.8, 0.16, 30);
  }
  if (stripes && h > 0.3) c.hazard_stripes(0.0, h - 0.18, w, 0.16);
  // Warning stickers and lamps.
  for (int i = 0; i < 3; ++i) {
    const double sx = rng.uniform(0.1, std::max(0.2, w - 0.3));
    const double sy = rng.uniform(0.05, std::max(0.1, h - 0.25));
    c.rect(sx, sy, 0.16, 0.12, rng.chance(0.5) ? 30 : 240);
    c.text("!", sx + 0.05, sy + 0.1, 0.08, 128);
  }
  c.dirt(dirt, 1.0);
  return tex(c.image());
}

TexturePtr cab_side(Rng& rng, double w, double h, int paint, bool door) {
  Canvas c(rng, w, h, kMachineTpm, paint, 5.0);
  c.window(0.12, 0.1, w - 0.24, h * 0.5);
  if (door) {
    c.rect(w * 0.3, 0.05, w * 0.45, h - 0.1, 60, false, 2);
    c.rect(w * 0.68, h * 0.62, 0.12, 0.04, 30);
  }
  c.rivets(0.3, 0.05);
  c.dirt(0.15, 1.0);
  return tex(c.image());
}

TexturePtr steel_drum(Rng& rng, double circumference_m, double width_m) {
  Canvas c(rng, circumference_m, width_m, kMachineTpm, 120, 10.0);
  c.seams(circumference_m / 8.0, 0.0, 30);
  c.dirt(0.5, 0.0);
  // Scratches along the rolling direction.
  for (int i = 0; i < 60; ++i) {
    const double x = rng.uniform(0, circumference_m);
    const double y = rng.uniform(0, width_m);
    cv::line(c.image(), c.px(x, y), c.px(x + rng.uniform(0.1, 0.5), y), rng.integer(150, 210), 1);
  }
  return tex(c.image());
}

TexturePtr tyre_tread(Rng& rng, double circumference_m, double width_m) {
  Canvas c(rng, circumference_m, width_m, kMachineTpm, 45, 6.0);
  for (double x = 0.0; x < circumference_m; x += 0.12) {
    c.rect(x, 0.02, 0.05, width_m * 0.45, 25);
    c.rect(x + 0.06, width_m * 0.55, 0.05, width_m * 0.43, 25);
    c.rect(x + 0.02, width_m * 0.47, 0.02, 0.03, 90);
  }
  c.dirt(0.4, 0.0);
  return tex(c.image());
}

TexturePtr hub(Rng& rng, double radius_m, int paint, bool tyre) {
  const double d = 2.0 * radius_m;
  Canvas c(rng, d, d, kMachineTpm, tyre ? 40 : paint, 6.0);
  if (tyre) c.circle(radius_m, radius_m, radius_m * 0.62, paint, true);
  c.circle(radius_m, radius_m, radius_m * 0.62, 30, false);
  c.circle(radius_m, radius_m, radius_m * 0.22, 70, true);
  for (int i = 0; i < 8; ++i) {
    const double a = 2.0 * std::numbers::pi * i / 8.0;
    c.circle(radius_m + 0.4 * radius_m * std::cos(a), radius_m + 0.4 * radius_m * std::sin(a), 0.025, 225,
             true);
  }
  c.text(std::to_string(rng.integer(10, 99)), radius_m * 0.7, radius_m * 1.75, radius_m * 0.12, 200);
  c.dirt(0.4, 0.8);
  return tex(c.image());
}

TexturePtr track_side(Rng& rng, double w, double h) {
  Canvas c(rng, w, h, kMachineTpm, 55, 8.0);
  for (double x = 0.0; x < w; x += 0.19) c.rect(x, 0.0, 0.07, h, 30);                   // grousers
  for (double x = 0.4; x < w - 0.3; x += 0.55) c.circle(x, h * 0.62, 0.13, 150, true);  // rollers
  c.rect(0.2, h * 0.25, w - 0.4, 0.08, 90);
  c.dirt(0.8, 0.6);
  return tex(c.image());
}

TexturePtr load_top(Rng& rng, double w, double h) {
  cv::Mat img;
  cv::resize(soil_tile(rng, 256), img, cv::Size(static_cast<int>(w * 60), static_cast<int>(h * 60)));
  return tex(img);
}

BoxTextures painted_box(Rng& rng, const Vector3d& size, int paint, double dirt, const std::string& label,
                        bool stripes, bool grille) {
  BoxTextures t;
  t.left = painted_panel(rng, size.x(), size.z(), paint, dirt, label, stripes, grille);
  t.right = painted_panel(rng, size.x(), size.z(), paint, dirt, label, stripes, grille);
  t.front = painted_panel(rng, size.y(), size.z(), paint, dirt, "", stripes, false);
  t.back = painted_panel(rng, size.y(), size.z(), paint, dirt, "", stripes, grille);
  t.top = painted_panel(rng, size.x(), size.y(), paint - 15, dirt * 1.5, "", false, false);
  return t;
}

// A cab of size (length, width, height) with windows all round and a door
// on each side. Every panel draws from rng: the order left, right, front,
// back, top is part of what each scene renders, so keep it.
BoxTextures glass_cab(Rng& rng, const Vector3d& size, int paint) {
  BoxTextures t;
  t.left = cab_side(rng, size.x(), size.z(), paint, true);
  t.right = cab_side(rng, size.x(), size.z(), paint, true);
  t.front = cab_side(rng, size.y(), size.z(), paint, false);
  t.back = cab_side(rng, size.y(), size.z(), paint, false);
  t.top = painted_panel(rng, size.x(), size.y(), paint, 0.2, "", false, false);
  return t;
}

int paint_or_default(const std::string& name) {
  const int level = paint_level(name);
  return level >= 0 ? level : paint_level("yellow");
}

// What a machine is painted with and says on its side: the scenario's
// choice, or yellow and the model's own label when it makes none.
struct Livery {
  int paint;
  std::string label;
};

Livery livery_of(const MachineLook& look, const char* model_label) {
  return {paint_or_default(look.paint), look.label.empty() ? model_label : look.label};
}

Eigen::Matrix3d pitch_up(double angle_rad) {
  // Rotation about y that turns +x towards +z.
  return Eigen::AngleAxisd(-angle_rad, Vector3d::UnitY()).toRotationMatrix();
}

}  // namespace

Mesh make_roller(Rng& rng, const MachineLook& look) {
  Mesh m;
  const auto [paint, label] = livery_of(look, "ROLLMAX");
  // Front drum and its frame.
  add_cylinder(m, {1.9, 0.0, 0.75}, 0.75, 2.1, 16, steel_drum(rng, 2 * std::numbers::pi * 0.75, 2.1),
               hub(rng, 0.75, paint, false));
  add_box(m, {1.0, -1.15, 1.35}, {1.8, 2.3, 0.4},
          painted_box(rng, {1.8, 2.3, 0.4}, paint, 0.3, "", true, false));
  for (double y : {-1.2, 1.07}) {
    add_box(m, {1.25, y, 0.35}, {1.3, 0.13, 1.05},
            painted_box(rng, {1.3, 0.13, 1.05}, paint, 0.5, "", false, false));
  }
  // Rear body (engine) with wheels.
  const Vector3d body_size(3.8, 2.2, 1.4);
  add_box(m, {-2.9, -1.1, 0.5}, body_size, painted_box(rng, body_size, paint, 0.35, label, true, true));
  const TexturePtr tread = tyre_tread(rng, 2 * std::numbers::pi * 0.75, 0.6);
  const TexturePtr wheel_hub = hub(rng, 0.75, paint, true);
  add_cylinder(m, {-1.9, 0.88, 0.75}, 0.75, 0.6, 16, tread, wheel_hub);
  add_cylinder(m, {-1.9, -0.88, 0.75}, 0.75, 0.6, 16, tread, wheel_hub);
  // Cab (mostly glass), roof and beacon.
  const Vector3d cab_size(2.0, 1.9, 1.1);
  add_box(m, {-1.7, -0.95, 1.9}, cab_size, glass_cab(rng, cab_size, paint));
  add_box(m, {-1.85, -1.05, 3.0}, {2.3, 2.1, 0.15},
          painted_box(rng, {2.3, 2.1, 0.15}, paint, 0.2, "", false, false));
  add_box(m, {-0.8, -0.1, 3.15}, {-0.6, 0.1, 3.35}, tex(Canvas(rng, 0.2, 0.2, kMachineTpm, 170).image()));
  return m;
}

Mesh make_truck(Rng& rng, const MachineLook& look) {
  Mesh m;
  const auto [paint, label] = livery_of(look, "HAULCO");
  add_box(m, {-4.2, -0.9, 0.55}, {4.2, 0.9, 1.05}, painted_panel(rng, 8.4, 0.5, 50, 0.8, "", false, false));
  // Cab: windows, door, grille and lights at the front.
  BoxTextures cab;
  cab.left = cab_side(rng, 1.65, 2.2, paint, true);
  cab.right = cab_side(rng, 1.65, 2.2, paint, true);
  {
    Canvas front(rng, 2.5, 2.2, kMachineTpm, paint, 5.0);
    front.window(0.15, 0.15, 2.2, 0.8);
    front.grille(0.5, 1.2, 1.5, 0.6, 0.07);
    front.rect(0.15, 1.35, 0.25, 0.15, 235);
    front.rect(2.1, 1.35, 0.25, 0.15, 235);
    front.text(label, 0.8, 1.15, 0.14, 30);
    front.dirt(0.3, 1.0);
    cab.front = tex(front.image());
  }
  cab.back = painted_panel(rng, 2.5, 2.2, paint, 0.3, "", false, true);
  cab.top = painted_panel(rng, 1.65, 2.5, paint, 0.2, "", false, false);
  add_box(m, {2.6, -1.25, 1.0}, {1.65, 2.5, 2.2}, cab);
  // Tipper body with ribs, fleet number and a load of soil on top.
  const Vector3d bed_size(6.6, 2.5, 1.8);
  BoxTextures bed =
      painted_box(rng, bed_size, paint_level("gray") + rng.integer(-20, 30), 0.6, label, false, false);
  bed.top = load_top(rng, bed_size.x(), bed_size.y());
  add_box(m, {-4.2, -1.25, 1.1}, bed_size, bed);
  // Fuel tank, mudguards, wheels.
  add_box(m, {0.6, -1.2, 0.6}, {1.2, 0.35, 0.55},
          painted_box(rng, {1.2, 0.35, 0.55}, 190, 0.5, "DIESEL", false, false));
  const TexturePtr tread = tyre_tread(rng, 2 * std::numbers::pi * 0.52, 0.45);
  const TexturePtr wheel_hub = hub(rng, 0.52, 200, true);
  for (double x : {3.3, -1.6, -2.9}) {
    for (double y : {-1.02, 1.02}) add_cylinder(m, {x, y, 0.52}, 0.52, 0.45, 12, tread, wheel_hub);
  }
  return m;
}

std::vector<JointPart> make_excavator_parts(Rng& rng, const MachineLook& look) {
  const auto [paint, label] = livery_of(look, "EX 320");
  std::vector<JointPart> parts(5);
  JointPart& under = parts[0];
  under.name = "undercarriage";
  for (double y : {0.7, -1.35}) {
    BoxTextures t;
    t.left = t.right = track_side(rng, 4.6, 0.9);
    t.front = t.back = track_side(rng, 0.65, 0.9);
    t.top = track_side(rng, 4.6, 0.65);
    add_box(under.mesh, {-2.3, y, 0.0}, {4.6, 0.65, 0.9}, t);
  }
  add_box(under.mesh, {-1.0, -0.7, 0.3}, {1.0, 0.7, 1.0},
          painted_panel(rng, 2.0, 0.7, 60, 0.8, "", false, false));
  JointPart& house_part = parts[1];
  house_part = {"house", {}, 0, Vector3d::Zero(), Vector3d::UnitZ(), JointDrive::kSlew, 1.0};
  const Vector3d house(3.2, 2.7, 1.3);
  add_box(house_part.mesh, {-2.2, -1.35, 1.0}, house,
          painted_box(rng, house, paint, 0.3, label, false, true));
  add_box(house_part.mesh, {-2.65, -1.35, 1.0}, {0.45, 2.7, 1.15},
          painted_box(rng, {0.45, 2.7, 1.15}, 60, 0.4, "", true, false));
  BoxTextures cab;
  cab.left = cab_side(rng, 1.7, 2.0, paint, true);
  cab.right = cab_side(rng, 1.7, 2.0, paint, false);
  cab.front = cab_side(rng, 1.0, 2.0, paint, false);
  cab.back = painted_panel(rng, 1.0, 2.0, paint, 0.2, "", false, false);
  cab.top = painted_panel(rng, 1.7, 1.0, paint, 0.2, "", false, false);
  add_box(house_part.mesh, {0.0, 0.35, 1.0}, {1.7, 1.0, 2.0}, cab);
  // Boom up 40 deg, stick down, bucket: tilted boxes. Digging lowers the
  // boom a little and curls stick and bucket in (turns about y).
  const double boom_len = 4.2, stick_len = 2.6;
  const Eigen::Matrix3d R_boom = pitch_up(40.0 * std::numbers::pi / 180.0);
  const Vector3d boom_start(0.9, -0.55, 1.6);
  parts[2] = {"boom", {}, 1, boom_start, Vector3d::UnitY(), JointDrive::kDig, 0.35};
  add_box(parts[2].mesh, boom_start, {boom_len, 0.5, 0.55},
          painted_box(rng, {boom_len, 0.5, 0.55}, paint, 0.4, "", false, false), R_boom);
  const Vector3d boom_end = boom_start + R_boom.col(0) * boom_len;
  const Eigen::Matrix3d R_stick = pitch_up(-60.0 * std::numbers::pi / 180.0);
  parts[3] = {"arm", {}, 2, boom_end, Vector3d::UnitY(), JointDrive::kDig, -0.8};
  add_box(parts[3].mesh, boom_end, {stick_len, 0.45, 0.45},
          painted_box(rng, {stick_len, 0.45, 0.45}, paint, 0.5, "", false, false), R_stick);
  const Vector3d stick_end = boom_end + R_stick.col(0) * stick_len;
  parts[4] = {"bucket", {}, 3, stick_end, Vector3d::UnitY(), JointDrive::kDig, -1.2};
  add_box(parts[4].mesh, stick_end - Vector3d(0.3, 0.0, 0.4), {0.9, 1.1, 0.8},
          painted_box(rng, {0.9, 1.1, 0.8}, 70, 1.0, "", false, false));
  return parts;
}

Mesh merge_parts(const std::vector<JointPart>& parts) {
  Mesh m;
  for (const JointPart& p : parts)
    m.patches.insert(m.patches.end(), p.mesh.patches.begin(), p.mesh.patches.end());
  return m;
}

Mesh make_excavator(Rng& rng, const MachineLook& look) {
  return merge_parts(make_excavator_parts(rng, look));
}

std::vector<JointPart> make_loader_parts(Rng& rng, const MachineLook& look) {
  const auto [paint, label] = livery_of(look, "WL 150");
  std::vector<JointPart> parts(3);
  JointPart& body = parts[0];
  body.name = "body";
  const Vector3d rear(3.0, 2.3, 1.5);
  add_box(body.mesh, {-3.0, -1.15, 0.6}, rear, painted_box(rng, rear, paint, 0.35, label, true, true));
  add_box(body.mesh, {0.0, -0.6, 0.6}, {1.2, 1.2, 0.7},
          painted_box(rng, {1.2, 1.2, 0.7}, paint, 0.4, "", false, false));
  const Vector3d cab_size(1.6, 1.5, 1.4);
  add_box(body.mesh, {-1.6, -0.75, 2.1}, cab_size, glass_cab(rng, cab_size, paint));
  const TexturePtr tread = tyre_tread(rng, 2 * std::numbers::pi * 0.7, 0.55);
  const TexturePtr wheel_hub = hub(rng, 0.7, 200, true);
  for (double x : {-2.0, 0.9}) {
    for (double y : {-1.05, 1.05}) add_cylinder(body.mesh, {x, y, 0.7}, 0.7, 0.55, 14, tread, wheel_hub);
  }
  // Lift arms from the front frame, pitched down to the bucket.
  const Vector3d arm_pivot(0.8, 0.0, 1.8);
  const double arm_len = 2.4;
  const Eigen::Matrix3d R_arm = pitch_up(-32.0 * std::numbers::pi / 180.0);
  parts[1] = {"arm", {}, -1, arm_pivot, Vector3d::UnitY(), JointDrive::kDig, -1.0};
  for (double y : {-0.85, 0.6}) {
    add_box(parts[1].mesh, arm_pivot + Vector3d(0.0, y, 0.0), {arm_len, 0.25, 0.3},
            painted_box(rng, {arm_len, 0.25, 0.3}, paint, 0.5, "", false, false), R_arm);
  }
  const Vector3d arm_end = arm_pivot + R_arm.col(0) * arm_len;
  parts[2] = {"bucket", {}, 1, arm_end, Vector3d::UnitY(), JointDrive::kDig, 0.7};
  add_box(parts[2].mesh, arm_end + Vector3d(-0.1, -1.3, -0.35), {0.9, 2.6, 0.85},
          painted_box(rng, {0.9, 2.6, 0.85}, 70, 1.0, "", false, false));
  return parts;
}

Mesh make_person(Rng& rng, const MachineLook& look, bool crouching) {
  Mesh m;
  const int vest = paint_or_default(look.paint.empty() ? "orange" : look.paint);
  Canvas v(rng, 0.45, 0.6, 200.0, vest, 6.0);
  v.rect(0.0, 0.18, 0.45, 0.05, 240);
  v.rect(0.0, 0.38, 0.45, 0.05, 240);
  if (!look.label.empty()) v.text(look.label, 0.05, 0.3, 0.06, 30);
  v.dirt(0.3, 1.0);
  const TexturePtr torso = tex(v.image());
  const TexturePtr trousers = tex(Canvas(rng, 0.3, 0.9, 200.0, 60, 8.0).image());
  const TexturePtr skin = tex(Canvas(rng, 0.22, 0.22, 200.0, 150, 6.0).image());
  const TexturePtr helmet = tex(Canvas(rng, 0.3, 0.3, 200.0, 235, 4.0).image());
  const double leg_h = crouching ? 0.45 : 0.85;
  const double lean = crouching ? 0.15 : 0.0;
  for (double y : {-0.17, 0.02})
    add_box(m, {-0.08, y, 0.0}, {0.16, 0.15, leg_h},
            BoxTextures{trousers, trousers, trousers, trousers, trousers});
  if (crouching) {  // thighs forward
    for (double y : {-0.17, 0.02})
      add_box(m, {0.0, y, leg_h - 0.12}, {0.4, 0.15, 0.14},
              BoxTextures{trousers, trousers, trousers, trousers, trousers});
  }
  add_box(m, {-0.14 + lean, -0.22, leg_h}, {0.28, 0.45, 0.6}, BoxTextures{torso, torso, torso, torso, torso});
  for (double y : {-0.3, 0.22}) {
    add_box(m, {-0.05 + lean, y, leg_h + 0.05}, {0.12, 0.08, 0.55},
            BoxTextures{torso, torso, torso, torso, torso});
  }
  add_box(m, {-0.1 + lean, -0.1, leg_h + 0.62}, {0.2, 0.2, 0.2}, BoxTextures{skin, skin, skin, skin, skin});
  add_box(m, {-0.14 + lean, -0.14, leg_h + 0.8}, {0.28, 0.28, 0.1},
          BoxTextures{helmet, helmet, helmet, helmet, helmet});
  return m;
}

Mesh make_cone(Rng& rng) {
  Mesh m;
  Canvas c(rng, 0.32, 0.64, kMachineTpm, paint_level("orange"), 4.0);
  c.rect(0.0, 0.2, 0.32, 0.1, 235);
  c.rect(0.0, 0.36, 0.32, 0.08, 235);
  c.dirt(0.3, 1.0);
  const TexturePtr body = tex(c.image());
  const int sides = 8;
  const double r = 0.16, h = 0.72;
  const Vector3d apex(0, 0, h);
  for (int i = 0; i < sides; ++i) {
    const double a0 = 2.0 * std::numbers::pi * i / sides;
    const double a1 = 2.0 * std::numbers::pi * (i + 1) / sides;
    const Vector3d p0(r * std::cos(a0), r * std::sin(a0), 0.03);
    const Vector3d p1(r * std::cos(a1), r * std::sin(a1), 0.03);
    Patch p;
    p.shape = Shape::kTriangle;
    p.origin = p0;
    p.axis_u = p1 - p0;
    p.axis_v = apex - p0;
    p.texture = body;
    p.tex_x0 = 0.0;
    p.tex_du = body->width();
    p.tex_y0 = body->height();
    p.tex_dv = -body->height();
    p.shade = face_shade(p.axis_u.cross(p.axis_v));
    m.patches.push_back(p);
  }
  add_box(m, {-0.2, -0.2, 0.0}, {0.2, 0.2, 0.03}, tex(Canvas(rng, 0.4, 0.4, kMachineTpm, 35).image()));
  return m;
}

}  // namespace sitepose::sim::detail
