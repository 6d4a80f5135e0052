// What the server does under more queries than it takes on: heavy queries wait in a bounded
// queue for a bounded number of workers, and what does not fit, or passes --max-calls, is
// answered RESOURCE_EXHAUSTED at once, while cheap calls are still answered. The pool is
// occupied by a task the test holds, so "busy" does not depend on timing.

#include <chrono>
#include <future>
#include <thread>

#include <gtest/gtest.h>

#include "server_fixture.h"

namespace shapesense::testing {
namespace {

using namespace std::chrono_literals;

/// Occupies every worker of a pool until release() (or destruction).
class PoolBlocker {
 public:
  explicit PoolBlocker(QueryPool& pool) {
    for (int i = 0; i < pool.workers(); ++i) {
      auto started = std::make_shared<std::promise<void>>();
      auto running = started->get_future();
      EXPECT_TRUE(pool.trySubmit([gate = gate_, started](bool) {
        started->set_value();
        gate.wait();
      }));
      EXPECT_EQ(running.wait_for(5s), std::future_status::ready);
    }
  }
  ~PoolBlocker() { release(); }
  void release() {
    if (!released_) release_.set_value();
    released_ = true;
  }

 private:
  std::promise<void> release_;
  std::shared_future<void> gate_ = release_.get_future().share();
  bool released_ = false;
};

ServerLimits oneWorker(std::size_t queue, std::size_t max_calls = 128) {
  ServerLimits limits;
  limits.queries.workers = 1;
  limits.queries.max_wait = 60s;  // held calls are answered, however long the test holds them
  limits.queries.queue = queue;
  limits.max_calls = max_calls;
  return limits;
}

v1::EstimateBoxRequest boxRequest() {
  v1::EstimateBoxRequest request;
  request.mutable_p1()->set_x(4);
  request.mutable_p1()->set_y(4);
  request.mutable_p2()->set_x(20);
  request.mutable_p2()->set_y(16);
  request.set_mode(v1::BOX_MODE_AXIS_ALIGNED_CONTAINED);
  return request;
}

/// The retry pushback the daemon sent with a call's status, or "" when it sent none.
std::string pushbackOf(const grpc::ClientContext& context) {
  const auto& trailers = context.GetServerTrailingMetadata();
  const auto found = trailers.find(kRetryPushbackKey);
  return found == trailers.end() ? "" : std::string(found->second.data(), found->second.size());
}

/// An EstimateBox started now, answered whenever the server answers it.
struct PendingCall {
  grpc::ClientContext context;
  v1::EstimateBoxResponse response;
  std::promise<grpc::Status> done;
  std::future<grpc::Status> status = done.get_future();

  PendingCall(v1::ShapeSense::Stub& stub, const v1::EstimateBoxRequest& request) {
    context.set_deadline(std::chrono::system_clock::now() + 10s);
    stub.async()->EstimateBox(&context, &request, &response,
                              [this](grpc::Status s) { done.set_value(std::move(s)); });
  }
};

TEST(QueryPool, RefusesPastItsQueueAndRunsWhatItQueuedWhenStopped) {
  QueryPool pool(QueryPoolOptions{.workers = 1, .queue = 2, .max_wait = 60s, .nice = 0});
  EXPECT_EQ(pool.workers(), 1);
  std::atomic<int> ran{0};
  const auto count = [&](bool run) { ran += run ? 1 : 100; };
  {
    PoolBlocker blocker(pool);
    EXPECT_TRUE(pool.trySubmit(count));
    EXPECT_TRUE(pool.trySubmit(count));
    EXPECT_FALSE(pool.trySubmit(count)) << "a third task past a queue of 2";
    EXPECT_EQ(ran, 0);
  }
  pool.stop();
  EXPECT_EQ(ran, 2);
  EXPECT_FALSE(pool.trySubmit(count)) << "a stopped pool takes nothing";
}

TEST(QueryPool, ATaskThatWaitedPastMaxWaitIsToldNotToRun) {
  QueryPool pool(QueryPoolOptions{.workers = 1, .queue = 4, .max_wait = 20ms, .nice = 0});
  std::promise<bool> told;
  {
    PoolBlocker blocker(pool);
    ASSERT_TRUE(pool.trySubmit([&](bool run) { told.set_value(run); }));
    std::this_thread::sleep_for(50ms);  // the only worker is held well past max_wait
  }
  EXPECT_FALSE(told.get_future().get());
  std::promise<bool> prompt;
  ASSERT_TRUE(pool.trySubmit([&](bool run) { prompt.set_value(run); }));
  EXPECT_TRUE(prompt.get_future().get()) << "a task that found a worker idle runs";
}

TEST(QueryPool, DefaultLeavesACoreToTheDetectors) {
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  EXPECT_EQ(QueryPool::defaultWorkers(), std::max(1, cores - 1));
}

TEST(QueryLimits, FullQueueAnswersResourceExhaustedAtOnceAndCheapCallsStillWork) {
  TestServer srv(16, {}, {}, oneWorker(/*queue=*/1));
  srv.addMany(2);
  const auto request = boxRequest();
  PoolBlocker blocker(srv.server().queryPool());
  PendingCall queued(srv.stub(), request);  // takes the one queue slot
  ASSERT_EQ(queued.status.wait_for(200ms), std::future_status::timeout)
      << "answered although the only worker is busy: " << queued.status.get().error_message();

  v1::EstimateBoxResponse response;
  const auto start = std::chrono::steady_clock::now();
  const auto refused_context = clientContext();
  const grpc::Status refused = srv.stub().EstimateBox(refused_context.get(), request, &response);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(pushbackOf(*refused_context), std::to_string(ServerLimits{}.busy_pushback_ms))
      << "a busy refusal says when to call again";
  EXPECT_NE(refused.error_message().find("--query-queue"), std::string::npos)
      << refused.error_message();
  EXPECT_LT(std::chrono::steady_clock::now() - start, 2s) << "refused, but not at once";
  v1::GetBowlsResponse bowls;
  EXPECT_EQ(srv.stub().GetBowls(clientContext().get(), {}, &bowls).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED)
      << "GetBowls runs on the same pool";
  v1::FindObjectsResponse found;
  EXPECT_EQ(srv.stub().FindObjects(clientContext().get(), {}, &found).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED)
      << "FindObjects runs on the same pool";
  v1::TeachObjectResponse taught;
  EXPECT_EQ(srv.stub().TeachObject(clientContext().get(), {}, &taught).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED)
      << "TeachObject runs on the same pool";

  // Cheap calls are answered on gRPC's own threads.
  v1::GetStatusResponse status;
  EXPECT_TRUE(srv.stub().GetStatus(clientContext().get(), {}, &status).ok());
  v1::ListFramesResponse frames;
  EXPECT_TRUE(srv.stub().ListFrames(clientContext().get(), {}, &frames).ok());
  v1::ListObjectModelsResponse models;
  EXPECT_TRUE(srv.stub().ListObjectModels(clientContext().get(), {}, &models).ok());

  blocker.release();
  ASSERT_EQ(queued.status.wait_for(5s), std::future_status::ready);
  const grpc::Status answered = queued.status.get();
  EXPECT_TRUE(answered.ok()) << answered.error_message();
  EXPECT_EQ(queued.response.corners_size(), 8);
  EXPECT_TRUE(srv.stub().EstimateBox(clientContext().get(), request, &response).ok());
}

TEST(QueryLimits, ACallThatWaitedTooLongIsRefusedNotRunLate) {
  ServerLimits limits = oneWorker(/*queue=*/4);
  limits.queries.max_wait = 20ms;
  TestServer srv(16, {}, {}, limits);
  srv.addMany(2);
  const auto request = boxRequest();
  PoolBlocker blocker(srv.server().queryPool());
  PendingCall late(srv.stub(), request);
  std::this_thread::sleep_for(100ms);
  blocker.release();
  ASSERT_EQ(late.status.wait_for(5s), std::future_status::ready);
  const grpc::Status status = late.status.get();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(status.error_message().find("--query-max-wait-ms"), std::string::npos)
      << status.error_message();
  EXPECT_EQ(pushbackOf(late.context), std::to_string(ServerLimits{}.busy_pushback_ms));
}

TEST(QueryLimits, MaxCallsCountsQueuedCalls) {
  ServerLimits limits = oneWorker(/*queue=*/8, /*max_calls=*/2);
  limits.busy_pushback_ms = 40;
  TestServer srv(16, {}, {}, limits);
  srv.addMany(2);
  const auto request = boxRequest();
  PoolBlocker blocker(srv.server().queryPool());
  PendingCall first(srv.stub(), request);
  PendingCall second(srv.stub(), request);
  ASSERT_EQ(second.status.wait_for(200ms), std::future_status::timeout);
  v1::GetStatusResponse status;
  const auto refused_context = clientContext();
  const grpc::Status refused = srv.stub().GetStatus(refused_context.get(), {}, &status);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(refused.error_message().find("--max-calls"), std::string::npos)
      << refused.error_message();
  EXPECT_EQ(pushbackOf(*refused_context), "40");
  blocker.release();
  EXPECT_TRUE(first.status.get().ok());
  EXPECT_TRUE(second.status.get().ok());
  EXPECT_TRUE(srv.stub().GetStatus(clientContext().get(), {}, &status).ok())
      << "the slots of finished calls are free again";
}

TEST(QueryLimits, OversizedRequestIsRefused) {
  ServerLimits limits;
  limits.max_receive_message_bytes = 1024;
  TestServer srv(16, {}, {}, limits);
  srv.addMany(1);
  v1::GetSegmentsRequest request;
  request.set_method(std::string(4096, 'x'));
  v1::GetSegmentsResponse response;
  EXPECT_EQ(srv.stub().GetSegments(clientContext().get(), request, &response).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
}

TEST(QueryLimits, NoPushbackWhenTurnedOffAndNoneOnAnswers) {
  ServerLimits limits = oneWorker(/*queue=*/1);
  limits.busy_pushback_ms = 0;
  TestServer srv(16, {}, {}, limits);
  srv.addMany(2);
  const auto answered_context = clientContext();
  v1::EstimateBoxResponse response;
  ASSERT_TRUE(srv.stub().EstimateBox(answered_context.get(), boxRequest(), &response).ok());
  EXPECT_EQ(pushbackOf(*answered_context), "");
  PoolBlocker blocker(srv.server().queryPool());
  PendingCall queued(srv.stub(), boxRequest());  // takes the one queue slot
  ASSERT_EQ(queued.status.wait_for(200ms), std::future_status::timeout);
  const auto refused_context = clientContext();
  EXPECT_EQ(srv.stub().EstimateBox(refused_context.get(), boxRequest(), &response).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(pushbackOf(*refused_context), "");
  blocker.release();
  EXPECT_TRUE(queued.status.get().ok());
}

}  // namespace
}  // namespace shapesense::testing
