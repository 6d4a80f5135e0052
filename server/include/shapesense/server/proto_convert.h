#pragma once
// Conversions from the daemon's types to API messages, shared by the handlers.

#include <Eigen/Core>

#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/server/frame_cache.h"
#include "shapesense/server/object_model_store.h"
#include "shapesense/server/pipeline.h"
#include "shapesense/v1/shapesense.pb.h"

namespace shapesense {

void toProto(const CachedFrame& entry, v1::FrameInfo* out);
void toProto(const CameraIntrinsics& intrinsics, v1::Intrinsics* out);
void toProto(const DepthStatistics& stats, v1::DepthStats* out);
void toProto(const CachedRange& range, v1::CacheRange* out);
v1::GetStatusResponse::SourceState toProto(SourceState state);
void toProto(const Eigen::Vector3d& point, v1::Point3* out);
void toProto(const RoiDepthStatistics& stats, v1::RoiDepthStats* out);
void toProto(const cv::Rect& box, v1::PixelBox* out);
void toProto(const SegmentStatistics& segment, v1::Segment* out);
void toProto(const DetectedPlane& plane, bool with_polygon, v1::Plane* out);
void toProto(const DetectedBowl& bowl, v1::Bowl* out);
void toProto(const StoredObjectModel& stored, v1::ObjectModelInfo* out);
/// A taught object's detection; the image box projects its 3D box with `intrinsics`.
void toProto(const ObjectDetection& detection, const CameraIntrinsics& intrinsics,
             v1::ObjectDetection* out);

}  // namespace shapesense
