#include "shapesense/server/frame_cache.h"

#include <algorithm>
#include <mutex>
#include <stdexcept>

#include "shapesense/core/geometry/timestamp.h"

namespace shapesense {
namespace {

std::string describeRange(const std::deque<CachedFrame>& entries) {
  return "[" + formatNsAsSeconds(entries.front().frame->timestamp_ns) + ", " +
         formatNsAsSeconds(entries.back().frame->timestamp_ns) + "] s (" +
         std::to_string(entries.size()) + " frames)";
}

}  // namespace

FrameCache::FrameCache(std::size_t capacity) : capacity_(capacity) {
  if (capacity == 0) throw std::invalid_argument("frame cache capacity must be at least 1");
}

bool FrameCache::insert(std::shared_ptr<const Frame> frame) {
  std::lock_guard lock(mutex_);
  if (!entries_.empty() &&
      !stampFollows(entries_.back().frame->timestamp_ns, frame->timestamp_ns)) {
    return false;
  }
  if (entries_.size() == capacity_) entries_.pop_front();
  entries_.push_back(CachedFrame{std::move(frame), nullptr});
  return true;
}

bool FrameCache::publishResults(std::uint64_t sequence,
                                std::shared_ptr<const FrameResults> results) {
  std::lock_guard lock(mutex_);
  // The frame being published is almost always among the newest: search from the back.
  for (auto it = entries_.rbegin(); it != entries_.rend(); ++it) {
    if (it->frame->sequence == sequence) {
      it->results = std::move(results);
      return true;
    }
  }
  return false;
}

std::variant<CachedFrame, LookupError> FrameCache::at(TimestampNs t) const {
  std::lock_guard lock(mutex_);
  if (entries_.empty()) {
    return LookupError{LookupError::Kind::kEmpty,
                       "no frame cached yet: the source has delivered none"};
  }
  if (t == 0 || t >= entries_.back().frame->timestamp_ns) return entries_.back();
  // First entry captured after t; the one before it is the latest at or before t.
  auto after = std::upper_bound(
      entries_.begin(), entries_.end(), t,
      [](TimestampNs time, const CachedFrame& entry) { return time < entry.frame->timestamp_ns; });
  if (after == entries_.begin()) {
    return LookupError{LookupError::Kind::kBeforeCache,
                       "T = " + formatNsAsSeconds(t) + " s is older than the cache, which holds " +
                           describeRange(entries_)};
  }
  return *std::prev(after);
}

std::optional<CachedFrame> FrameCache::bySequence(std::uint64_t sequence) const {
  std::lock_guard lock(mutex_);
  for (auto it = entries_.rbegin(); it != entries_.rend(); ++it) {
    if (it->frame->sequence == sequence) return *it;
  }
  return std::nullopt;
}

std::vector<CachedFrame> FrameCache::list(TimestampNs from, TimestampNs to) const {
  std::lock_guard lock(mutex_);
  std::vector<CachedFrame> out;
  out.reserve(entries_.size());
  for (const auto& entry : entries_) {
    const TimestampNs t = entry.frame->timestamp_ns;
    if ((from == 0 || t >= from) && (to == 0 || t <= to)) out.push_back(entry);
  }
  return out;
}

CachedRange FrameCache::range() const {
  std::lock_guard lock(mutex_);
  CachedRange r;
  r.frames = entries_.size();
  r.capacity = capacity_;
  if (!entries_.empty()) {
    r.oldest_ns = entries_.front().frame->timestamp_ns;
    r.newest_ns = entries_.back().frame->timestamp_ns;
  }
  return r;
}

}  // namespace shapesense
