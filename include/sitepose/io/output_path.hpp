#pragma once
// Checks an output path before a long run, so a typo in it is bad usage at
// the start (exit 2), not a failure after the work is done.

#include <string>

#include "sitepose/core/expected.hpp"

namespace sitepose::io {

// Ok when `path` can be opened for writing: an existing writable file or
// device, or a new file in an existing writable folder. Leaves no file
// behind and changes none. kInvalidArgument naming the path and the reason.
Status check_output_path(const std::string& path);

}  // namespace sitepose::io
