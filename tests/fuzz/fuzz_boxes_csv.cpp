// A sequence's labels/boxes.csv: accepted rows hold instance ids that fit
// the 16-bit masks, non-empty boxes, sorted unique (frame, instance).
#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/io/labels.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  const fuzz::InputFile file(data, size);
  // The first byte chooses whether the frame count is known (as run does).
  const std::optional<std::size_t> n_frames =
      size > 0 && (data[0] & 1) ? std::optional<std::size_t>(data[0] >> 1) : std::nullopt;
  auto boxes = io::read_boxes_csv(file.path(), n_frames);
  if (!boxes) return 0;
  for (std::size_t i = 0; i < boxes->size(); ++i) {
    const io::LabelBox& b = (*boxes)[i];
    fuzz::require(b.instance >= 1 && b.instance <= 65535, "instance in 1..65535");
    fuzz::require(b.frame >= 0, "frame >= 0");
    fuzz::require(!n_frames || static_cast<std::size_t>(b.frame) < *n_frames, "frame < n_frames");
    fuzz::require(b.box.width > 0 && b.box.height > 0, "non-empty box");
    if (i > 0) {
      const io::LabelBox& a = (*boxes)[i - 1];
      fuzz::require(a.frame < b.frame || (a.frame == b.frame && a.instance < b.instance), "sorted, unique");
    }
  }
  return 0;
}
