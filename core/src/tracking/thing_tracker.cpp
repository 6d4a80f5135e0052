#include "shapesense/core/tracking/thing_tracker.h"

#include <algorithm>
#include <limits>

namespace shapesense {
namespace {

/// Front top-left to back bottom-right: the box's space diagonal.
double diagonalOf(const BoxCorners& corners) { return (corners[0] - corners[6]).norm(); }

}  // namespace

ThingTracker::ThingTracker(ThingTrackerParams params) : params_(params) {}

void ThingTracker::reset() {
  tracks_.clear();
  next_id_ = 1;
}

int ThingTracker::nearestTrack(const ThingObservation& observation,
                               const std::vector<bool>& taken) const {
  const Eigen::Vector3d centre = boxCentre(observation.corners);
  const double observed_diagonal = diagonalOf(observation.corners);
  int best = -1;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < tracks_.size(); ++i) {
    const TrackedThing& thing = tracks_[i].thing;
    if (taken[i] || thing.kind != observation.kind) continue;
    const double gate = std::max(
        params_.min_match_distance_m,
        params_.match_diagonal_fraction * std::max(observed_diagonal, diagonalOf(thing.corners)));
    const double distance = (boxCentre(thing.corners) - centre).norm();
    if (distance <= gate && distance < best_distance) {
      best = static_cast<int>(i);
      best_distance = distance;
    }
  }
  return best;
}

void ThingTracker::absorb(Track& track, const ThingObservation& observation) {
  TrackedThing& thing = track.thing;
  for (std::size_t c = 0; c < thing.corners.size(); ++c) {
    thing.corners[c] += params_.smoothing * (observation.corners[c] - thing.corners[c]);
  }
  thing.image_box = observation.image_box;
  thing.score = observation.score;
  ++thing.frames_seen;
  thing.frames_missed = 0;
  confirmIfDue(track);
}

void ThingTracker::confirmIfDue(Track& track) {
  // Ids are given at confirmation, so the ids a client sees count things, not false starts.
  if (track.confirmed || static_cast<int>(track.thing.frames_seen) < params_.confirm_frames) {
    return;
  }
  track.confirmed = true;
  track.thing.id = next_id_++;
}

void ThingTracker::ageUnmatched(const std::vector<bool>& matched) {
  std::vector<Track> kept;
  kept.reserve(tracks_.size());
  for (std::size_t i = 0; i < tracks_.size(); ++i) {
    Track& track = tracks_[i];
    if (!matched[i]) {
      // A tentative track must be seen in consecutive frames; a confirmed one is kept a while.
      if (!track.confirmed) continue;
      if (static_cast<int>(++track.thing.frames_missed) > params_.keep_frames) continue;
    }
    kept.push_back(std::move(track));
  }
  tracks_ = std::move(kept);
}

std::vector<TrackedThing> ThingTracker::update(const std::vector<ThingObservation>& observations) {
  // Higher-scoring observations choose first, so a strong bowl keeps its track over a weak
  // duplicate next to it.
  std::vector<const ThingObservation*> order;
  for (const auto& observation : observations) order.push_back(&observation);
  std::stable_sort(order.begin(), order.end(),
                   [](const auto* a, const auto* b) { return a->score > b->score; });

  const std::size_t existing = tracks_.size();
  std::vector<bool> matched(existing, false);
  std::vector<Track> started;
  for (const ThingObservation* observation : order) {
    const int index = nearestTrack(*observation, matched);
    if (index >= 0) {
      matched[static_cast<std::size_t>(index)] = true;
      absorb(tracks_[static_cast<std::size_t>(index)], *observation);
      continue;
    }
    Track track;
    track.thing.kind = observation->kind;
    track.thing.corners = observation->corners;
    track.thing.image_box = observation->image_box;
    track.thing.score = observation->score;
    track.thing.frames_seen = 1;
    confirmIfDue(track);
    started.push_back(std::move(track));
  }
  ageUnmatched(matched);
  for (auto& track : started) tracks_.push_back(std::move(track));

  std::vector<TrackedThing> confirmed;
  for (const auto& track : tracks_) {
    if (track.confirmed) confirmed.push_back(track.thing);
  }
  std::sort(confirmed.begin(), confirmed.end(),
            [](const auto& a, const auto& b) { return a.id < b.id; });
  return confirmed;
}

}  // namespace shapesense
