#pragma once
// Taught objects (object_model.h) over a frame sequence: each object found in the previous
// frame is followed from its pose there (followObject: ICP and the depth check, no features),
// and only the objects not followed are searched for (findObject), a few per frame, in turn. A
// frame where every object is followed costs the frame's normals, the surface around the
// objects and one ICP per object; a frame with a search also costs the whole frame's surface
// and features and the search. Searching in turn bounds that cost when many taught objects are out
// of view: an object that comes into view is found within (objects not followed) /
// searches_per_frame frames.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/core/recognition/object_model.h"

namespace shapesense {

/// Where the taught objects come from, asked once per frame (the daemon's model folder, to
/// which objects are taught while it runs).
using TaughtModelSource = std::function<std::vector<std::shared_ptr<const ObjectModel>>()>;

struct TaughtObjectTrackerParams {
  /// The parameters the models were taught with: frames are described alike. Default: the
  /// defaults, which teachObjectModel uses by default.
  ObjectModelParams describe;
  /// Search and check parameters for both following and searching. Default: defaults.
  ObjectMatchParams match;
  /// Objects not followed from the previous frame that are searched for in one frame, those
  /// searched for longest ago first; 0 (or less) = every one, every frame. Default 1: with five
  /// objects out of view a frame costs one search, and each is looked for every fifth frame.
  int searches_per_frame = 1;
};

class TaughtObjectTracker {
 public:
  explicit TaughtObjectTracker(TaughtObjectTrackerParams params = {});

  /// The objects of `models` found in the next frame (`depth_mm`: CV_16UC1 millimetres), in
  /// the order of `models`. Objects are known by name: a model replaced under its name
  /// (another object) is searched for afresh, and objects no longer in `models` are forgotten.
  /// `planes` (optional): the frame's plane detection, where one was made (SceneSurface).
  std::vector<ObjectDetection> update(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                      const std::vector<std::shared_ptr<const ObjectModel>>& models,
                                      const PlaneDetection* planes = nullptr);

  /// Searches (findObject) made by the last update(); for tests and benchmarks.
  int lastSearches() const { return last_searches_; }
  /// Share of the image the last update() described (1 with a search; the followed objects'
  /// regions without); for tests and benchmarks.
  double lastDescribedShare() const { return last_described_share_; }

 private:
  struct TrackedObject {
    std::shared_ptr<const ObjectModel> model;
    std::optional<Eigen::Isometry3f> pose;  ///< where it was last found (the previous frame)
    std::uint64_t last_searched = 0;        ///< the update() it was last searched in; 0 = never
  };

  /// The names of the objects to search for this frame: those not followed, longest unsearched
  /// first, at most searches_per_frame.
  std::vector<std::string> dueForSearch() const;
  /// Where the objects at `poses` (by name) may be now, as a mask of an `image`-sized frame
  /// (followObjectRegion); empty when none of them is in view.
  cv::Mat followedRegions(const std::map<std::string, Eigen::Isometry3f>& poses,
                          const CameraIntrinsics& intrinsics, cv::Size image) const;

  TaughtObjectTrackerParams params_;
  std::map<std::string, TrackedObject> objects_;
  std::uint64_t frame_ = 0;
  int last_searches_ = 0;
  double last_described_share_ = 0.0;
};

}  // namespace shapesense
