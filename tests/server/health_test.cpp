// The standard grpc.health.v1 health service answers on the daemon's port. Debian ships no
// generated health stubs, so the call is made with a generic stub and hand-encoded protobuf:
//   HealthCheckRequest  { string service = 1; }
//   HealthCheckResponse { ServingStatus status = 1; }  SERVING = 1, NOT_FOUND via gRPC status.

#include <future>
#include <string>
#include <vector>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/support/byte_buffer.h>
#include <gtest/gtest.h>

#include "server_fixture.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;

grpc::ByteBuffer healthRequest(const std::string& service) {
  std::string bytes;
  if (!service.empty()) {
    bytes.push_back(0x0a);  // field 1, length-delimited
    bytes.push_back(static_cast<char>(service.size()));
    bytes += service;
  }
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

std::string toBytes(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  if (!buffer.Dump(&slices).ok()) return {};
  std::string out;
  for (const auto& s : slices) out.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return out;
}

struct HealthAnswer {
  grpc::Status status;
  std::string response;
};

HealthAnswer check(testing::TestServer& srv, const std::string& service) {
  grpc::GenericStub stub(srv.channel());
  auto context = testing::clientContext(5s);
  const grpc::ByteBuffer request = healthRequest(service);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(context.get(), "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request,
                 &response, [&](grpc::Status status) { done.set_value(std::move(status)); });
  auto future = done.get_future();
  if (future.wait_for(10s) != std::future_status::ready) {
    context->TryCancel();
    future.wait();
    return {grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "no answer"), {}};
  }
  HealthAnswer answer{future.get(), {}};
  if (answer.status.ok()) answer.response = toBytes(response);
  return answer;
}

TEST(Health, OverallServiceIsServing) {
  testing::TestServer srv(4);
  const HealthAnswer answer = check(srv, "");
  ASSERT_TRUE(answer.status.ok()) << answer.status.error_code() << " "
                                  << answer.status.error_message();
  // status (field 1, varint) = SERVING (1)
  EXPECT_EQ(answer.response, std::string("\x08\x01", 2));
}

TEST(Health, ServingEvenBeforeAnyFrame) {
  // Health is about the process answering, not about the cache: an empty cache still serves.
  testing::TestServer srv(4);
  ASSERT_EQ(srv.cache().range().frames, 0u);
  const HealthAnswer answer = check(srv, "");
  ASSERT_TRUE(answer.status.ok()) << answer.status.error_message();
  EXPECT_EQ(answer.response, std::string("\x08\x01", 2));
}

TEST(Health, UnknownServiceIsNotFound) {
  testing::TestServer srv(4);
  const HealthAnswer answer = check(srv, "no.such.Service");
  EXPECT_EQ(answer.status.error_code(), grpc::StatusCode::NOT_FOUND)
      << answer.status.error_message();
}

}  // namespace
}  // namespace shapesense
