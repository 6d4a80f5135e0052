// Requests whose bytes are not a valid protobuf message, sent with grpc::GenericStub: what the
// daemon answers today, and what RequestParseStatusFactory makes of it.

#include <future>
#include <iostream>
#include <string>

#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>
#include <grpcpp/support/byte_buffer.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server_fixture.h"
#include "shapesense/server/request_parse_status.h"

namespace shapesense {
namespace {

using ::testing::HasSubstr;

// Field 1 with wire type 7, which does not exist: no parser accepts it.
const std::string kGarbage("\x0f\xff\xff\xff", 4);

grpc::Status callRaw(const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
                     const std::string& bytes) {
  grpc::GenericStub stub(channel);
  grpc::Slice slice(bytes);
  grpc::ByteBuffer request(&slice, 1);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  auto context = testing::clientContext();
  stub.UnaryCall(context.get(), method, grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status status) { done.set_value(std::move(status)); });
  return done.get_future().get();
}

std::string serialized(const google::protobuf::MessageLite& message) {
  std::string bytes;
  message.SerializeToString(&bytes);
  return bytes;
}

TEST(MalformedRequest, TheDaemonRefusesItAndKeepsServing) {
  testing::TestServer server;
  server.addMany(3);
  const grpc::Status status =
      callRaw(server.channel(), "/shapesense.v1.ShapeSense/GetFrame", kGarbage);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
      << "'" << status.error_message() << "'";
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr("could not be parsed"));
  v1::GetFrameRequest valid;
  EXPECT_TRUE(
      callRaw(server.channel(), "/shapesense.v1.ShapeSense/GetFrame", serialized(valid)).ok());
}

/// Only GetFrame, answering OK, or INTERNAL when asked for T = 1.
class TinyService final : public v1::ShapeSense::Service {
  grpc::Status GetFrame(grpc::ServerContext*, const v1::GetFrameRequest* request,
                        v1::GetFrameResponse*) override {
    if (request->at_ns() == 1) return {grpc::StatusCode::INTERNAL, "handler's own failure"};
    return grpc::Status::OK;
  }
};

class ParseStatusServer {
 public:
  explicit ParseStatusServer(bool with_interceptor) {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(&service_);
    if (with_interceptor) {
      std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> list;
      list.push_back(std::make_unique<RequestParseStatusFactory>());
      builder.experimental().SetInterceptorCreators(std::move(list));
    }
    server_ = builder.BuildAndStart();
    channel_ = grpc::CreateChannel("127.0.0.1:" + std::to_string(port_),
                                   grpc::InsecureChannelCredentials());
  }
  ~ParseStatusServer() { server_->Shutdown(); }
  grpc::Status getFrame(const std::string& bytes) {
    return callRaw(channel_, "/shapesense.v1.ShapeSense/GetFrame", bytes);
  }

 private:
  TinyService service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  std::shared_ptr<grpc::Channel> channel_;
};

TEST(MalformedRequest, GrpcAloneAnswersInternalWithAnEmptyMessage) {
  ParseStatusServer server(false);
  const grpc::Status status = server.getFrame(kGarbage);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_EQ(status.error_message(), "");
}

TEST(MalformedRequest, TheInterceptorSaysTheRequestCouldNotBeParsed) {
  ParseStatusServer server(true);
  const grpc::Status status = server.getFrame(kGarbage);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("could not be parsed as the GetFrame request"));
  // Parsed requests are left alone, the handler's own INTERNAL included.
  v1::GetFrameRequest valid;
  EXPECT_TRUE(server.getFrame(serialized(valid)).ok());
  valid.set_at_ns(1);
  const grpc::Status own = server.getFrame(serialized(valid));
  EXPECT_EQ(own.error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_EQ(own.error_message(), "handler's own failure");
}

}  // namespace
}  // namespace shapesense
