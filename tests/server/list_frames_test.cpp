// ListFrames through a real in-process gRPC server.

#include <vector>

#include <gtest/gtest.h>

#include "server_fixture.h"

namespace shapesense {
namespace {

using testing::clientContext;
using testing::kFramePeriodNs;
using testing::kServerT0;
using testing::ServerTest;

class ListFramesTest : public ServerTest {
 protected:
  void SetUp() override { srv.addMany(10); }  // frames 0..9

  grpc::Status list(std::int64_t from, std::int64_t to, std::uint32_t limit,
                    v1::ListFramesResponse& response) {
    v1::ListFramesRequest request;
    request.set_from_ns(from);
    request.set_to_ns(to);
    request.set_limit(limit);
    auto context = clientContext();
    return srv.stub().ListFrames(context.get(), request, &response);
  }

  std::vector<std::uint64_t> sequences(std::int64_t from, std::int64_t to,
                                       std::uint32_t limit = 0) {
    v1::ListFramesResponse response;
    const grpc::Status status = list(from, to, limit, response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    std::vector<std::uint64_t> out;
    for (const auto& f : response.frames()) out.push_back(f.sequence());
    return out;
  }

  static std::int64_t t(int i) { return kServerT0 + i * kFramePeriodNs; }
};

using V = std::vector<std::uint64_t>;

TEST_F(ListFramesTest, AllFramesOldestFirstWithTheirInfo) {
  v1::ListFramesResponse response;
  ASSERT_TRUE(list(0, 0, 0, response).ok());
  ASSERT_EQ(response.frames_size(), 10);
  for (int i = 0; i < 10; ++i) {
    const auto& f = response.frames(i);
    EXPECT_EQ(f.sequence(), static_cast<std::uint64_t>(i));
    EXPECT_EQ(f.timestamp_ns(), t(i));
    EXPECT_EQ(f.width(), 32u);
    EXPECT_EQ(f.height(), 24u);
    EXPECT_TRUE(f.has_rgb());
    EXPECT_TRUE(f.processed());
  }
  EXPECT_EQ(response.cache().frames(), 10u);
  EXPECT_EQ(response.cache().capacity(), 16u);
  EXPECT_EQ(response.cache().oldest_ns(), t(0));
  EXPECT_EQ(response.cache().newest_ns(), t(9));
}

TEST_F(ListFramesTest, LimitKeepsTheNewestOfTheRange) {
  EXPECT_EQ(sequences(0, 0, 3), (V{7, 8, 9}));
  EXPECT_EQ(sequences(0, 0, 1), (V{9}));
  EXPECT_EQ(sequences(0, 0, 10), (V{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(sequences(0, 0, 1000), (V{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(sequences(0, t(5), 2), (V{4, 5}));
  EXPECT_EQ(sequences(t(2), t(6), 3), (V{4, 5, 6}));
}

TEST_F(ListFramesTest, FromAndToAreInclusive) {
  EXPECT_EQ(sequences(t(4), 0), (V{4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(sequences(t(4) + 1, 0), (V{5, 6, 7, 8, 9}));
  EXPECT_EQ(sequences(0, t(3)), (V{0, 1, 2, 3}));
  EXPECT_EQ(sequences(0, t(3) - 1), (V{0, 1, 2}));
  EXPECT_EQ(sequences(t(2), t(4)), (V{2, 3, 4}));
  EXPECT_EQ(sequences(t(5), t(5)), (V{5}));
}

TEST_F(ListFramesTest, RangesOutsideTheCacheAreEmptyNotErrors) {
  EXPECT_TRUE(sequences(t(9) + 1, 0).empty());
  EXPECT_TRUE(sequences(1, t(0) - 1).empty());
  EXPECT_TRUE(sequences(t(3) + 1, t(4) - 1).empty());
}

TEST_F(ListFramesTest, FromAfterToIsInvalidArgument) {
  v1::ListFramesResponse response;
  const grpc::Status status = list(t(5), t(4), 0, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_FALSE(status.error_message().empty());
}

TEST_F(ListFramesTest, NegativeTimesAreInvalidArgument) {
  for (auto [from, to] : {std::pair<std::int64_t, std::int64_t>{-1, 0}, {0, -1}, {-5, -1}}) {
    v1::ListFramesResponse response;
    EXPECT_EQ(list(from, to, 0, response).error_code(), grpc::StatusCode::INVALID_ARGUMENT)
        << from << " " << to;
  }
}

TEST_F(ListFramesTest, UnprocessedAndColourlessFramesAreMarked) {
  srv.add(t(10), /*with_rgb=*/false, /*publish_results=*/false);
  v1::ListFramesResponse response;
  ASSERT_TRUE(list(t(10), 0, 0, response).ok());
  ASSERT_EQ(response.frames_size(), 1);
  EXPECT_FALSE(response.frames(0).has_rgb());
  EXPECT_FALSE(response.frames(0).processed());
  EXPECT_EQ(response.frames(0).sequence(), 10u);
}

TEST(ListFrames, EvictedFramesAreNotListed) {
  testing::TestServer srv(4);
  srv.addMany(9);
  v1::ListFramesResponse response;
  auto context = clientContext();
  ASSERT_TRUE(srv.stub().ListFrames(context.get(), {}, &response).ok());
  ASSERT_EQ(response.frames_size(), 4);
  EXPECT_EQ(response.frames(0).sequence(), 5u);
  EXPECT_EQ(response.frames(3).sequence(), 8u);
  EXPECT_EQ(response.cache().capacity(), 4u);
  EXPECT_EQ(response.cache().frames(), 4u);
}

TEST(ListFrames, EmptyCacheListsNothing) {
  testing::TestServer srv(4);
  v1::ListFramesResponse response;
  auto context = clientContext();
  const grpc::Status status = srv.stub().ListFrames(context.get(), {}, &response);
  // Either answer is within the contract; what must not happen is a frame out of nowhere.
  if (status.ok()) {
    EXPECT_EQ(response.frames_size(), 0);
    EXPECT_EQ(response.cache().frames(), 0u);
  } else {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  }
}

}  // namespace
}  // namespace shapesense
