// `sitepose bench soak` as the short memory and map-size regression (issues
// 20, 19): backforth's first pass, then its periodic second pass looped
// twice, RSS and keyframes after the first loop as the reference
// (soak_check.hpp): the first loop may still add keyframes where the first
// pass did not look (3 with the travel rule of issue 24, 0 after it over
// 1300 frames). 2000 frames: soak_sweep_test.

#include "soak_check.hpp"

namespace sitepose {
namespace {

TEST(BenchSoak, RssStaysFlatAfterWarmUpOnALoopedSequence) { testing::expect_flat_rss_soak(648, 72, 432); }

}  // namespace
}  // namespace sitepose
