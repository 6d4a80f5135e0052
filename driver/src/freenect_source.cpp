#include "shapesense/driver/freenect_source.h"

#include <libfreenect.h>
#include <sys/time.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>

// Not in Debian's fakenect build; used only when present.
#pragma weak freenect_list_device_attributes
#pragma weak freenect_free_device_attributes

namespace shapesense {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;
constexpr int kLibusbErrorInterrupted = -10;  // LIBUSB_ERROR_INTERRUPTED: a signal, not a failure

/// The first camera serial libfreenect enumerates at `index`, when it can tell.
std::string serialAt(freenect_context* ctx, int index) {
  if (&freenect_list_device_attributes == nullptr || &freenect_free_device_attributes == nullptr) {
    return {};
  }
  freenect_device_attributes* list = nullptr;
  if (freenect_list_device_attributes(ctx, &list) < 0) return {};
  std::string serial;
  int i = 0;
  for (auto* node = list; node != nullptr; node = node->next, ++i) {
    if (i == index && node->camera_serial != nullptr) serial = node->camera_serial;
  }
  freenect_free_device_attributes(list);
  return serial;
}

class FreenectSession final : public DeviceSession {
 public:
  /// Takes ownership of an initialised context; opens and starts the device or throws.
  FreenectSession(freenect_context* ctx, const FreenectOptions& options)
      : ctx_(ctx), options_(options), to_mm_(options.raw) {
    try {
      start();
    } catch (...) {
      close();
      throw;
    }
  }

  ~FreenectSession() override { close(); }

  /// One freenect_process_events_timeout call; callbacks run inside it, on this thread.
  std::optional<std::string> pump(std::chrono::milliseconds budget,
                                  const DeviceImageSink& sink) override {
    return pumpImpl(budget, sink);
  }
  CameraIntrinsics intrinsics() const override { return options_.intrinsics; }
  bool hasColour() const override { return options_.colour; }
  std::string name() const override { return name_; }

 private:
  void start() {
    const auto& device = options_.device;
    int rc;
    if (!device.serial.empty()) {
      rc = freenect_open_device_by_camera_serial(ctx_, &dev_, device.serial.c_str());
      name_ = "Kinect serial " + device.serial;
    } else {
      rc = freenect_open_device(ctx_, &dev_, device.index);
      const std::string serial = serialAt(ctx_, device.index);
      name_ = "Kinect #" + std::to_string(device.index) +
              (serial.empty() ? "" : " (serial " + serial + ")");
    }
    if (rc < 0 || dev_ == nullptr) {
      dev_ = nullptr;
      throw std::runtime_error("cannot open " + name_ + " (freenect error " + std::to_string(rc) +
                               "; is it in use, or missing udev permissions?)");
    }
    freenect_set_user(dev_, this);
    freenect_set_depth_callback(dev_, &FreenectSession::depthCallback);
    // Only the modes Debian's fakenect serves: 11-bit depth and RGB, both 640x480.
    if (freenect_set_depth_mode(
            dev_, freenect_find_depth_mode(FREENECT_RESOLUTION_MEDIUM, FREENECT_DEPTH_11BIT)) < 0) {
      throw std::runtime_error(name_ + ": cannot set 11-bit depth mode");
    }
    if (freenect_start_depth(dev_) < 0) throw std::runtime_error(name_ + ": cannot start depth");
    depth_running_ = true;
    if (options_.colour) {
      freenect_set_video_callback(dev_, &FreenectSession::videoCallback);
      if (freenect_set_video_mode(
              dev_, freenect_find_video_mode(FREENECT_RESOLUTION_MEDIUM, FREENECT_VIDEO_RGB)) < 0) {
        throw std::runtime_error(name_ + ": cannot set RGB video mode");
      }
      if (freenect_start_video(dev_) < 0) throw std::runtime_error(name_ + ": cannot start RGB");
      video_running_ = true;
    }
  }

  void close() {
    if (dev_ != nullptr) {
      if (depth_running_) freenect_stop_depth(dev_);
      if (video_running_) freenect_stop_video(dev_);
      freenect_close_device(dev_);
      dev_ = nullptr;
    }
    if (ctx_ != nullptr) freenect_shutdown(ctx_);
    ctx_ = nullptr;
  }

  std::optional<std::string> pumpImpl(std::chrono::milliseconds budget,
                                      const DeviceImageSink& sink) {
    timeval timeout{};
    timeout.tv_sec = static_cast<time_t>(budget.count() / 1000);
    timeout.tv_usec = static_cast<suseconds_t>((budget.count() % 1000) * 1000);
    const int rc = freenect_process_events_timeout(ctx_, &timeout);
    // Convert outside the USB event loop: callbacks only copy, so isochronous transfers (and
    // fakenect's pacing, which does not count callback time) are not held up.
    for (auto& image : received_) {
      if (image.kind == DeviceImage::Kind::kDepth) {
        image.image = to_mm_.convert(image.image);
      } else {
        cv::cvtColor(image.image, image.image, cv::COLOR_RGB2BGR);
      }
      sink(std::move(image));
    }
    received_.clear();
    if (rc < 0 && rc != kLibusbErrorInterrupted) {
      return "freenect_process_events returned " + std::to_string(rc) + " (" + name_ +
             " unplugged, or the end of a fakenect dump)";
    }
    return std::nullopt;
  }

  static void depthCallback(freenect_device* dev, void* data, std::uint32_t timestamp) {
    static_cast<FreenectSession*>(freenect_get_user(dev))
        ->onImage(DeviceImage::Kind::kDepth, data, timestamp);
  }
  static void videoCallback(freenect_device* dev, void* data, std::uint32_t timestamp) {
    static_cast<FreenectSession*>(freenect_get_user(dev))
        ->onImage(DeviceImage::Kind::kColour, data, timestamp);
  }

  /// Runs inside freenect_process_events: stamp and copy only.
  void onImage(DeviceImage::Kind kind, void* data, std::uint32_t timestamp) {
    if (data == nullptr) return;
    DeviceImage image;
    image.kind = kind;
    image.host_arrival_ns = hostNowNs();
    image.device_ticks = timestamp;
    const int type = kind == DeviceImage::Kind::kDepth ? CV_16UC1 : CV_8UC3;
    image.image = cv::Mat(kHeight, kWidth, type, data).clone();
    received_.push_back(std::move(image));
  }

  freenect_context* ctx_;
  freenect_device* dev_ = nullptr;
  FreenectOptions options_;
  KinectRawToMm to_mm_;
  std::string name_;
  bool depth_running_ = false;
  bool video_running_ = false;
  std::vector<DeviceImage> received_;  // filled by the callbacks during one pump
};

class FreenectConnector final : public DeviceConnector {
 public:
  explicit FreenectConnector(FreenectOptions options) : options_(std::move(options)) {}

  std::string describe() const override { return "freenect:" + options_.device.toString(); }
  DeviceClockParams clockParams() const override { return options_.clock; }
  std::span<const UsbId> usbIds() const override { return kKinectUsbIds; }

  std::unique_ptr<DeviceSession> open(std::string& why_not) override {
    freenect_context* ctx = nullptr;
    if (freenect_init(&ctx, nullptr) < 0 || ctx == nullptr) {
      why_not = "freenect_init failed (libusb unavailable?)";
      return nullptr;
    }
    freenect_set_log_level(ctx, FREENECT_LOG_ERROR);
    freenect_select_subdevices(ctx, FREENECT_DEVICE_CAMERA);
    const int count = freenect_num_devices(ctx);
    if (count <= 0) {
      freenect_shutdown(ctx);
      why_not = "no Kinect v1 connected";
      return nullptr;
    }
    if (options_.device.serial.empty() && options_.device.index >= count) {
      freenect_shutdown(ctx);
      why_not = "Kinect #" + std::to_string(options_.device.index) + " requested but " +
                std::to_string(count) + " connected";
      return nullptr;
    }
    try {
      return std::make_unique<FreenectSession>(ctx, options_);  // owns ctx from here
    } catch (const std::exception& e) {
      why_not = e.what();
      return nullptr;
    }
  }

 private:
  FreenectOptions options_;
};

}  // namespace

FreenectDeviceSelector FreenectDeviceSelector::parse(const std::string& text) {
  FreenectDeviceSelector selector;
  if (text.empty()) return selector;
  const bool digits = text.size() <= 3 && std::all_of(text.begin(), text.end(),
                                                      [](char c) { return c >= '0' && c <= '9'; });
  if (digits) {
    selector.index = std::stoi(text);
  } else {
    selector.serial = text;
  }
  return selector;
}

std::string FreenectDeviceSelector::toString() const {
  return serial.empty() ? std::to_string(index) : serial;
}

std::unique_ptr<DeviceConnector> makeFreenectConnector(FreenectOptions options) {
  return std::make_unique<FreenectConnector>(std::move(options));
}

FreenectSource::FreenectSource(FreenectOptions options)
    : LiveSource(makeFreenectConnector(options), options.live) {}

}  // namespace shapesense
