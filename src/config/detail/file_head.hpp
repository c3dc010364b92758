#pragma once
// Reading a settings file with a size limit, shared by the YAML config
// reader and the ORB-SLAM2 settings reader so both refuse a folder and a
// missing file with the same kinds of error.

#include <cstddef>
#include <string>
#include <string_view>

#include "sitepose/core/expected.hpp"

namespace sitepose::config::detail {

// The first limit + 1 bytes of the file at path: one byte past the limit
// tells a file at the limit from a larger one without reading all of a
// huge file; the caller decides what a larger file is told. Errors name the
// file as "<noun> <path>": kInvalidArgument for a directory (the message ends
// with directory_hint), kNotFound when it cannot be opened, kIoError when the
// read fails.
Expected<std::string> read_file_head(const std::string& path, std::size_t limit, std::string_view noun,
                                     std::string_view directory_hint);

}  // namespace sitepose::config::detail
