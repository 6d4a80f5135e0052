// EstimateBox latency over loopback gRPC under a steady offered load: several client threads
// together send `rate` requests per second (open loop: each request is sent at its scheduled
// time, whether or not earlier ones have returned), for a fixed duration. Reports latency
// percentiles measured from the scheduled send time, so queueing delay counts.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include <benchmark/benchmark.h>
#include <grpcpp/grpcpp.h>

#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/boxes/segment_box.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/pipeline/stages.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/server/rpc_server.h"
#include "shapesense/v1/shapesense.grpc.pb.h"

namespace shapesense {
namespace {

using Clock = std::chrono::steady_clock;

void BM_EstimateBoxLoopback(benchmark::State& state) {
  const int rate = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const auto duration = std::chrono::seconds(3);

  FrameCache cache;
  SummaryHub hub;
  synthetic::SceneParams params;
  params.render_colour = false;
  const synthetic::SyntheticScene scene(params);
  std::vector<cv::Rect> rois;
  for (int i = 0; i < 30; ++i) {
    auto rendered = scene.render(i, 1'700'000'000'000'000'000LL + i * 33'333'333LL);
    rendered.frame.sequence = i;
    if (i == 0) {
      for (const auto& object : rendered.truth.objects) {
        if (object.pixel_count > 200) rois.push_back(object.image_box);
      }
    }
    cache.insert(std::make_shared<const Frame>(std::move(rendered.frame)));
  }
  RpcServer server("127.0.0.1:0", ServiceContext{.cache = cache, .hub = hub});
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(server.port()),
                                     grpc::InsecureChannelCredentials());
  auto stub = v1::ShapeSense::NewStub(channel);

  std::vector<double> latencies_ms;
  std::atomic<int> failures{0};
  for (auto _ : state) {
    std::vector<std::vector<double>> per_thread(threads);
    const auto start = Clock::now() + std::chrono::milliseconds(50);
    const auto period = std::chrono::nanoseconds(1'000'000'000LL * threads / rate);
    std::vector<std::thread> clients;
    for (int t = 0; t < threads; ++t) {
      clients.emplace_back([&, t] {
        // Thread t sends requests t, t + threads, ... of the global schedule.
        auto due = start + std::chrono::nanoseconds(1'000'000'000LL * t / rate);
        for (int i = 0; due < start + duration; ++i, due += period) {
          std::this_thread::sleep_until(due);
          const cv::Rect r = rois[(i + t) % rois.size()];
          v1::EstimateBoxRequest request;
          request.set_at_ns(1'700'000'000'000'000'000LL + (i % 30) * 33'333'333LL);
          request.mutable_p1()->set_x(r.x);
          request.mutable_p1()->set_y(r.y);
          request.mutable_p2()->set_x(r.x + r.width - 1);
          request.mutable_p2()->set_y(r.y + r.height - 1);
          request.set_mode(v1::BOX_MODE_AXIS_ALIGNED_CONTAINED);
          v1::EstimateBoxResponse response;
          grpc::ClientContext context;
          if (!stub->EstimateBox(&context, request, &response).ok()) ++failures;
          per_thread[t].push_back(
              std::chrono::duration<double, std::milli>(Clock::now() - due).count());
        }
      });
    }
    for (auto& client : clients) client.join();
    for (auto& samples : per_thread)
      latencies_ms.insert(latencies_ms.end(), samples.begin(), samples.end());
  }
  std::sort(latencies_ms.begin(), latencies_ms.end());
  auto quantile = [&](double q) {
    return latencies_ms[std::min(latencies_ms.size() - 1,
                                 static_cast<std::size_t>(q * latencies_ms.size()))];
  };
  state.counters["requests"] = static_cast<double>(latencies_ms.size());
  state.counters["failures"] = failures.load();
  state.counters["p50_ms"] = quantile(0.50);
  state.counters["p99_ms"] = quantile(0.99);
  state.counters["max_ms"] = latencies_ms.back();
  server.shutdown();
}
// The frame of the in-process benchmarks with its object ROIs, largest first.
struct BenchFrame {
  synthetic::RenderedFrame rendered;
  std::vector<cv::Rect> rois;
};

const BenchFrame& benchFrame() {
  static const BenchFrame frame = [] {
    synthetic::SceneParams params;
    params.render_colour = false;
    BenchFrame f{synthetic::SyntheticScene(params).render(0, 0), {}};
    for (const auto& object : f.rendered.truth.objects) {
      if (object.pixel_count > 200) f.rois.push_back(object.image_box);
    }
    std::sort(f.rois.begin(), f.rois.end(),
              [](const cv::Rect& a, const cv::Rect& b) { return a.area() > b.area(); });
    return f;
  }();
  return frame;
}

// The estimate alone, in process, per ROI of the same frame (no gRPC): what each request costs
// the server before serialisation. Argument: index into the frame's object ROIs, largest first.
void BM_EstimateBoxInProcess(benchmark::State& state) {
  const BenchFrame& f = benchFrame();
  const auto index = static_cast<std::size_t>(state.range(0));
  if (index >= f.rois.size()) {
    state.SkipWithError("no such ROI");
    return;
  }
  const cv::Rect r = f.rois[index];
  for (auto _ : state) {
    auto result =
        estimateBox(f.rendered.frame.depth, f.rendered.frame.intrinsics, r.tl(),
                    {r.x + r.width - 1, r.y + r.height - 1}, BoxMode::kAxisAlignedContained);
    benchmark::DoNotOptimize(result);
  }
  state.counters["roi_pixels"] = r.area();
}

// Mode 4 in process on the same ROIs, over the default segmentation and Hough planes of the
// frame (computed once, as the daemon's pipeline computes them before any request).
void BM_EstimateBoxSegmentsInProcess(benchmark::State& state) {
  const BenchFrame& f = benchFrame();
  const auto index = static_cast<std::size_t>(state.range(0));
  if (index >= f.rois.size()) {
    state.SkipWithError("no such ROI");
    return;
  }
  const Frame& frame = f.rendered.frame;
  const DetectorConfig config;
  const PlaneDetection planes =
      HoughPlaneDetector(config.hough_params).detect(frame.depth, frame.intrinsics);
  const SegmentationResult segments =
      segmentFrame(frame, kDefaultSegmentationMethod, config.segmentation_params, &planes);
  const cv::Rect r = f.rois[index];
  for (auto _ : state) {
    auto result = boxFromSegments(frame.depth, frame.intrinsics, r.tl(),
                                  {r.x + r.width - 1, r.y + r.height - 1}, segments.labels,
                                  segments.segments, planes);
    benchmark::DoNotOptimize(result);
  }
  state.counters["roi_pixels"] = r.area();
}
BENCHMARK(BM_EstimateBoxSegmentsInProcess)->DenseRange(0, 2)->Arg(5)->Unit(benchmark::kMicrosecond);

BENCHMARK(BM_EstimateBoxInProcess)->DenseRange(0, 2)->Arg(5)->Unit(benchmark::kMicrosecond);

BENCHMARK(BM_EstimateBoxLoopback)
    ->Args({1000, 4})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace shapesense
