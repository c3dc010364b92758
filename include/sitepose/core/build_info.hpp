#pragma once

namespace sitepose {

const char* version_string();   // e.g. "0.1.0"
const char* git_revision();     // short hash of the build, or "unknown"
const char* build_type();       // CMake build type

}  // namespace sitepose
