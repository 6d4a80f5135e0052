// Every RPC leaves a log line with method, peer, status and duration: Record at info (it
// writes on the daemon's machine), the rest at debug. The line is written before the status
// is sent, so it is there once the client has the status.

#include "shapesense/server/call_log.h"

#include <algorithm>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include "server_fixture.h"

namespace shapesense {
namespace {

using ::testing::AllOf;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Not;

/// Collects what the default logger writes while it lives, at `level`.
class CapturedLog {
 public:
  explicit CapturedLog(spdlog::level::level_enum level)
      : sink_(std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(256)),
        previous_level_(spdlog::default_logger()->level()) {
    spdlog::default_logger()->sinks().push_back(sink_);
    spdlog::set_level(level);
  }
  ~CapturedLog() {
    auto& sinks = spdlog::default_logger()->sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink_), sinks.end());
    spdlog::set_level(previous_level_);
  }
  std::vector<std::string> lines() const { return sink_->last_formatted(); }

 private:
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_;
  spdlog::level::level_enum previous_level_;
};

grpc::Status record(testing::TestServer& srv, const std::string& dir) {
  v1::RecordRequest request;
  request.set_dir(dir);
  request.set_seconds(0.05);
  auto context = testing::clientContext();
  auto reader = srv.stub().Record(context.get(), request);
  v1::RecordProgress progress;
  while (reader->Read(&progress)) {
  }
  return reader->Finish();
}

grpc::Status getStatus(testing::TestServer& srv) {
  v1::GetStatusResponse response;
  auto context = testing::clientContext();
  return srv.stub().GetStatus(context.get(), {}, &response);
}

TEST(CallLog, RecordIsLoggedAtInfoWithPeerStatusAndDuration) {
  testing::TestServer srv(4);
  CapturedLog log(spdlog::level::info);
  ASSERT_TRUE(record(srv, "take").ok());
  ASSERT_EQ(record(srv, "../escape").error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  ASSERT_TRUE(getStatus(srv).ok());
  const auto lines = log.lines();
  EXPECT_THAT(lines, Contains(AllOf(HasSubstr("[info] rpc /shapesense.v1.ShapeSense/Record from "
                                              "ipv4:127.0.0.1:"),
                                    HasSubstr(": OK in "), HasSubstr(" ms"))));
  EXPECT_THAT(lines, Contains(AllOf(HasSubstr("rpc /shapesense.v1.ShapeSense/Record"),
                                    HasSubstr(": INVALID_ARGUMENT (dir '../escape' contains"))));
  EXPECT_THAT(lines, Not(Contains(HasSubstr("GetStatus"))));
}

TEST(CallLog, OtherCallsAreLoggedAtDebug) {
  testing::TestServer srv(4);
  CapturedLog log(spdlog::level::debug);
  ASSERT_TRUE(getStatus(srv).ok());
  EXPECT_THAT(log.lines(),
              Contains(AllOf(HasSubstr("[debug] rpc /shapesense.v1.ShapeSense/GetStatus from "
                                       "ipv4:127.0.0.1:"),
                             HasSubstr(": OK in "))));
}

}  // namespace
}  // namespace shapesense
