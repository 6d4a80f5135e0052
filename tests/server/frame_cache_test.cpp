// FrameCache: lookup rules at the edges, eviction, ordering, and one writer vs many readers.

#include "shapesense/server/frame_cache.h"

#include <atomic>
#include <limits>
#include <thread>
#include <variant>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "shapesense/core/geometry/timestamp.h"

namespace shapesense {
namespace {

using ::testing::HasSubstr;

constexpr TimestampNs kT0 = 1'700'000'000'000'000'000LL;
constexpr TimestampNs kStep = 33'333'333;

std::shared_ptr<const Frame> frameAt(TimestampNs t, std::uint64_t sequence) {
  auto frame = std::make_shared<Frame>();
  frame->timestamp_ns = t;
  frame->sequence = sequence;
  frame->depth = cv::Mat(2, 2, CV_16UC1, cv::Scalar(static_cast<double>(sequence % 60000)));
  return frame;
}

// Frames 0..n-1 at kT0 + i * kStep.
void fill(FrameCache& cache, int n) {
  for (int i = 0; i < n; ++i) ASSERT_TRUE(cache.insert(frameAt(kT0 + i * kStep, i)));
}

std::uint64_t sequenceAt(const FrameCache& cache, TimestampNs t) {
  auto found = cache.at(t);
  if (auto* error = std::get_if<LookupError>(&found)) {
    ADD_FAILURE() << "lookup of " << t << " failed: " << error->message;
    return ~0ull;
  }
  return std::get<CachedFrame>(found).frame->sequence;
}

TEST(FrameCache, EmptyCacheLookupIsKEmpty) {
  FrameCache cache(4);
  for (TimestampNs t : {TimestampNs{0}, kT0, TimestampNs{1}}) {
    auto found = cache.at(t);
    ASSERT_TRUE(std::holds_alternative<LookupError>(found));
    EXPECT_EQ(std::get<LookupError>(found).kind, LookupError::Kind::kEmpty);
    EXPECT_FALSE(std::get<LookupError>(found).message.empty());
  }
  const CachedRange range = cache.range();
  EXPECT_EQ(range.frames, 0u);
  EXPECT_EQ(range.capacity, 4u);
  EXPECT_EQ(range.oldest_ns, 0);
  EXPECT_EQ(range.newest_ns, 0);
  EXPECT_TRUE(cache.list().empty());
  EXPECT_FALSE(cache.bySequence(0).has_value());
}

TEST(FrameCache, ZeroCapacityIsRejected) {
  EXPECT_THROW(FrameCache cache(0), std::invalid_argument);
}

TEST(FrameCache, ExactlyOnAFrameGivesThatFrame) {
  FrameCache cache(10);
  fill(cache, 5);
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(sequenceAt(cache, kT0 + i * kStep), static_cast<std::uint64_t>(i));
}

TEST(FrameCache, BetweenTwoFramesGivesTheEarlier) {
  FrameCache cache(10);
  fill(cache, 5);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(sequenceAt(cache, kT0 + i * kStep + 1), static_cast<std::uint64_t>(i));
    EXPECT_EQ(sequenceAt(cache, kT0 + i * kStep + kStep / 2), static_cast<std::uint64_t>(i));
    EXPECT_EQ(sequenceAt(cache, kT0 + (i + 1) * kStep - 1), static_cast<std::uint64_t>(i));
  }
}

TEST(FrameCache, OlderThanTheOldestIsBeforeCacheNamingTheRange) {
  FrameCache cache(10);
  fill(cache, 5);
  for (TimestampNs t : {kT0 - 1, kT0 - 10 * kStep, TimestampNs{1}}) {
    auto found = cache.at(t);
    ASSERT_TRUE(std::holds_alternative<LookupError>(found)) << t;
    const LookupError& error = std::get<LookupError>(found);
    EXPECT_EQ(error.kind, LookupError::Kind::kBeforeCache);
    EXPECT_THAT(error.message, HasSubstr(formatNsAsSeconds(kT0)));
    EXPECT_THAT(error.message, HasSubstr(formatNsAsSeconds(kT0 + 4 * kStep)));
  }
}

TEST(FrameCache, NewerThanTheNewestOrZeroGivesTheNewest) {
  FrameCache cache(10);
  fill(cache, 5);
  EXPECT_EQ(sequenceAt(cache, kT0 + 4 * kStep + 1), 4u);
  EXPECT_EQ(sequenceAt(cache, kT0 + 1000 * kStep), 4u);
  EXPECT_EQ(sequenceAt(cache, std::numeric_limits<TimestampNs>::max()), 4u);
  EXPECT_EQ(sequenceAt(cache, 0), 4u);
}

TEST(FrameCache, SingleFrame) {
  FrameCache cache(3);
  ASSERT_TRUE(cache.insert(frameAt(kT0, 7)));
  EXPECT_EQ(sequenceAt(cache, kT0), 7u);
  EXPECT_EQ(sequenceAt(cache, kT0 + 1), 7u);
  EXPECT_EQ(sequenceAt(cache, 0), 7u);
  auto before = cache.at(kT0 - 1);
  ASSERT_TRUE(std::holds_alternative<LookupError>(before));
  EXPECT_EQ(std::get<LookupError>(before).kind, LookupError::Kind::kBeforeCache);
}

TEST(FrameCache, RepeatedTimestampIsRefusedAndTheFirstFrameStays) {
  // Two frames at one T would make "the frame at T" ambiguous and hide the first from lookups.
  FrameCache cache(5);
  ASSERT_TRUE(cache.insert(frameAt(kT0, 0)));
  ASSERT_TRUE(cache.insert(frameAt(kT0 + kStep, 1)));
  EXPECT_FALSE(cache.insert(frameAt(kT0 + kStep, 2)));
  EXPECT_EQ(cache.range().frames, 2u);
  EXPECT_FALSE(cache.bySequence(2).has_value());
  EXPECT_EQ(sequenceAt(cache, kT0 + kStep), 1u);
  EXPECT_EQ(sequenceAt(cache, kT0 + kStep - 1), 0u);
  EXPECT_TRUE(cache.insert(frameAt(kT0 + kStep + 1, 3)));
}

TEST(FrameCache, EvictsTheOldestAtCapacity) {
  FrameCache cache(3);
  fill(cache, 5);
  const CachedRange range = cache.range();
  EXPECT_EQ(range.frames, 3u);
  EXPECT_EQ(range.capacity, 3u);
  EXPECT_EQ(range.oldest_ns, kT0 + 2 * kStep);
  EXPECT_EQ(range.newest_ns, kT0 + 4 * kStep);
  EXPECT_FALSE(cache.bySequence(0).has_value());
  EXPECT_FALSE(cache.bySequence(1).has_value());
  ASSERT_TRUE(cache.bySequence(2).has_value());
  EXPECT_EQ(cache.bySequence(2)->frame->timestamp_ns, kT0 + 2 * kStep);
  // T on an evicted frame is now before the cache.
  auto found = cache.at(kT0 + kStep);
  ASSERT_TRUE(std::holds_alternative<LookupError>(found));
  EXPECT_EQ(std::get<LookupError>(found).kind, LookupError::Kind::kBeforeCache);
  EXPECT_THAT(std::get<LookupError>(found).message, HasSubstr(formatNsAsSeconds(kT0 + 2 * kStep)));
  EXPECT_EQ(sequenceAt(cache, kT0 + 2 * kStep), 2u);
}

TEST(FrameCache, OutOfOrderInsertIsRejected) {
  FrameCache cache(5);
  fill(cache, 3);
  EXPECT_FALSE(cache.insert(frameAt(kT0 + kStep, 99)));
  EXPECT_FALSE(cache.insert(frameAt(kT0 + 2 * kStep - 1, 100)));
  const CachedRange range = cache.range();
  EXPECT_EQ(range.frames, 3u);
  EXPECT_EQ(range.newest_ns, kT0 + 2 * kStep);
  EXPECT_FALSE(cache.bySequence(99).has_value());
  EXPECT_EQ(sequenceAt(cache, 0), 2u);
  EXPECT_TRUE(cache.insert(frameAt(kT0 + 3 * kStep, 3)));
}

TEST(FrameCache, PublishResultsAttachesToTheFrameOrFailsAfterEviction) {
  FrameCache cache(2);
  fill(cache, 2);
  EXPECT_EQ(std::get<CachedFrame>(cache.at(kT0)).results, nullptr);
  auto results = std::make_shared<FrameResults>();
  results->depth_stats = DepthStatistics{0.5, 1.0, 2.0, 3.0};
  EXPECT_TRUE(cache.publishResults(0, results));
  const CachedFrame entry = std::get<CachedFrame>(cache.at(kT0));
  ASSERT_NE(entry.results, nullptr);
  EXPECT_DOUBLE_EQ(entry.results->depth_stats->median_m, 2.0);
  EXPECT_EQ(std::get<CachedFrame>(cache.at(kT0 + kStep)).results, nullptr);

  ASSERT_TRUE(cache.insert(frameAt(kT0 + 2 * kStep, 2)));  // evicts 0
  EXPECT_FALSE(cache.publishResults(0, std::make_shared<FrameResults>()));
  EXPECT_FALSE(cache.publishResults(42, std::make_shared<FrameResults>()));
  EXPECT_TRUE(cache.publishResults(2, std::make_shared<FrameResults>()));
  EXPECT_NE(cache.bySequence(2)->results, nullptr);
}

TEST(FrameCache, ReaderKeepsItsViewAfterEviction) {
  FrameCache cache(1);
  fill(cache, 1);
  const CachedFrame held = std::get<CachedFrame>(cache.at(0));
  ASSERT_TRUE(cache.insert(frameAt(kT0 + kStep, 1)));
  ASSERT_TRUE(cache.insert(frameAt(kT0 + 2 * kStep, 2)));
  EXPECT_EQ(held.frame->sequence, 0u);
  EXPECT_EQ(held.frame->timestamp_ns, kT0);
  EXPECT_EQ(held.frame->depth.at<std::uint16_t>(0, 0), 0u);
}

std::vector<std::uint64_t> sequences(const std::vector<CachedFrame>& frames) {
  std::vector<std::uint64_t> out;
  for (const auto& f : frames) out.push_back(f.frame->sequence);
  return out;
}

TEST(FrameCache, ListRanges) {
  FrameCache cache(10);
  fill(cache, 6);
  using V = std::vector<std::uint64_t>;
  EXPECT_EQ(sequences(cache.list()), (V{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(sequences(cache.list(0, 0)), (V{0, 1, 2, 3, 4, 5}));
  // Bounds are inclusive.
  EXPECT_EQ(sequences(cache.list(kT0 + 2 * kStep, 0)), (V{2, 3, 4, 5}));
  EXPECT_EQ(sequences(cache.list(0, kT0 + 2 * kStep)), (V{0, 1, 2}));
  EXPECT_EQ(sequences(cache.list(kT0 + kStep, kT0 + 3 * kStep)), (V{1, 2, 3}));
  EXPECT_EQ(sequences(cache.list(kT0 + kStep + 1, kT0 + 3 * kStep - 1)), (V{2}));
  EXPECT_EQ(sequences(cache.list(kT0 + 2 * kStep, kT0 + 2 * kStep)), (V{2}));
  EXPECT_TRUE(cache.list(kT0 + kStep + 1, kT0 + 2 * kStep - 1).empty());
  EXPECT_TRUE(cache.list(kT0 + 6 * kStep, 0).empty());
  EXPECT_TRUE(cache.list(0, kT0 - 1).empty());
  EXPECT_TRUE(cache.list(kT0 + 4 * kStep, kT0 + 2 * kStep).empty());  // from > to
}

// One writer inserting thousands of frames, several readers looking frames up meanwhile. Every
// answer must obey the lookup rule as far as a reader can tell: never newer than T, and a
// reader asking for the newest never sees time or sequence go backwards.
TEST(FrameCache, OneWriterManyReaders) {
  constexpr int kFrames = 5000;
  constexpr int kReaders = 4;
  FrameCache cache(64);
  std::atomic<bool> writing{true};
  std::atomic<int> violations{0};
  std::atomic<long> lookups{0};
  std::atomic<TimestampNs> newest_inserted{0};

  std::vector<std::thread> readers;
  for (int r = 0; r < kReaders; ++r) {
    readers.emplace_back([&, r] {
      std::uint64_t last_sequence = 0;
      TimestampNs last_newest = 0;
      std::uint64_t rng = 12345 + r;
      while (writing.load()) {
        rng = rng * 6364136223846793005ull + 1442695040888963407ull;
        // Sometimes the newest, else a T somewhere in the recent past (or just ahead).
        const TimestampNs high = newest_inserted.load();
        if (high == 0) continue;
        const bool newest = (rng >> 60) == 0;
        const TimestampNs t =
            newest ? 0 : high - static_cast<TimestampNs>((rng >> 20) % (80 * kStep)) + kStep;
        auto found = cache.at(t);
        lookups.fetch_add(1);
        if (auto* error = std::get_if<LookupError>(&found)) {
          // Only "before the cache" can happen here (something was inserted).
          if (error->kind != LookupError::Kind::kBeforeCache) violations.fetch_add(1);
          continue;
        }
        const CachedFrame& entry = std::get<CachedFrame>(found);
        const Frame& f = *entry.frame;
        // Frame i is at kT0 + i * kStep: the frame's content must match its identity.
        if (f.timestamp_ns != kT0 + static_cast<TimestampNs>(f.sequence) * kStep)
          violations.fetch_add(1);
        if (t != 0 && f.timestamp_ns > t) violations.fetch_add(1);
        // When T is not past `high`, the frame at or before T was inserted before this lookup,
        // and the cache holds a contiguous run ending at the newest: it must be that frame.
        if (t != 0 && t <= high && f.sequence != static_cast<std::uint64_t>((t - kT0) / kStep)) {
          violations.fetch_add(1);
        }
        if (newest) {
          if (f.sequence < last_sequence || f.timestamp_ns < last_newest) violations.fetch_add(1);
          last_sequence = f.sequence;
          last_newest = f.timestamp_ns;
        }
        // Like gRPC handlers, readers come and go rather than hold the lock back to back.
        // (glibc's shared_mutex prefers readers: back-to-back readers on 2 cores starve the
        // writer.)
        std::this_thread::yield();
        // list() is oldest first, strictly increasing sequence and time, at most capacity.
        if ((rng >> 50) % 16 == 0) {
          const auto all = cache.list();
          if (all.size() > 64) violations.fetch_add(1);
          for (std::size_t i = 1; i < all.size(); ++i) {
            if (all[i].frame->sequence != all[i - 1].frame->sequence + 1 ||
                all[i].frame->timestamp_ns <= all[i - 1].frame->timestamp_ns) {
              violations.fetch_add(1);
            }
          }
        }
      }
    });
  }

  // At least kFrames inserts, and on until the readers have done a fair number of lookups.
  int inserted = 0;
  for (int i = 0; i < kFrames || (lookups.load() < 2000 && i < 50 * kFrames); ++i, ++inserted) {
    auto frame = frameAt(kT0 + i * kStep, i);
    ASSERT_TRUE(cache.insert(frame));
    newest_inserted.store(frame->timestamp_ns);
    if (i % 2 == 0) cache.publishResults(i, std::make_shared<FrameResults>());
    if (i % 256 == 0) std::this_thread::yield();
  }
  // Give readers a moment against the final state too.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  writing.store(false);
  for (auto& reader : readers) reader.join();

  EXPECT_EQ(violations.load(), 0);
  EXPECT_GE(lookups.load(), 2000);
  const CachedRange range = cache.range();
  EXPECT_EQ(range.frames, 64u);
  EXPECT_EQ(range.newest_ns, kT0 + static_cast<TimestampNs>(inserted - 1) * kStep);
  EXPECT_EQ(range.oldest_ns, kT0 + static_cast<TimestampNs>(inserted - 64) * kStep);
}

}  // namespace
}  // namespace shapesense
