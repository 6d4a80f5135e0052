// SummaryHub / Subscription: bounded per-subscriber queues that drop the oldest.

#include "shapesense/server/summary_hub.h"

#include <chrono>
#include <future>
#include <thread>

#include <gtest/gtest.h>

namespace shapesense {
namespace {

using namespace std::chrono_literals;

CachedFrame entry(std::uint64_t sequence) {
  auto frame = std::make_shared<Frame>();
  frame->sequence = sequence;
  frame->timestamp_ns = 1'700'000'000'000'000'000LL + static_cast<TimestampNs>(sequence) * 1000;
  frame->depth = cv::Mat(1, 1, CV_16UC1, cv::Scalar(1));
  return CachedFrame{frame, std::make_shared<FrameResults>()};
}

TEST(SummaryHub, DeliversInOrderWithoutDropsWhenKeepingUp) {
  SummaryHub hub;
  auto sub = hub.subscribe(4);
  EXPECT_EQ(hub.subscribers(), 1u);
  for (std::uint64_t i = 0; i < 10; ++i) {
    hub.publish(entry(i));
    auto item = sub->pop(100ms);
    ASSERT_TRUE(item.has_value());
    EXPECT_EQ(item->frame.frame->sequence, i);
    EXPECT_EQ(item->dropped_before, 0u);
  }
  EXPECT_FALSE(sub->pop(10ms).has_value());  // nothing pending: timeout
  EXPECT_FALSE(sub->closed());
}

TEST(SummaryHub, SlowSubscriberLosesTheOldestAndIsToldHowMany) {
  SummaryHub hub;
  auto slow = hub.subscribe(3);
  auto fast = hub.subscribe(100);
  for (std::uint64_t i = 0; i < 10; ++i) hub.publish(entry(i));
  // The slow one kept the newest 3 (7, 8, 9); 7 frames were dropped before the first of them.
  auto a = slow->pop(100ms);
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->frame.frame->sequence, 7u);
  EXPECT_EQ(a->dropped_before, 7u);
  auto b = slow->pop(100ms);
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->frame.frame->sequence, 8u);
  EXPECT_EQ(b->dropped_before, 0u);
  // More arrive: 10..13 with one slot taken by 9 -> 9 and 10 dropped.
  for (std::uint64_t i = 10; i < 14; ++i) hub.publish(entry(i));
  auto c = slow->pop(100ms);
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->frame.frame->sequence, 11u);
  EXPECT_EQ(c->dropped_before, 2u);
  EXPECT_EQ(slow->pop(100ms)->frame.frame->sequence, 12u);
  EXPECT_EQ(slow->pop(100ms)->frame.frame->sequence, 13u);
  EXPECT_FALSE(slow->pop(0ms).has_value());
  // The fast subscriber, with room, lost nothing: one slow client does not affect another.
  for (std::uint64_t i = 0; i < 14; ++i) {
    auto item = fast->pop(100ms);
    ASSERT_TRUE(item.has_value());
    EXPECT_EQ(item->frame.frame->sequence, i);
    EXPECT_EQ(item->dropped_before, 0u);
  }
}

TEST(SummaryHub, MaxPendingZeroStillHoldsOne) {
  SummaryHub hub;
  auto sub = hub.subscribe(0);
  hub.publish(entry(0));
  hub.publish(entry(1));
  auto item = sub->pop(100ms);
  ASSERT_TRUE(item.has_value());
  EXPECT_EQ(item->frame.frame->sequence, 1u);
  EXPECT_EQ(item->dropped_before, 1u);
}

TEST(SummaryHub, PublishNeverBlocksOnASubscriberThatDoesNotRead) {
  SummaryHub hub;
  auto sub = hub.subscribe(8);
  auto done = std::async(std::launch::async, [&] {
    for (std::uint64_t i = 0; i < 100000; ++i) hub.publish(entry(i % 16));
  });
  ASSERT_EQ(done.wait_for(10s), std::future_status::ready);
  std::uint64_t total = 0;
  int items = 0;
  while (auto item = sub->pop(0ms)) {
    total += 1 + item->dropped_before;
    ++items;
  }
  EXPECT_EQ(items, 8);
  EXPECT_EQ(total, 100000u);
}

TEST(SummaryHub, CloseAllEndsAWaitingPopPromptly) {
  SummaryHub hub;
  auto sub = hub.subscribe();
  auto waiting = std::async(std::launch::async, [&] { return sub->pop(30s); });
  std::this_thread::sleep_for(50ms);
  const auto start = std::chrono::steady_clock::now();
  hub.closeAll();
  ASSERT_EQ(waiting.wait_for(2s), std::future_status::ready) << "pop() kept waiting after closeAll";
  EXPECT_FALSE(waiting.get().has_value());
  EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
  EXPECT_TRUE(sub->closed());
  EXPECT_EQ(hub.subscribers(), 0u);
}

TEST(SummaryHub, ClosedSubscriptionGivesNothingEvenWithPendingItems) {
  SummaryHub hub;
  auto sub = hub.subscribe();
  hub.publish(entry(0));
  hub.closeAll();
  EXPECT_FALSE(sub->pop(0ms).has_value());
  // Publishing after close reaches nobody and does not crash.
  hub.publish(entry(1));
  // Subscribing after close gives an already closed subscription.
  auto late = hub.subscribe();
  EXPECT_TRUE(late->closed());
  EXPECT_FALSE(late->pop(10ms).has_value());
  EXPECT_EQ(hub.subscribers(), 0u);
}

TEST(SummaryHub, UnsubscribeStopsDelivery) {
  SummaryHub hub;
  auto a = hub.subscribe();
  auto b = hub.subscribe();
  EXPECT_EQ(hub.subscribers(), 2u);
  hub.unsubscribe(a);
  EXPECT_EQ(hub.subscribers(), 1u);
  hub.publish(entry(5));
  EXPECT_FALSE(a->pop(0ms).has_value());
  ASSERT_TRUE(b->pop(0ms).has_value());
  hub.unsubscribe(a);  // twice is harmless
  EXPECT_EQ(hub.subscribers(), 1u);
}

}  // namespace
}  // namespace shapesense
