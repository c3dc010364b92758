// `sitepose bench soak` as the short memory and map-size regression (issues
// 20, 19): backforth's first pass, then its periodic second pass once, RSS
// and keyframes after the first pass as the reference (soak_check.hpp).
// 2000 frames: soak_sweep_test.

#include "soak_check.hpp"

namespace sitepose {
namespace {

TEST(BenchSoak, RssStaysFlatAfterWarmUpOnALoopedSequence) { testing::expect_flat_rss_soak(432, 72, 216); }

}  // namespace
}  // namespace sitepose
