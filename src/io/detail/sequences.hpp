#pragma once
// Layout-specific openers behind open_sequence().

#include <memory>
#include <string>

#include "sitepose/io/sequence.hpp"

namespace sitepose::io::detail {

// `dir` holds image_0/, image_1/, calib.txt, times.txt.
Expected<std::unique_ptr<Sequence>> open_sitepose_sequence(const std::string& dir,
                                                           const SequenceOptions& options);
// `mav0_dir` holds cam0/, cam1/; `dir` is what the user named (source id).
Expected<std::unique_ptr<Sequence>> open_euroc_sequence(const std::string& dir,
                                                        const std::string& mav0_dir,
                                                        const SequenceOptions& options);

}  // namespace sitepose::io::detail
