#include "shapesense/server/proto_convert.h"

#include <array>

namespace shapesense {
namespace {

void quaternionToProto(const Eigen::Quaterniond& q, v1::Quaternion* out) {
  out->set_w(q.w());
  out->set_x(q.x());
  out->set_y(q.y());
  out->set_z(q.z());
}

std::array<Eigen::Vector3d, 8> boxCorners(const OrientedBox& box) {
  // The order v1::OrientedBox.corners documents: a face loop at -z, the same loop at +z.
  constexpr int kSigns[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  std::array<Eigen::Vector3d, 8> corners;
  const Eigen::Vector3d half = 0.5 * box.size.cast<double>();
  const Eigen::Matrix3d axes = box.axes.cast<double>();
  for (int face = 0; face < 2; ++face) {
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d local(kSigns[i][0] * half.x(), kSigns[i][1] * half.y(),
                                  (face == 0 ? -1 : 1) * half.z());
      corners[face * 4 + i] = box.centre.cast<double>() + axes * local;
    }
  }
  return corners;
}

}  // namespace

void toProto(const CachedFrame& entry, v1::FrameInfo* out) {
  const Frame& frame = *entry.frame;
  out->set_timestamp_ns(frame.timestamp_ns);
  out->set_sequence(frame.sequence);
  out->set_width(static_cast<std::uint32_t>(frame.depth.cols));
  out->set_height(static_cast<std::uint32_t>(frame.depth.rows));
  out->set_has_rgb(!frame.rgb.empty());
  out->set_processed(entry.results != nullptr);
}

void toProto(const CameraIntrinsics& k, v1::Intrinsics* out) {
  out->set_fx(k.fx);
  out->set_fy(k.fy);
  out->set_cx(k.cx);
  out->set_cy(k.cy);
  out->set_width(static_cast<std::uint32_t>(k.width));
  out->set_height(static_cast<std::uint32_t>(k.height));
}

void toProto(const DepthStatistics& stats, v1::DepthStats* out) {
  out->set_valid_fraction(stats.valid_fraction);
  out->set_min_m(stats.min_m);
  out->set_median_m(stats.median_m);
  out->set_max_m(stats.max_m);
}

void toProto(const CachedRange& range, v1::CacheRange* out) {
  out->set_frames(static_cast<std::uint32_t>(range.frames));
  out->set_capacity(static_cast<std::uint32_t>(range.capacity));
  out->set_oldest_ns(range.oldest_ns);
  out->set_newest_ns(range.newest_ns);
}

v1::GetStatusResponse::SourceState toProto(SourceState state) {
  switch (state) {
    case SourceState::kStreaming:
      return v1::GetStatusResponse::STREAMING;
    case SourceState::kEnded:
      return v1::GetStatusResponse::ENDED;
    case SourceState::kFailed:
      return v1::GetStatusResponse::FAILED;
    case SourceState::kStopped:
      return v1::GetStatusResponse::STOPPED;
    case SourceState::kReconnecting:
      return v1::GetStatusResponse::RECONNECTING;
  }
  return v1::GetStatusResponse::SOURCE_STATE_UNSPECIFIED;
}

void toProto(const Eigen::Vector3d& point, v1::Point3* out) {
  out->set_x(point.x());
  out->set_y(point.y());
  out->set_z(point.z());
}

void toProto(const RoiDepthStatistics& stats, v1::RoiDepthStats* out) {
  out->set_valid_pixels(static_cast<std::uint32_t>(stats.valid_pixels));
  out->set_used_pixels(static_cast<std::uint32_t>(stats.used_pixels));
  out->set_mean_m(stats.mean_m);
  out->set_std_m(stats.std_m);
  out->set_median_m(stats.median_m);
  out->set_min_m(stats.min_m);
  out->set_max_m(stats.max_m);
  out->set_near_m(stats.near_m);
  out->set_far_m(stats.far_m);
  out->set_moved_back_m(stats.moved_back_m);
  out->set_range_from_origin(stats.range_from_origin);
}

void toProto(const cv::Rect& box, v1::PixelBox* out) {
  out->set_x(box.x);
  out->set_y(box.y);
  out->set_width(box.width);
  out->set_height(box.height);
}

void toProto(const SegmentStatistics& segment, v1::Segment* out) {
  out->set_id(segment.id);
  out->set_pixels(static_cast<std::uint32_t>(segment.pixels));
  toProto(segment.centroid, out->mutable_centroid());
  toProto(segment.mean_normal, out->mutable_normal());
  out->set_plane_rms_m(segment.plane_rms_m);
  toProto(segment.box, out->mutable_box());
}

void toProto(const DetectedPlane& plane, bool with_polygon, v1::Plane* out) {
  out->set_id(plane.id);
  out->set_group(static_cast<std::uint32_t>(plane.group));
  toProto(plane.normal, out->mutable_normal());
  out->set_d(plane.d);
  out->set_inliers(plane.inliers);
  out->set_rms_m(plane.rms_m);
  toProto(plane.box, out->mutable_box());
  if (with_polygon) {
    for (const auto& vertex : plane.polygon) toProto(vertex, out->add_polygon());
    for (const auto& triangle : plane.triangles) {
      for (int index : triangle) out->add_triangles(static_cast<std::uint32_t>(index));
    }
  }
  if (plane.mean_bgr) {
    out->set_has_colour(true);
    out->set_mean_b((*plane.mean_bgr)[0]);
    out->set_mean_g((*plane.mean_bgr)[1]);
    out->set_mean_r((*plane.mean_bgr)[2]);
  }
}

void toProto(const DetectedBowl& bowl, v1::Bowl* out) {
  toProto(bowl.detection.box, out->mutable_box());
  out->set_score(bowl.detection.score);
  out->set_view(bowl.detection.view);
  if (const auto& geometry = bowl.detection.geometry) {
    out->set_rim_diameter_m(geometry->rim_diameter_m);
    out->set_height_m(geometry->height_m);
    out->set_support_plane_id(geometry->support_plane_id);
  }
  if (bowl.box) {
    for (const auto& corner : bowl.box->corners) toProto(corner, out->add_corners());
  }
}

void toProto(const StoredObjectModel& stored, v1::ObjectModelInfo* out) {
  const ObjectModel& model = *stored.model;
  out->set_name(model.name);
  out->set_feature_count(static_cast<std::uint32_t>(model.features.size()));
  out->set_surface_points(static_cast<std::uint32_t>(model.surface.size()));
  toProto(model.box.size.cast<double>().eval(), out->mutable_box_size());
  out->set_taught_at_ns(stored.taught_at_ns);
}

void toProto(const ObjectDetection& detection, const CameraIntrinsics& intrinsics,
             v1::ObjectDetection* out) {
  out->set_name(detection.name);
  toProto(detection.camera_from_model.translation().cast<double>().eval(),
          out->mutable_translation());
  quaternionToProto(
      Eigen::Quaterniond(detection.camera_from_model.linear().cast<double>()).normalized(),
      out->mutable_rotation());
  out->set_score(detection.score);
  out->set_confirmed_points(static_cast<std::uint32_t>(detection.confirmed_points));
  out->set_feature_inliers(static_cast<std::uint32_t>(detection.feature_inliers));
  auto* box = out->mutable_box();
  toProto(detection.box.centre.cast<double>().eval(), box->mutable_centre());
  Eigen::Matrix3d axes = detection.box.axes.cast<double>();
  if (axes.determinant() < 0) axes.col(2) = -axes.col(2);  // a rotation, whatever the core gives
  quaternionToProto(Eigen::Quaterniond(axes).normalized(), box->mutable_orientation());
  toProto(detection.box.size.cast<double>().eval(), box->mutable_size());
  const auto corners = boxCorners(detection.box);
  for (const auto& corner : corners) toProto(corner, box->add_corners());
  toProto(projectedBounds(corners, intrinsics), out->mutable_image_box());
}

}  // namespace shapesense
