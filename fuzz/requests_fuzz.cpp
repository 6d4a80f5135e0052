// The request validators: the first byte picks an RPC, the rest is parsed as its request message
// and handed to the real handler over a small cache (one frame with detector results, one
// without). Watch and Record need a live gRPC stream and are not covered here.
#include <cstddef>
#include <cstdint>
#include <memory>

#include <google/protobuf/stubs/logging.h>

#include "shapesense/server/handlers.h"

namespace {

using namespace shapesense;

std::shared_ptr<const Frame> makeFrame(TimestampNs stamp, std::uint64_t sequence) {
  auto frame = std::make_shared<Frame>();
  frame->depth = cv::Mat(48, 64, CV_16UC1);
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) {
      frame->depth.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(800 + 13 * u + 7 * v);
    }
  }
  frame->rgb = cv::Mat(48, 64, CV_8UC3, cv::Scalar(10, 20, 30));
  frame->intrinsics = CameraIntrinsics{52.5, 52.5, 31.5, 23.5, 64, 48};
  frame->timestamp_ns = stamp;
  frame->sequence = sequence;
  return frame;
}

struct Service {
  FrameCache cache{4};
  SummaryHub hub;
  ServiceContext context{cache, hub};
  Service() {
    // Invalid UTF-8 in a string field is a parse failure the fuzzer meets constantly; protobuf
    // would log each one.
    google::protobuf::SetLogHandler(nullptr);
    constexpr TimestampNs kT0 = 1'700'000'000'000'000'000LL;
    cache.insert(makeFrame(kT0, 0));
    cache.insert(makeFrame(kT0 + 33'333'333, 1));
    cache.publishResults(0, std::make_shared<const FrameResults>());
  }
};

template <typename Request, typename Response, typename Handler>
void call(const Service& service, const std::uint8_t* data, std::size_t size, Handler handler) {
  Request request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return;
  Response response;
  handler(service.context, request, &response);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Service service;
  if (size == 0) return 0;
  const std::uint8_t* body = data + 1;
  const std::size_t body_size = size - 1;
  switch (data[0] % 8) {
    case 0:
      call<v1::GetStatusRequest, v1::GetStatusResponse>(service, body, body_size, handleGetStatus);
      break;
    case 1:
      call<v1::ListFramesRequest, v1::ListFramesResponse>(service, body, body_size,
                                                          handleListFrames);
      break;
    case 2:
      call<v1::GetFrameRequest, v1::GetFrameResponse>(service, body, body_size, handleGetFrame);
      break;
    case 3:
      call<v1::EstimateBoxRequest, v1::EstimateBoxResponse>(service, body, body_size,
                                                            handleEstimateBox);
      break;
    case 4:
      call<v1::GetDetectedBoxesRequest, v1::GetDetectedBoxesResponse>(service, body, body_size,
                                                                      handleGetDetectedBoxes);
      break;
    case 5:
      call<v1::GetSegmentsRequest, v1::GetSegmentsResponse>(service, body, body_size,
                                                            handleGetSegments);
      break;
    case 6:
      call<v1::GetPlanesRequest, v1::GetPlanesResponse>(service, body, body_size, handleGetPlanes);
      break;
    case 7:
      call<v1::GetBowlsRequest, v1::GetBowlsResponse>(service, body, body_size, handleGetBowls);
      break;
  }
  return 0;
}
