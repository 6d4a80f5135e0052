#pragma once
// Tracks the boxed things of a frame sequence (objects standing on planes, bowls) so that a
// thing keeps one id while it stays in view and a display does not flicker with the
// detectors' frame-to-frame misses and one-off false hits.
//
// A frame's observations join the nearest unmatched track of the same kind whose box centre is
// within the match gate; the rest start tentative tracks. A tentative track is confirmed after
// `confirm_frames` consecutive sightings and dropped at its first miss, so a detection that
// comes and goes is never shown. A confirmed track survives up to `keep_frames` frames without
// a sighting (showing its last box) and is dropped after that. Matched boxes are smoothed with
// an exponential average so a static thing does not jitter by the sensor's noise.

#include <cstdint>
#include <vector>

#include <opencv2/core/types.hpp>

#include "shapesense/core/boxes/box_estimation.h"

namespace shapesense {

enum class ThingKind { kObject, kBowl };

/// One detection of one frame.
struct ThingObservation {
  ThingKind kind = ThingKind::kObject;
  BoxCorners corners;  ///< camera frame, metres, BoxCorners order
  cv::Rect image_box;  ///< pixels
  double score = 0;    ///< the detector's score (bowls); 0 for objects
};

struct TrackedThing {
  std::uint32_t id = 0;  ///< from 1 in order of confirmation, never reused until reset()
  ThingKind kind = ThingKind::kObject;
  BoxCorners corners;  ///< smoothed over the sightings
  cv::Rect image_box;  ///< of the last sighting
  double score = 0;    ///< of the last sighting
  std::uint32_t frames_seen = 0;
  std::uint32_t frames_missed = 0;  ///< since the last sighting; 0 = seen in this frame
};

struct ThingTrackerParams {
  /// Consecutive sightings before a new thing is reported. Default 3 (0.1 s at 30 fps).
  int confirm_frames = 3;
  /// Frames a confirmed thing is kept without a sighting. Default 10 (a third of a second).
  int keep_frames = 10;
  /// Match gate on the distance between box centres: this fraction of the larger box's
  /// diagonal, at least `min_match_distance_m`. Defaults 0.5 and 0.05 m.
  double match_diagonal_fraction = 0.5;
  double min_match_distance_m = 0.05;
  /// Weight of a new sighting in the smoothed corners (1 = no smoothing). Default 0.5.
  double smoothing = 0.5;
};

class ThingTracker {
 public:
  explicit ThingTracker(ThingTrackerParams params = {});

  /// Adds one frame's observations and returns the confirmed things, ordered by id.
  std::vector<TrackedThing> update(const std::vector<ThingObservation>& observations);

  void reset();

 private:
  struct Track {
    TrackedThing thing;
    bool confirmed = false;
  };

  /// Index of the nearest unmatched track of the observation's kind within the gate, or -1.
  int nearestTrack(const ThingObservation& observation, const std::vector<bool>& taken) const;
  void absorb(Track& track, const ThingObservation& observation);
  void confirmIfDue(Track& track);
  void ageUnmatched(const std::vector<bool>& matched);

  ThingTrackerParams params_;
  std::vector<Track> tracks_;
  std::uint32_t next_id_ = 1;
};

}  // namespace shapesense
