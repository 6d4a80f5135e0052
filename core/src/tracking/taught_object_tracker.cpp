#include "shapesense/core/tracking/taught_object_tracker.h"

#include <algorithm>
#include <set>

namespace shapesense {

TaughtObjectTracker::TaughtObjectTracker(TaughtObjectTrackerParams params) : params_(params) {}

std::vector<ObjectDetection> TaughtObjectTracker::update(
    const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
    const std::vector<std::shared_ptr<const ObjectModel>>& models, const PlaneDetection* planes) {
  ++frame_;
  last_searches_ = 0;
  std::set<std::string> present;
  for (const auto& model : models) {
    if (!model) continue;
    present.insert(model->name);
    TrackedObject& object = objects_[model->name];
    if (object.model != model) {
      object = TrackedObject{};
      object.model = model;
    }
  }
  std::erase_if(objects_, [&](const auto& entry) { return !present.contains(entry.first); });

  // Each object's pose in the previous frame; from here on `pose` is this frame's.
  std::map<std::string, Eigen::Isometry3f> previous;
  for (auto& [name, object] : objects_) {
    if (object.pose) previous.emplace(name, *object.pose);
    object.pose.reset();
  }

  // The whole frame's surface when an object that was not found in the previous frame is due
  // for a search; otherwise the surface around the followed objects only, and the whole one
  // later if following loses one.
  std::map<std::string, ObjectDetection> found;
  std::optional<SceneSurface> surface;
  const bool whole_frame = objects_.size() > previous.size();  // one was not found before
  last_described_share_ = whole_frame ? 1.0 : 0.0;
  if (whole_frame) {
    surface.emplace(depth_mm, intrinsics, params_.describe, cv::Mat(), planes);
  } else if (const cv::Mat regions = followedRegions(previous, intrinsics, depth_mm.size());
             !regions.empty()) {
    surface.emplace(depth_mm, intrinsics, params_.describe, regions);
    last_described_share_ =
        static_cast<double>(cv::countNonZero(regions)) / static_cast<double>(regions.total());
  }
  if (surface) {
    for (const auto& [name, pose] : previous) {
      TrackedObject& object = objects_.at(name);
      auto detection = followObject(*object.model, *surface, pose, params_.match);
      if (!detection) continue;
      object.pose = detection->camera_from_model;
      found.emplace(name, std::move(*detection));
    }
  }
  const std::vector<std::string> due = dueForSearch();
  if (!due.empty() && !whole_frame) {
    surface.emplace(depth_mm, intrinsics, params_.describe, cv::Mat(), planes);
    last_described_share_ = 1.0;
  }
  for (const std::string& name : due) {
    TrackedObject& object = objects_.at(name);
    object.last_searched = frame_;
    ++last_searches_;
    auto detection = findObject(*object.model, *surface, params_.match);
    if (!detection) continue;
    object.pose = detection->camera_from_model;
    found.emplace(name, std::move(*detection));
  }

  std::vector<ObjectDetection> out;
  for (const auto& model : models) {
    if (!model) continue;
    const auto it = found.find(model->name);
    if (it == found.end()) continue;
    out.push_back(it->second);
    found.erase(it);  // a name listed twice is reported once
  }
  return out;
}

cv::Mat TaughtObjectTracker::followedRegions(const std::map<std::string, Eigen::Isometry3f>& poses,
                                             const CameraIntrinsics& intrinsics,
                                             cv::Size image) const {
  cv::Mat mask;
  for (const auto& [name, pose] : poses) {
    // Clipped to the depth image itself, in case the intrinsics name another size.
    const cv::Rect region =
        followObjectRegion(*objects_.at(name).model, pose, intrinsics, params_.match) &
        cv::Rect(cv::Point(0, 0), image);
    if (region.empty()) continue;
    if (mask.empty()) mask = cv::Mat::zeros(image, CV_8UC1);
    mask(region).setTo(255);
  }
  return mask;
}

std::vector<std::string> TaughtObjectTracker::dueForSearch() const {
  std::vector<std::pair<std::uint64_t, std::string>> waiting;
  for (const auto& [name, object] : objects_) {
    if (object.pose) continue;  // found in this frame already
    waiting.emplace_back(object.last_searched, name);
  }
  std::sort(waiting.begin(), waiting.end());
  if (params_.searches_per_frame > 0 &&
      waiting.size() > static_cast<std::size_t>(params_.searches_per_frame))
    waiting.resize(static_cast<std::size_t>(params_.searches_per_frame));
  std::vector<std::string> names;
  for (auto& entry : waiting) names.push_back(std::move(entry.second));
  return names;
}

}  // namespace shapesense
