// `sitepose map info FILE`: what a saved site map holds. A file that is
// refused (truncated, corrupted, another version) exits 2 with the reason.

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command_registry.hpp"
#include "sitepose/mapfile/map_file.hpp"

namespace sitepose::cli {
namespace {

void print_summary(const std::string& path, const mapfile::MapSummary& s) {
  const auto per = [](std::uint64_t total, std::size_t n) {
    return n > 0 ? static_cast<double>(total) / n : 0.0;
  };
  std::printf("file          %s\n", path.c_str());
  std::printf("version       %u\n", s.version);
  std::printf("size          %ju bytes (%.0f bytes per keyframe)\n",
              static_cast<std::uintmax_t>(s.file_bytes), per(s.file_bytes, s.keyframes));
  std::printf("keyframes     %zu (%zu keypoints, %.0f per keyframe)\n", s.keyframes, s.keypoints,
              per(s.keypoints, s.keyframes));
  std::printf("points        %zu (%zu observations, %.1f per point)\n", s.points, s.observations,
              per(s.observations, s.points));
  std::printf("covisibility  %zu edges\n", s.covisibility_edges);
  std::printf("loop edges    %zu\n", s.loop_edges);
  std::printf(
      "area          x %.2f .. %.2f, y %.2f .. %.2f, z %.2f .. %.2f m (keyframe centres, map frame)\n",
      s.centre_min_m.x(), s.centre_max_m.x(), s.centre_min_m.y(), s.centre_max_m.y(), s.centre_min_m.z(),
      s.centre_max_m.z());
  std::printf("path          %.2f m (keyframe centres in order)\n", s.path_length_m);
  std::printf("map travel    %.2f m at the farthest keyframe (the published drift term's distance)\n",
              s.largest_map_travel_m);
  if (s.meta.anchor) {
    const auto& a = *s.meta.anchor;
    const Eigen::Vector3d t = a.T_site_slam.translation();
    std::printf("anchor        origin %.8f %.8f %.3f m, T_site_slam translation %.3f %.3f %.3f m\n",
                a.latitude_deg, a.longitude_deg, a.height_m, t.x(), t.y(), t.z());
  } else {
    std::printf("anchor        none (the map's own frame)\n");
  }
  std::printf("vocabulary    %s\n", s.meta.vocabulary_id.empty() ? "none" : s.meta.vocabulary_id.c_str());
}

const CommandRegistrar kMapInfo{
    {"map", "info", "Print what a saved site map holds", [](CLI::App& sub) -> CommandAction {
       auto path = std::make_shared<std::string>();
       sub.add_option("FILE", *path, "Map file (sitepose run --map-out)")->required();
       return [path] {
         auto loaded = mapfile::load_map(*path);
         if (!loaded) return fail("map info", loaded.error().message, 2);
         std::error_code ec;
         const auto bytes = std::filesystem::file_size(*path, ec);
         print_summary(*path, mapfile::summarise(*loaded, ec ? 0 : bytes));
         return 0;
       };
     }}};

}  // namespace
}  // namespace sitepose::cli
