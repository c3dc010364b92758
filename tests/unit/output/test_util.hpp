#pragma once
// Byte-level expectations for the CAN encoder tests.

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "sitepose/output/can_frame.hpp"

namespace sitepose::output::testing {

inline std::string hex_bytes(const std::uint8_t* p, std::size_t n) {
  std::string s;
  char buf[4];
  for (std::size_t i = 0; i < n; ++i) {
    std::snprintf(buf, sizeof(buf), "%02X", p[i]);
    s += buf;
    if (i + 1 < n) s += ' ';
  }
  return s;
}

// Compares dlc and every data byte, printing both in hex on mismatch.
inline void expect_data(const CanFrame& f, const std::vector<std::uint8_t>& expected) {
  ASSERT_EQ(f.dlc, expected.size());
  EXPECT_EQ(hex_bytes(f.data.data(), f.dlc), hex_bytes(expected.data(), expected.size()));
}

}  // namespace sitepose::output::testing
