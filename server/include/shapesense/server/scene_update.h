#pragma once
// The scene model a thin link carries (GetScene, WatchScene): a processed frame's stable planes
// and tracked things as a v1::SceneUpdate, a small JPEG preview of the same frame, and the
// per-subscriber bookkeeping that turns full scenes into changes since the last one sent.

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include <grpcpp/support/status.h>

#include "shapesense/server/frame_cache.h"
#include "shapesense/v1/shapesense.pb.h"

namespace shapesense {

/// A validated v1::PreviewRequest.
struct PreviewOptions {
  v1::PreviewRequest::Kind kind = v1::PreviewRequest::NONE;
  int width = 320;     ///< pixels; the height keeps the frame's aspect
  int quality = 70;    ///< JPEG quality
  double rate_hz = 0;  ///< previews a second at most; 0 = every update
};

/// INVALID_ARGUMENT (naming the field and its limits) for a width outside 16..1280, a quality
/// above 100, a negative or non-finite rate or an unknown kind.
grpc::Status parsePreview(const v1::PreviewRequest& request, PreviewOptions& options);

/// The newest cached frame the detectors have processed (for T = 0), or the processed frame at
/// T, with the API's status codes (lookupProcessedFrame).
grpc::Status lookupSceneFrame(const FrameCache& cache, std::int64_t at_ns, CachedFrame& out);

/// The whole scene of a processed frame: frame info, intrinsics, the accumulated planes, the
/// tracked things and the stage timings; full = true. FAILED_PRECONDITION when neither the plane
/// stage nor the tracking stage ran on it.
grpc::Status fillScene(const CachedFrame& entry, const std::string& session_id,
                       v1::SceneUpdate& update);

/// Puts a JPEG preview of `frame` into the update (colour, or depth colour-mapped).
void addPreview(const Frame& frame, const PreviewOptions& options, v1::SceneUpdate& update);

/// What one subscriber was sent, so each update carries only what changed. A plane counts as
/// changed when its normal turned by more than 0.5 deg, d moved more than 5 mm, its image box
/// moved more than 4 px, its colour or its polygon's vertex count changed; a thing when a corner
/// moved more than 5 mm, its image box more than 2 px, it was missed or seen again, or its
/// score moved by more than 1.
class SceneDelta {
 public:
  /// Turns `update`, a full scene, into the changes since the previous call (all of it on the
  /// first call or when `full` is true, which also keeps update.full set).
  void reduce(v1::SceneUpdate& update, bool full);

 private:
  std::map<std::uint32_t, v1::ScenePlane> planes_;
  std::map<std::uint32_t, v1::SceneObject> objects_;
  bool has_sent_ = false;
};

/// Rate limits of one WatchScene subscriber: when the next update, preview and full update
/// are due.
class SceneSchedule {
 public:
  using Clock = std::chrono::steady_clock;
  SceneSchedule(double max_rate_hz, double preview_rate_hz, double full_every_s);

  /// How long to wait before the next update may be sent (zero when it may be now).
  Clock::duration untilNextUpdate(Clock::time_point now) const;
  /// Marks an update sent at `now`; says whether it carries a preview and whether it is full.
  struct Sent {
    bool preview;
    bool full;
  };
  Sent send(Clock::time_point now);

 private:
  Clock::duration update_period_;
  Clock::duration preview_period_;
  Clock::duration full_period_;
  std::optional<Clock::time_point> last_update_;
  std::optional<Clock::time_point> last_preview_;
  std::optional<Clock::time_point> last_full_;
};

}  // namespace shapesense
