// Every YAML file under config/ (recursively) loads with the loader it is
// meant for; a new file in a place this test does not know fails it until it
// is given its loader here.

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "sitepose/config/config.hpp"
#include "sitepose/config/orbslam2_settings.hpp"
#include "sitepose/daemon/daemon_config.hpp"
#include "sitepose/sim/scenario.hpp"

namespace sitepose {
namespace {

namespace fs = std::filesystem;

enum class Loader { kSitepose, kDaemon, kOrbSlam2, kScenario };

std::optional<Loader> loader_for(const fs::path& relative) {
  if (relative == "sitepose.yaml") return Loader::kSitepose;
  if (relative == "siteposed.yaml") return Loader::kDaemon;
  const std::string folder = relative.begin()->string();
  if (folder == "orbslam2") return Loader::kOrbSlam2;
  if (folder == "scenarios") return Loader::kScenario;
  if (folder == "examples") return Loader::kDaemon;  // siteposed configs for a first try
  return std::nullopt;
}

template <typename T>
std::string problem_of(const Expected<T>& loaded) {
  return loaded ? "" : loaded.error().message;
}

// The loader's error message, or "" when the file loaded.
std::string load_problem(Loader loader, const std::string& path) {
  switch (loader) {
    case Loader::kSitepose:
      return problem_of(config::load_config(path));
    case Loader::kDaemon:
      return problem_of(daemon::load_daemon_config(path));
    case Loader::kOrbSlam2:
      return problem_of(config::load_orbslam2_settings(path));
    case Loader::kScenario:
      return problem_of(sim::load_scenario(path));
  }
  return "unknown loader";
}

TEST(ConfigFiles, EveryYamlFileLoadsWithItsLoader) {
  const fs::path root = fs::path(SITEPOSE_SOURCE_DIR) / "config";
  std::map<Loader, int> files;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    const std::string extension = entry.path().extension().string();
    if (!entry.is_regular_file() || (extension != ".yaml" && extension != ".yml")) continue;
    const fs::path relative = fs::relative(entry.path(), root);
    const auto loader = loader_for(relative);
    if (!loader) {
      ADD_FAILURE() << "config/" << relative.string() << ": no loader known; add it to loader_for";
      continue;
    }
    ++files[*loader];
    EXPECT_EQ(load_problem(*loader, entry.path().string()), "") << "config/" << relative.string();
  }
  // Each loader was exercised: a renamed folder cannot empty this test.
  EXPECT_EQ(files[Loader::kSitepose], 1);
  EXPECT_GE(files[Loader::kDaemon], 2);  // siteposed.yaml and examples/
  EXPECT_GE(files[Loader::kOrbSlam2], 1);
  EXPECT_GE(files[Loader::kScenario], 8);
}

}  // namespace
}  // namespace sitepose
