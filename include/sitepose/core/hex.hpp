#pragma once
// Numbers shown in hexadecimal in messages: checksums and bus identifiers.

#include <cstdint>
#include <string>

namespace sitepose {

enum class HexStyle {
  kChecksum,  // eight lower-case digits, zero-padded: "0badf00d"
  kLiteral,   // as a C literal, upper-case, unpadded: "0x3FFFF"
};

std::string hex(std::uint32_t value, HexStyle style);

}  // namespace sitepose
