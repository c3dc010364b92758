#pragma once
// CameraDevice on Aravis 0.8 (GigE Vision and USB3 Vision cameras, and
// Aravis's in-process fake camera for tests). The only file that includes
// <arv.h> is its implementation.
// Device ids are Aravis's ("Vendor-Model-Serial", or an IP address);
// "Fake_<name>" opens a new camera on Aravis's in-process fake interface
// (enabled on first use; Aravis knows it as "Fake_1" and makes an
// independent camera on each open, so "Fake_L" and "Fake_R" are a pair).
// Frame times: the buffer's timestamp is the camera's clock (GigE: the
// device's tick counter in ns); the arrival time is the buffer's system
// timestamp (CLOCK_REALTIME when the last packet came in). The stereo
// source maps one onto the other (clock_mapper.hpp).
// A camera is gone when Aravis reports its control channel lost (GigE
// heartbeat) or the stream thread fails; poll() then returns kIoError.

#include <functional>
#include <string>

#include "sitepose/drivers/aravis/camera_device.hpp"

// Aravis's opaque type, declared as <arv.h> does.
typedef struct _ArvCamera ArvCamera;  // NOLINT(bugprone-reserved-identifier): Aravis names it so

namespace sitepose::drivers::aravis {

struct AravisOpenerOptions {
  // Called with each camera after it is configured and before it streams:
  // tests install the fake camera's fill callback here.
  std::function<void(ArvCamera*, const std::string& device_id)> on_open;
};

CameraOpener aravis_camera_opener(AravisOpenerOptions options = {});

}  // namespace sitepose::drivers::aravis
