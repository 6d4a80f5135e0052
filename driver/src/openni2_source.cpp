#include "shapesense/driver/openni2_source.h"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <opencv2/imgproc.hpp>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <OpenNI.h>
#pragma GCC diagnostic pop

namespace shapesense {
namespace {

/// How long a driver's frame thread may still run after VideoStream::stop(). DummyDevice's
/// thread checks its flag once per 33 ms frame and is never joined, so destroying a stream
/// right after stop() lets it write into freed memory.
constexpr std::chrono::milliseconds kStopSettle{120};

std::string lastOpenNIError() {
  const char* text = openni::OpenNI::getExtendedError();
  return text != nullptr && *text != '\0' ? text : "no details";
}

/// OpenNI::initialize() once per process; returns an error message on failure.
std::optional<std::string> initializeOpenNI() {
  static std::once_flag once;
  static std::optional<std::string> failure;
  std::call_once(once, [] {
    if (openni::OpenNI::initialize() != openni::STATUS_OK) {
      failure = "OpenNI::initialize failed: " + lastOpenNIError();
    }
  });
  return failure;
}

/// The supported mode closest to the wanted size and rate among the accepted pixel formats.
std::optional<openni::VideoMode> chooseMode(const openni::SensorInfo& info,
                                            std::initializer_list<openni::PixelFormat> formats,
                                            int width, int height, int fps) {
  std::optional<openni::VideoMode> best;
  double best_cost = 0;
  const auto& modes = info.getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::VideoMode& mode = modes[i];
    int rank = 0;
    bool accepted = false;
    for (auto format : formats) {
      if (mode.getPixelFormat() == format) accepted = true;
      if (!accepted) ++rank;
    }
    if (!accepted) continue;
    const double cost = std::abs(mode.getResolutionX() - width) +
                        std::abs(mode.getResolutionY() - height) +
                        10.0 * std::abs(mode.getFps() - fps) + 0.5 * rank;
    if (!best || cost < best_cost) {
      best = mode;
      best_cost = cost;
    }
  }
  return best;
}

class DisconnectFlag final : public openni::OpenNI::DeviceDisconnectedListener {
 public:
  explicit DisconnectFlag(std::string uri) : uri_(std::move(uri)) {}
  void onDeviceDisconnected(const openni::DeviceInfo* info) override {
    if (info != nullptr && uri_ == info->getUri()) raised_ = true;
  }
  bool raised() const { return raised_.load(); }

 private:
  std::string uri_;
  std::atomic<bool> raised_{false};
};

class OpenNI2Session final : public DeviceSession {
 public:
  /// Opens and starts the device or throws std::runtime_error.
  explicit OpenNI2Session(const OpenNI2Options& options) : options_(options) {
    try {
      start();
    } catch (...) {
      close();
      throw;
    }
  }
  ~OpenNI2Session() override { close(); }

  std::optional<std::string> pump(std::chrono::milliseconds budget,
                                  const DeviceImageSink& sink) override {
    if (disconnect_ && disconnect_->raised()) return name_ + " disconnected";
    openni::VideoStream* streams[2] = {&depth_, &colour_};
    const int count = colour_running_ ? 2 : 1;
    int ready = -1;
    const auto rc =
        openni::OpenNI::waitForAnyStream(streams, count, &ready, static_cast<int>(budget.count()));
    if (rc == openni::STATUS_TIME_OUT) return std::nullopt;
    if (rc != openni::STATUS_OK || ready < 0 || ready >= count) {
      return "waitForAnyStream failed: " + lastOpenNIError();
    }
    openni::VideoFrameRef frame;
    if (streams[ready]->readFrame(&frame) != openni::STATUS_OK || !frame.isValid()) {
      return "readFrame failed: " + lastOpenNIError();
    }
    DeviceImage image;
    image.host_arrival_ns = hostNowNs();
    image.device_ticks = frame.getTimestamp();
    if (ready == 0) {
      image.kind = DeviceImage::Kind::kDepth;
      image.image = depthToMm(frame);
    } else {
      image.kind = DeviceImage::Kind::kColour;
      image.image = colourToBgr(frame);
    }
    if (image.image.empty()) return std::nullopt;  // a format we did not ask for: skip
    sink(std::move(image));
    return std::nullopt;
  }

  CameraIntrinsics intrinsics() const override { return intrinsics_; }
  bool hasColour() const override { return colour_running_; }
  std::string name() const override { return name_; }

 private:
  void start() {
    if (auto failure = initializeOpenNI()) throw std::runtime_error(*failure);
    const char* uri = options_.uri.empty() ? openni::ANY_DEVICE : options_.uri.c_str();
    if (options_.uri.empty()) {
      openni::Array<openni::DeviceInfo> devices;
      openni::OpenNI::enumerateDevices(&devices);
      if (devices.getSize() == 0) throw std::runtime_error("no OpenNI2 device connected");
    }
    if (device_.open(uri) != openni::STATUS_OK) {
      throw std::runtime_error("cannot open OpenNI2 device '" +
                               std::string(options_.uri.empty() ? "(any)" : options_.uri) +
                               "': " + lastOpenNIError());
    }
    const openni::DeviceInfo& info = device_.getDeviceInfo();
    name_ = std::string(info.getVendor()) + " " + info.getName() + " (" + info.getUri() + ")";
    disconnect_ = std::make_unique<DisconnectFlag>(info.getUri());
    openni::OpenNI::addDeviceDisconnectedListener(disconnect_.get());

    startDepth();
    if (options_.colour && device_.hasSensor(openni::SENSOR_COLOR)) startColour();
    if (colour_running_) {
      device_.setDepthColorSyncEnabled(true);  // best effort; pairing is by time anyway
      if (options_.registration &&
          device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR)) {
        registered_ = device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) ==
                      openni::STATUS_OK;
      }
    }
    intrinsics_ = options_.intrinsics ? *options_.intrinsics
                                      : intrinsicsOf(registered_ ? colour_ : depth_, depth_mode_);
    if (registered_) name_ += ", depth registered to colour";
  }

  void startDepth() {
    if (!device_.hasSensor(openni::SENSOR_DEPTH))
      throw std::runtime_error(name_ + " has no depth sensor");
    if (depth_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
      throw std::runtime_error(name_ + ": cannot create depth stream: " + lastOpenNIError());
    }
    const auto mode =
        chooseMode(depth_.getSensorInfo(),
                   {openni::PIXEL_FORMAT_DEPTH_1_MM, openni::PIXEL_FORMAT_DEPTH_100_UM},
                   options_.width, options_.height, options_.fps);
    if (!mode) throw std::runtime_error(name_ + ": no millimetre depth mode");
    depth_.setVideoMode(*mode);  // drivers with one fixed mode refuse even that: ignore
    depth_mode_ = depth_.getVideoMode();
    if (depth_mode_.getResolutionX() <= 0) depth_mode_ = *mode;
    if (depth_.start() != openni::STATUS_OK) {
      throw std::runtime_error(name_ + ": cannot start depth: " + lastOpenNIError());
    }
    depth_running_ = true;
  }

  void startColour() {
    if (colour_.create(device_, openni::SENSOR_COLOR) != openni::STATUS_OK) return;
    const auto mode =
        chooseMode(colour_.getSensorInfo(), {openni::PIXEL_FORMAT_RGB888},
                   depth_mode_.getResolutionX(), depth_mode_.getResolutionY(), options_.fps);
    if (!mode) return;
    colour_.setVideoMode(*mode);
    if (colour_.start() == openni::STATUS_OK) colour_running_ = true;
  }

  static CameraIntrinsics intrinsicsOf(const openni::VideoStream& stream,
                                       const openni::VideoMode& mode) {
    CameraIntrinsics k;
    k.width = mode.getResolutionX();
    k.height = mode.getResolutionY();
    const double hfov = stream.getHorizontalFieldOfView(), vfov = stream.getVerticalFieldOfView();
    if (hfov > 0.1 && hfov < 3.0 && vfov > 0.1 && vfov < 3.0) {
      k.fx = k.width / (2.0 * std::tan(hfov / 2.0));
      k.fy = k.height / (2.0 * std::tan(vfov / 2.0));
    } else {
      k.fx = k.fy = 525.0 * k.width / 640.0;
    }
    k.cx = (k.width - 1) / 2.0;
    k.cy = (k.height - 1) / 2.0;
    return k;
  }

  static cv::Mat depthToMm(const openni::VideoFrameRef& frame) {
    const auto format = frame.getVideoMode().getPixelFormat();
    if (format != openni::PIXEL_FORMAT_DEPTH_1_MM && format != openni::PIXEL_FORMAT_DEPTH_100_UM)
      return {};
    const cv::Mat view(frame.getHeight(), frame.getWidth(), CV_16UC1,
                       const_cast<void*>(frame.getData()),
                       static_cast<std::size_t>(frame.getStrideInBytes()));
    if (format == openni::PIXEL_FORMAT_DEPTH_1_MM) return view.clone();
    cv::Mat mm;
    view.convertTo(mm, CV_16UC1, 0.1);  // 100 um -> mm, rounded
    return mm;
  }

  static cv::Mat colourToBgr(const openni::VideoFrameRef& frame) {
    if (frame.getVideoMode().getPixelFormat() != openni::PIXEL_FORMAT_RGB888) return {};
    const cv::Mat view(frame.getHeight(), frame.getWidth(), CV_8UC3,
                       const_cast<void*>(frame.getData()),
                       static_cast<std::size_t>(frame.getStrideInBytes()));
    cv::Mat bgr;
    cv::cvtColor(view, bgr, cv::COLOR_RGB2BGR);
    return bgr;
  }

  /// Guarded shutdown: stop, let drivers' frame threads settle, then destroy and close.
  void close() {
    const bool any_running = depth_running_ || colour_running_;
    if (colour_running_) colour_.stop();
    if (depth_running_) depth_.stop();
    depth_running_ = colour_running_ = false;
    if (any_running) std::this_thread::sleep_for(kStopSettle);
    colour_.destroy();
    depth_.destroy();
    if (disconnect_) {
      openni::OpenNI::removeDeviceDisconnectedListener(disconnect_.get());
      disconnect_.reset();
    }
    if (device_.isValid()) device_.close();
  }

  OpenNI2Options options_;
  openni::Device device_;
  openni::VideoStream depth_;
  openni::VideoStream colour_;
  openni::VideoMode depth_mode_;
  std::unique_ptr<DisconnectFlag> disconnect_;
  CameraIntrinsics intrinsics_;
  std::string name_ = "OpenNI2 device";
  bool depth_running_ = false;
  bool colour_running_ = false;
  bool registered_ = false;
};

class OpenNI2Connector final : public DeviceConnector {
 public:
  explicit OpenNI2Connector(OpenNI2Options options) : options_(std::move(options)) {}

  std::string describe() const override {
    return options_.uri.empty() ? "openni2" : "openni2:" + options_.uri;
  }
  DeviceClockParams clockParams() const override { return options_.clock; }
  /// The first device, or a USB URI ("1d27/0600@1/5"): a PrimeSense sensor. Dummy and .oni
  /// files are not on USB.
  std::span<const UsbId> usbIds() const override {
    if (options_.uri.empty() || options_.uri.find('@') != std::string::npos)
      return kPrimeSenseUsbIds;
    return {};
  }

  std::unique_ptr<DeviceSession> open(std::string& why_not) override {
    try {
      return std::make_unique<OpenNI2Session>(options_);
    } catch (const std::exception& e) {
      why_not = e.what();
      return nullptr;
    }
  }

 private:
  OpenNI2Options options_;
};

}  // namespace

std::unique_ptr<DeviceConnector> makeOpenNI2Connector(OpenNI2Options options) {
  return std::make_unique<OpenNI2Connector>(std::move(options));
}

OpenNI2Source::OpenNI2Source(OpenNI2Options options)
    : LiveSource(makeOpenNI2Connector(options), options.live) {}

}  // namespace shapesense
