#include <chrono>

#include "shapesense/core/pipeline/stages.h"
#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {

grpc::Status handleGetSegments(const ServiceContext& context, const v1::GetSegmentsRequest& request,
                               v1::GetSegmentsResponse* response) {
  std::optional<SegmentationMethod> wanted;
  if (!request.method().empty()) {
    wanted = parseSegmentationMethod(request.method());
    if (!wanted) {
      return {grpc::StatusCode::INVALID_ARGUMENT, "unknown segmentation method '" +
                                                      request.method() + "': use " +
                                                      listSegmentationMethods()};
    }
  }
  CachedFrame entry;
  if (auto status = lookupFrame(context.cache, request.at_ns(), entry); !status.ok()) return status;

  const SegmentationResult* result = nullptr;
  SegmentationResult computed;
  const auto& cached = entry.results ? entry.results->segmentation : std::nullopt;
  if (cached && (!wanted || *wanted == cached->method)) {
    result = &*cached;
    response->set_compute_ms(entry.results->timings_ms.count("segmentation")
                                 ? entry.results->timings_ms.at("segmentation")
                                 : 0.0);
  } else {
    const auto start = std::chrono::steady_clock::now();
    const auto& planes = entry.results ? entry.results->planes : std::nullopt;
    computed = segmentFrame(*entry.frame, wanted.value_or(kDefaultSegmentationMethod), {},
                            planes ? &planes->frame : nullptr);
    const std::chrono::duration<double, std::milli> took = std::chrono::steady_clock::now() - start;
    response->set_compute_ms(took.count());
    response->set_computed_on_request(true);
    result = &computed;
  }
  response->set_frame_timestamp_ns(entry.frame->timestamp_ns);
  response->set_method(std::string(formatSegmentationMethod(result->method)));
  if (!request.skip_labels()) {
    response->set_labels_png(
        result == &computed ? encodePng(result->labels)
                            : *context.pngs->get(entry.frame->sequence, entry.frame->timestamp_ns,
                                                 FrameImage::kSegmentLabels, result->labels));
  }
  for (const auto& segment : result->segments) toProto(segment, response->add_segments());
  return grpc::Status::OK;
}

}  // namespace shapesense
