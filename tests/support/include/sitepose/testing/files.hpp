#pragma once
// Temp folders and small file helpers for tests.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace sitepose::testing {

// Writes `text` to `path` (the folder must exist).
inline void write_file(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

// The whole file; empty when it cannot be read.
inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The file's lines without their line ends; none when it cannot be read.
inline std::vector<std::string> read_lines(const std::string& path) {
  std::vector<std::string> lines;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// A fresh folder under the system temp folder, removed with the object
// unless the test failed (then kept, and its path printed, for a look).
// Its name holds `tag` (default: the running test's suite and name), the
// process id and a count, so parallel ctest processes never share one.
class TempDir {
 public:
  explicit TempDir(const std::string& tag = "") {
    static std::atomic<int> count{0};
    std::string name = "sitepose-" + (tag.empty() ? running_test_name() : tag) + "-" +
                       std::to_string(::getpid()) + "-" + std::to_string(count++);
    std::replace(name.begin(), name.end(), '/', '_');  // parameterised test names
    path_ = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    if (::testing::Test::HasFailure()) {
      std::printf("kept %s\n", path_.c_str());
      return;
    }
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  // Path of `name` inside the folder.
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

  // Writes `text` to `name` (parent folders created); returns its path.
  std::string write(const std::string& name, const std::string& text) const {
    const std::filesystem::path p = path_ / name;
    std::filesystem::create_directories(p.parent_path());
    write_file(p.string(), text);
    return p.string();
  }

 private:
  static std::string running_test_name() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    if (info == nullptr) return "suite";  // SetUpTestSuite: pass a tag
    return std::string(info->test_suite_name()) + "." + info->name();
  }

  std::filesystem::path path_;
};

}  // namespace sitepose::testing
