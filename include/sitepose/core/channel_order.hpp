#pragma once
// Channel order of colour images as decoded (cv::imread gives B, G, R), for
// their conversion to gray: ORB-SLAM2's Camera.RGB (0 = BGR, 1 = RGB). A
// wrong order swaps the weights of red and blue (0.299 and 0.114).

namespace sitepose {

enum class ChannelOrder { kBgr, kRgb };

}  // namespace sitepose
