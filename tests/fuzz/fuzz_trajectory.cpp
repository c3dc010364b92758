// Trajectories: TUM, KITTI poses, EuRoC ground truth and EuRoC image lists
// (the first byte chooses); accepted poses are finite with unit rotations.
#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/io/euroc.hpp"
#include "sitepose/io/trajectory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  if (size == 0) return 0;
  const fuzz::InputFile file(data + 1, size - 1);
  switch (data[0] % 4) {
    case 0:
      if (auto t = io::read_tum_trajectory(file.path())) {
        for (const auto& p : *t) fuzz::require_pose(p.T_world_cam);
      }
      break;
    case 1:
      if (auto poses = io::read_kitti_poses(file.path())) {
        for (const auto& p : *poses) fuzz::require_pose(p);
      }
      break;
    case 2:
      if (auto gt = io::read_euroc_groundtruth(file.path())) {
        for (const auto& s : *gt) fuzz::require_pose(s.T_world_body);
      }
      break;
    default:
      if (auto images = io::read_euroc_image_list(file.path())) {
        for (std::size_t i = 1; i < images->size(); ++i) {
          fuzz::require((*images)[i - 1].t_ns < (*images)[i].t_ns, "image times increase");
        }
      }
      break;
  }
  return 0;
}
