#include "shapesense/driver/live_sources_pairing.h"

#include <cstdlib>

namespace shapesense {

std::vector<PairedImages> DepthColourPairer::addColour(StampedImage colour) {
  newest_ns_ = any_ ? std::max(newest_ns_, colour.capture_ns) : colour.capture_ns;
  any_ = true;
  colour_.push_back(std::move(colour));
  while (colour_.size() > params_.colour_history) colour_.pop_front();
  return release(false);
}

std::vector<PairedImages> DepthColourPairer::addDepth(StampedImage depth) {
  newest_ns_ = any_ ? std::max(newest_ns_, depth.capture_ns) : depth.capture_ns;
  any_ = true;
  pending_.push_back(std::move(depth));
  return release(false);
}

std::vector<PairedImages> DepthColourPairer::flush() { return release(true); }

void DepthColourPairer::reset() {
  pending_.clear();
  colour_.clear();
  newest_ns_ = 0;
  any_ = false;
}

PairedImages DepthColourPairer::pair(StampedImage depth) const {
  PairedImages out;
  TimestampNs best_gap = params_.max_offset.count();
  for (const auto& colour : colour_) {
    const TimestampNs gap = std::llabs(colour.capture_ns - depth.capture_ns);
    if (gap <= best_gap) {
      best_gap = gap;
      out.colour = colour.image;
    }
  }
  out.depth = std::move(depth);
  return out;
}

std::vector<PairedImages> DepthColourPairer::release(bool all) {
  std::vector<PairedImages> out;
  while (!pending_.empty()) {
    const TimestampNs t = pending_.front().capture_ns;
    bool later_colour = false;
    for (const auto& colour : colour_) later_colour |= colour.capture_ns >= t;
    const bool too_old = newest_ns_ - t > params_.max_offset.count();
    if (!(all || later_colour || too_old || pending_.size() > params_.max_pending_depth)) break;
    out.push_back(pair(std::move(pending_.front())));
    pending_.pop_front();
  }
  return out;
}

}  // namespace shapesense
