#pragma once
// Text outputs written in one go (a simulated sequence's calib.txt and
// times.txt, a debug record's run.txt, the HTML report).

#include <filesystem>
#include <string>

#include "sitepose/core/expected.hpp"

namespace sitepose::io {

// Creates or truncates `path` and writes `text`; kIoError "cannot write
// <path>" when it cannot be opened or the write fails (a full disk shows
// only at close).
Status write_text_file(const std::filesystem::path& path, const std::string& text);

}  // namespace sitepose::io
