// A writer killed mid-save (SIGKILL: no handler, no clean-up) must leave
// the previous map file loadable.

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "map_fixture.hpp"
#include "sitepose/mapfile/atomic_file.hpp"
#include "sitepose/mapfile/map_file.hpp"
#include "sitepose/testing/files.hpp"
#include "sitepose/testing/wait.hpp"

namespace sitepose::mapfile {
namespace {

bool temp_exists(const std::filesystem::path& folder) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (entry.path().filename().string().find(".tmp-") != std::string::npos) return true;
  }
  return false;
}

TEST(MapFileCrash, WriterKilledMidSaveLeavesThePreviousFile) {
  testing::TempDir dir;
  const std::string path = dir / "site.map";
  map::SharedMap old_map;
  test::build_map(old_map, 3);
  ASSERT_TRUE(old_map.read([&](const map::MapData& m) { return save_map(path, m, {}); }));
  // A large map (tens of MB) keeps the writer inside a save most of the time.
  map::SharedMap big;
  test::build_map(big, 40, 1500);
  const std::vector<std::uint8_t> bytes = big.read([](const map::MapData& m) { return encode_map(m, {}); });

  int killed_mid_save = 0;
  for (int attempt = 0; attempt < 5 && killed_mid_save < 2; ++attempt) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      // The child only saves, then leaves without running gtest's exit.
      for (int i = 0; i < 1000; ++i) (void)write_file_atomically(path, bytes);
      ::_exit(0);
    }
    const bool writing = testing::wait_for([&] { return temp_exists(dir.path()); }, std::chrono::seconds(20),
                                           std::chrono::milliseconds(1));
    ::kill(child, SIGKILL);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(writing) << "the writer never started a save";
    EXPECT_TRUE(WIFSIGNALED(status));
    if (temp_exists(dir.path())) ++killed_mid_save;
    auto loaded = load_map(path);
    ASSERT_TRUE(loaded) << "attempt " << attempt << ": " << loaded.error().message;
    // Either the old map or a complete new one, never a mix.
    EXPECT_TRUE(loaded->map.keyframe_count() == 3U || loaded->map.keyframe_count() == 39U)
        << loaded->map.keyframe_count();
  }
  EXPECT_GE(killed_mid_save, 1) << "no kill landed inside a save";
}

}  // namespace
}  // namespace sitepose::mapfile
