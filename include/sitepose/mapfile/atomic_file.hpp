#pragma once
// Replacing a file so that a reader (or the next start after a crash or a
// power cut) sees either the old content or the new, never a mix: the bytes
// go to a temp file in the same folder (so rename stays on one file
// system), which is fsync'ed, renamed over the target, and the folder is
// fsync'ed so the rename itself is durable. A failure before the rename
// removes the temp file and leaves the target untouched.
//
// Temp name: "<target>.tmp-<pid>"; a writer killed mid-write leaves it
// behind (the target is still the old file); the next save by the same
// path removes stale ones.

#include <cstdint>
#include <filesystem>
#include <span>

#include "sitepose/core/expected.hpp"

namespace sitepose::mapfile {

Status write_file_atomically(const std::filesystem::path& target, std::span<const std::uint8_t> bytes);

}  // namespace sitepose::mapfile
