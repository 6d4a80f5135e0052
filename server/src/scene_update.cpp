#include "shapesense/server/scene_update.h"

#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shapesense/server/proto_convert.h"
#include "shapesense/server/service_context.h"

namespace shapesense {
namespace {

constexpr int kMinPreviewWidth = 16;
constexpr int kMaxPreviewWidth = 1280;
/// Depth range the preview's colour map spans (Kinect-class sensors), millimetres.
constexpr double kPreviewNearMm = 400.0;
constexpr double kPreviewFarMm = 4500.0;

std::uint32_t packedRgb(const DetectedPlane& plane) {
  if (!plane.mean_bgr) return 0x808080;
  const cv::Vec3b bgr = *plane.mean_bgr;
  return (static_cast<std::uint32_t>(bgr[2]) << 16) | (static_cast<std::uint32_t>(bgr[1]) << 8) |
         bgr[0];
}

void toScenePlane(const DetectedPlane& plane, v1::ScenePlane* out) {
  out->set_id(plane.id);
  toProto(plane.normal, out->mutable_normal());
  out->set_d(plane.d);
  // An accumulated plane's outline is that of its last sighting, while its equation averages
  // every sighting: the outline is cast onto the reported plane so the two agree.
  for (const auto& vertex : plane.polygon) {
    const Eigen::Vector3d on_plane = vertex - (plane.normal.dot(vertex) + plane.d) * plane.normal;
    for (int axis = 0; axis < 3; ++axis) out->add_polygon_xyz(static_cast<float>(on_plane[axis]));
  }
  for (const auto& triangle : plane.triangles) {
    for (int index : triangle) out->add_triangles(static_cast<std::uint32_t>(index));
  }
  out->set_rgb(packedRgb(plane));
  toProto(plane.box, out->mutable_box());
}

void toSceneObject(const TrackedThing& thing, v1::SceneObject* out) {
  out->set_id(thing.id);
  out->set_kind(thing.kind == ThingKind::kBowl ? v1::SceneObject::BOWL : v1::SceneObject::OBJECT);
  for (const auto& corner : thing.corners) toProto(corner, out->add_corners());
  toProto(thing.image_box, out->mutable_box());
  out->set_score(thing.score);
  out->set_frames_seen(thing.frames_seen);
  out->set_frames_missed(thing.frames_missed);
  const auto& c = thing.corners;
  out->set_width_m((c[1] - c[0]).norm());
  out->set_height_m((c[3] - c[0]).norm());
  out->set_depth_m((c[4] - c[0]).norm());
}

Eigen::Vector3d fromProto(const v1::Point3& p) { return {p.x(), p.y(), p.z()}; }

bool boxMoved(const v1::PixelBox& a, const v1::PixelBox& b, int tolerance_px) {
  return std::abs(a.x() - b.x()) > tolerance_px || std::abs(a.y() - b.y()) > tolerance_px ||
         std::abs(a.x() + a.width() - b.x() - b.width()) > tolerance_px ||
         std::abs(a.y() + a.height() - b.y() - b.height()) > tolerance_px;
}

bool planeChanged(const v1::ScenePlane& sent, const v1::ScenePlane& now) {
  const double cos_angle = fromProto(sent.normal()).dot(fromProto(now.normal()));
  return cos_angle < std::cos(0.5 * M_PI / 180.0) || std::abs(sent.d() - now.d()) > 0.005 ||
         boxMoved(sent.box(), now.box(), 4) || sent.rgb() != now.rgb() ||
         sent.polygon_xyz_size() != now.polygon_xyz_size();
}

bool objectChanged(const v1::SceneObject& sent, const v1::SceneObject& now) {
  if (sent.corners_size() != now.corners_size() || boxMoved(sent.box(), now.box(), 2) ||
      (sent.frames_missed() == 0) != (now.frames_missed() == 0) ||
      std::abs(sent.score() - now.score()) > 1.0) {
    return true;
  }
  for (int i = 0; i < now.corners_size(); ++i) {
    if ((fromProto(sent.corners(i)) - fromProto(now.corners(i))).norm() > 0.005) return true;
  }
  return false;
}

/// Keeps the entries of `items` that `changed` says differ from what `sent` holds (or that it
/// lacks), records them as sent, and lists the ids `sent` held that `items` no longer has.
template <class Item, class Changed>
void keepChanged(google::protobuf::RepeatedPtrField<Item>& items,
                 std::map<std::uint32_t, Item>& sent, bool full, Changed changed,
                 google::protobuf::RepeatedField<std::uint32_t>& removed) {
  std::map<std::uint32_t, Item> now;
  google::protobuf::RepeatedPtrField<Item> kept;
  for (auto& item : items) {
    const auto previous = sent.find(item.id());
    if (full || previous == sent.end() || changed(previous->second, item)) {
      now[item.id()] = item;
      *kept.Add() = std::move(item);
    } else {
      now[item.id()] = previous->second;  // compare with what the client has, not the newest
    }
  }
  if (!full) {
    for (const auto& [id, item] : sent) {
      if (!now.count(id)) removed.Add(id);
    }
  }
  sent = std::move(now);
  items = std::move(kept);
}

/// OpenCV's JET colour map as a lookup table, made once: applyColorMap builds it on every call,
/// which costs more than the whole preview.
const cv::Mat& jetTable() {
  static const cv::Mat table = [] {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<std::uint8_t>(i) = static_cast<std::uint8_t>(i);
    cv::Mat coloured;
    cv::applyColorMap(ramp, coloured, cv::COLORMAP_JET);
    return coloured;
  }();
  return table;
}

/// The frame's colour, or its depth rendered for display, scaled to `size` before any per-pixel
/// work so a preview costs the small image, not the frame.
cv::Mat previewImage(const Frame& frame, v1::PreviewRequest::Kind kind, cv::Size size) {
  const auto interpolation = [&](const cv::Mat& source) {
    return size.width < source.cols ? cv::INTER_AREA : cv::INTER_LINEAR;
  };
  cv::Mat small;
  if (kind == v1::PreviewRequest::COLOUR && !frame.rgb.empty()) {
    cv::resize(frame.rgb, small, size, 0, 0, interpolation(frame.rgb));
    return small;
  }
  // Nearest neighbour: averaging would mix "no reading" (0) into the depths around holes.
  cv::resize(frame.depth, small, size, 0, 0, cv::INTER_NEAREST);
  const double scale = 255.0 / (kPreviewFarMm - kPreviewNearMm);
  cv::Mat near_bright;  // near = 255, far = 0
  small.convertTo(near_bright, CV_8U, -scale, 255.0 + kPreviewNearMm * scale);
  const cv::Mat holes = small == 0;
  if (kind == v1::PreviewRequest::COLOUR) {  // no colour: grey depth
    near_bright.setTo(0, holes);
    return near_bright;
  }
  // JET runs blue to red, so near depths (high values) come out red.
  cv::Mat grey3, coloured;
  cv::cvtColor(near_bright, grey3, cv::COLOR_GRAY2BGR);
  cv::LUT(grey3, jetTable(), coloured);
  coloured.setTo(cv::Scalar::all(0), holes);
  return coloured;
}

}  // namespace

grpc::Status parsePreview(const v1::PreviewRequest& request, PreviewOptions& options) {
  if (!v1::PreviewRequest::Kind_IsValid(request.kind())) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "preview.kind must be NONE, COLOUR or DEPTH"};
  }
  options.kind = request.kind();
  const int width = static_cast<int>(std::min<std::uint32_t>(request.width(), 1u << 20));
  if (request.width() != 0 && (width < kMinPreviewWidth || width > kMaxPreviewWidth)) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            fmt::format("preview.width must be {}..{} pixels (0 = 320)", kMinPreviewWidth,
                        kMaxPreviewWidth)};
  }
  options.width = width == 0 ? 320 : width;
  if (request.quality() > 100) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "preview.quality must be 1..100 (0 = 70)"};
  }
  options.quality = request.quality() == 0 ? 70 : static_cast<int>(request.quality());
  if (!std::isfinite(request.rate_hz()) || request.rate_hz() < 0 || request.rate_hz() > 1000) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "preview.rate_hz must be 0..1000 (0 = with every update)"};
  }
  options.rate_hz = request.rate_hz();
  return grpc::Status::OK;
}

grpc::Status lookupSceneFrame(const FrameCache& cache, std::int64_t at_ns, CachedFrame& out) {
  if (at_ns != 0) return lookupProcessedFrame(cache, at_ns, out);
  if (auto status = lookupFrame(cache, 0, out); !status.ok()) return status;
  if (out.results) return grpc::Status::OK;
  const auto frames = cache.list();
  for (auto it = frames.rbegin(); it != frames.rend(); ++it) {
    if (it->results) {
      out = *it;
      return grpc::Status::OK;
    }
  }
  return {grpc::StatusCode::UNAVAILABLE,
          "no cached frame has been processed yet; retry in a moment"};
}

grpc::Status fillScene(const CachedFrame& entry, const std::string& session_id,
                       v1::SceneUpdate& update) {
  const FrameResults& results = *entry.results;
  if (!results.planes && !results.things && !results.taught_objects) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "the scene needs the plane stage, the bowl or object-box stages or the taught-object "
            "stage; start shapesensed with --planes hough"};
  }
  update.Clear();
  update.set_session_id(session_id);
  toProto(entry, update.mutable_info());
  toProto(entry.frame->intrinsics, update.mutable_intrinsics());
  update.set_full(true);
  if (results.planes) {
    for (const auto& plane : results.planes->accumulated) toScenePlane(plane, update.add_planes());
  }
  if (results.things) {
    for (const auto& thing : *results.things) toSceneObject(thing, update.add_objects());
  }
  if (results.taught_objects) {
    for (const auto& detection : *results.taught_objects)
      toProto(detection, entry.frame->intrinsics, update.add_taught_objects());
  }
  for (const auto& [stage, ms] : results.timings_ms) {
    auto* timing = update.add_timings();
    timing->set_stage(stage);
    timing->set_ms(ms);
  }
  return grpc::Status::OK;
}

void addPreview(const Frame& frame, const PreviewOptions& options, v1::SceneUpdate& update) {
  if (options.kind == v1::PreviewRequest::NONE || frame.depth.empty()) return;
  const int height =
      std::max(1, static_cast<int>(std::lround(static_cast<double>(options.width) *
                                               frame.depth.rows / std::max(1, frame.depth.cols))));
  const cv::Mat small = previewImage(frame, options.kind, cv::Size(options.width, height));
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", small, jpeg, {cv::IMWRITE_JPEG_QUALITY, options.quality});
  update.set_preview_jpeg(jpeg.data(), jpeg.size());
  update.set_preview_width(static_cast<std::uint32_t>(small.cols));
  update.set_preview_height(static_cast<std::uint32_t>(small.rows));
}

void SceneDelta::reduce(v1::SceneUpdate& update, bool full) {
  full = full || !has_sent_;
  has_sent_ = true;
  update.set_full(full);
  keepChanged(*update.mutable_planes(), planes_, full, planeChanged,
              *update.mutable_removed_plane_ids());
  keepChanged(*update.mutable_objects(), objects_, full, objectChanged,
              *update.mutable_removed_object_ids());
}

namespace {
SceneSchedule::Clock::duration periodOf(double rate_hz) {
  if (rate_hz <= 0) return SceneSchedule::Clock::duration::zero();
  return std::chrono::duration_cast<SceneSchedule::Clock::duration>(
      std::chrono::duration<double>(1.0 / rate_hz));
}
}  // namespace

SceneSchedule::SceneSchedule(double max_rate_hz, double preview_rate_hz, double full_every_s)
    : update_period_(periodOf(max_rate_hz)),
      preview_period_(periodOf(preview_rate_hz)),
      full_period_(std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(full_every_s))) {}

SceneSchedule::Clock::duration SceneSchedule::untilNextUpdate(Clock::time_point now) const {
  if (!last_update_) return Clock::duration::zero();
  const auto due = *last_update_ + update_period_;
  return due > now ? due - now : Clock::duration::zero();
}

SceneSchedule::Sent SceneSchedule::send(Clock::time_point now) {
  Sent sent{};
  last_update_ = now;
  if (!last_preview_ || now - *last_preview_ >= preview_period_) {
    sent.preview = true;
    last_preview_ = now;
  }
  if (!last_full_ || now - *last_full_ >= full_period_) {
    sent.full = true;
    last_full_ = now;
  }
  return sent;
}

}  // namespace shapesense
