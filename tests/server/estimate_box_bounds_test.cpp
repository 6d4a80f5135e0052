// The one-request crash through the real gRPC server: a frame whose intrinsics say
// fx = fy = 0.001 (or 1e-300), then EstimateBox mode 1 over ROI (200,150)-(400,350). The daemon
// grew to gigabytes and died; the request is now refused and the server keeps answering.

#include <gtest/gtest.h>

#include "server_fixture.h"

namespace shapesense::testing {
namespace {

grpc::Status estimate(TestServer& srv, int mode) {
  v1::EstimateBoxRequest request;
  request.mutable_p1()->set_x(200);
  request.mutable_p1()->set_y(150);
  request.mutable_p2()->set_x(400);
  request.mutable_p2()->set_y(350);
  request.set_mode(static_cast<v1::BoxMode>(mode));
  v1::EstimateBoxResponse response;
  return srv.stub().EstimateBox(clientContext().get(), request, &response);
}

void expectRefusedAndServing(double focal) {
  SCOPED_TRACE("fx = fy = " + std::to_string(focal));
  TestServer srv;
  Frame frame = makeTestFrame(kServerT0, 0, false, 640, 480);
  frame.intrinsics.fx = focal;
  frame.intrinsics.fy = focal;
  ASSERT_TRUE(srv.cache().insert(std::make_shared<const Frame>(std::move(frame))));
  for (int mode : {1, 2, 3}) {
    const auto status = estimate(srv, mode);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << "mode " << mode;
    EXPECT_NE(status.error_message().find("optical axis"), std::string::npos);
  }
  v1::GetStatusResponse status_response;
  EXPECT_TRUE(
      srv.stub().GetStatus(clientContext().get(), v1::GetStatusRequest(), &status_response).ok());
}

TEST(EstimateBoxBounds, MilliPixelFocalLengthIsRefusedAndTheServerLives) {
  expectRefusedAndServing(0.001);
}

TEST(EstimateBoxBounds, DenormalScaleFocalLengthIsRefusedAndTheServerLives) {
  expectRefusedAndServing(1e-300);
}

}  // namespace
}  // namespace shapesense::testing
