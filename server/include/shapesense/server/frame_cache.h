#pragma once
// A bounded ring of the newest frames and the detector results computed from each.
//
// One writer (the pipeline) inserts frames and later publishes their results; any number of
// readers (gRPC handlers) look frames up by capture time. Everyone takes one plain mutex only to
// search the ring and copy shared pointers. (A shared_mutex would let a steady stream of
// overlapping readers starve the writer: glibc's prefers readers.) Entries are immutable once
// published: a reader keeps a consistent view for as long as it holds one.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "shapesense/core/geometry/frame.h"
#include "shapesense/core/pipeline/frame_results.h"

namespace shapesense {

/// A cached frame with its results; `results` is null until the detectors have run on it.
struct CachedFrame {
  std::shared_ptr<const Frame> frame;
  std::shared_ptr<const FrameResults> results;
};

/// The span of capture times the cache holds.
struct CachedRange {
  std::size_t frames = 0;
  std::size_t capacity = 0;
  TimestampNs oldest_ns = 0;
  TimestampNs newest_ns = 0;
};

/// Why a lookup found no frame.
struct LookupError {
  enum class Kind {
    kEmpty,        ///< nothing cached yet
    kBeforeCache,  ///< T is older than the oldest cached frame
  };
  Kind kind;
  std::string message;  ///< names T and the cached range, for people
};

class FrameCache {
 public:
  /// 90 frames hold 3 s at 30 fps.
  static constexpr std::size_t kDefaultCapacity = 90;

  explicit FrameCache(std::size_t capacity = kDefaultCapacity);

  /// Adds the newest frame, evicting the oldest when full. Capture times must increase: a
  /// frame stamped at or before the newest cached one is rejected (returns false), so "the
  /// frame at T" is always one frame and what is cached is never reordered or replaced.
  bool insert(std::shared_ptr<const Frame> frame);

  /// Attaches detector results to the cached frame with this sequence number. Returns false
  /// when that frame has already been evicted.
  bool publishResults(std::uint64_t sequence, std::shared_ptr<const FrameResults> results);

  /// The latest frame captured at or before `t` (t = 0 or newer than the newest: the newest).
  std::variant<CachedFrame, LookupError> at(TimestampNs t) const;

  /// The frame with this sequence number, if still cached.
  std::optional<CachedFrame> bySequence(std::uint64_t sequence) const;

  /// Cached frames captured within [from, to] (0 = unbounded), oldest first.
  std::vector<CachedFrame> list(TimestampNs from = 0, TimestampNs to = 0) const;

  CachedRange range() const;
  std::size_t capacity() const { return capacity_; }

 private:
  std::size_t capacity_;
  mutable std::mutex mutex_;
  std::deque<CachedFrame> entries_;  // oldest first; capture times strictly increasing
};

}  // namespace shapesense
