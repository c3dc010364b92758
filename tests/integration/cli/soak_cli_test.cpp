// `sitepose bench soak` as the short memory regression (issue 20): the
// backforth pass looped twice, RSS after the first loop as the reference
// (soak_check.hpp). 2000 frames: soak_sweep_test.

#include "soak_check.hpp"

namespace sitepose {
namespace {

TEST(BenchSoak, RssStaysFlatAfterWarmUpOnALoopedSequence) { testing::expect_flat_rss_soak(432, 72, 216); }

}  // namespace
}  // namespace sitepose
