// The scene model on a thin link (issue 19): bytes of a full SceneUpdate, of the deltas that
// follow it, and of a 320x240 JPEG preview, over frames of the synthetic table-top scene and of
// real recordings processed by the standard chain; and the time to build each.
//
//   build/bench/scene_bench --benchmark_counters_tabular=true

#include <algorithm>
#include <filesystem>
#include <map>

#include <benchmark/benchmark.h>

#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/driver/replay_source.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/server/scene_update.h"

namespace shapesense {
namespace {

constexpr int kFrames = 60;
constexpr std::size_t kRawFrameBytes = 640 * 480 * (2 + 3);

/// Frames of a source with the standard chain's results, computed once per source.
std::vector<CachedFrame> processedFrames(const std::string& source) {
  std::vector<Frame> frames;
  if (source == "synthetic") {
    synthetic::SyntheticScene scene(synthetic::SceneParams{});
    for (int i = 0; i < kFrames; ++i) {
      frames.push_back(scene.render(static_cast<std::uint64_t>(i), (i + 1) * 33'333'333LL).frame);
    }
  } else {
    const auto dir = std::filesystem::path(SHAPESENSE_SHARED_DIR) / "data/real" / source;
    ReplaySource replay(dir, ReplayOptions{.pacing = Pacing::kAsFastAsPossible, .loop = true});
    while (static_cast<int>(frames.size()) < kFrames) {
      auto event = replay.next({});
      if (auto* frame = std::get_if<Frame>(&event)) {
        frames.push_back(std::move(*frame));
      } else if (!std::holds_alternative<SourceError>(event)) {
        break;
      }
    }
  }
  const DetectorChain chain = makeDetectorChain(DetectorConfig{});
  std::vector<CachedFrame> processed;
  for (auto& frame : frames) {
    auto shared = std::make_shared<const Frame>(std::move(frame));
    processed.push_back({shared, std::make_shared<const FrameResults>(chain.process(*shared))});
  }
  return processed;
}

const std::vector<CachedFrame>& framesOf(const std::string& source) {
  static std::map<std::string, std::vector<CachedFrame>> cache;
  auto it = cache.find(source);
  if (it == cache.end()) it = cache.emplace(source, processedFrames(source)).first;
  return it->second;
}

const std::vector<std::string> kSources = {"synthetic", "mosd_tabletop", "pcl_tabletop_milk",
                                           "pcl_room_sweep"};

void BM_SceneUpdates(benchmark::State& state) {
  const auto& frames = framesOf(kSources[static_cast<std::size_t>(state.range(0))]);
  state.SetLabel(kSources[static_cast<std::size_t>(state.range(0))]);
  std::vector<double> full_bytes, delta_bytes, planes, objects;
  for (auto _ : state) {
    SceneDelta delta;
    full_bytes.clear();
    delta_bytes.clear();
    for (const auto& entry : frames) {
      v1::SceneUpdate update;
      if (!fillScene(entry, "0123456789abcdef0123456789abcdef", update).ok()) continue;
      full_bytes.push_back(static_cast<double>(update.ByteSizeLong()));
      planes.push_back(update.planes_size());
      objects.push_back(update.objects_size());
      delta.reduce(update, false);
      delta_bytes.push_back(static_cast<double>(update.ByteSizeLong()));
    }
  }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  state.counters["full_B_median"] = median(full_bytes);
  state.counters["full_B_max"] = *std::max_element(full_bytes.begin(), full_bytes.end());
  state.counters["full_%raw_max"] = 100.0 * state.counters["full_B_max"] / kRawFrameBytes;
  state.counters["delta_B_median"] = median({delta_bytes.begin() + 1, delta_bytes.end()});
  state.counters["planes_median"] = median(planes);
  state.counters["things_median"] = median(objects);
}
BENCHMARK(BM_SceneUpdates)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

void BM_ScenePreview(benchmark::State& state) {
  const auto& frames = framesOf(kSources[static_cast<std::size_t>(state.range(0))]);
  const bool depth = state.range(1) == 1;
  state.SetLabel(kSources[static_cast<std::size_t>(state.range(0))] +
                 (depth ? " depth" : " colour"));
  PreviewOptions options;
  options.kind = depth ? v1::PreviewRequest::DEPTH : v1::PreviewRequest::COLOUR;
  std::vector<double> bytes;
  std::size_t i = 0;
  for (auto _ : state) {
    v1::SceneUpdate update;
    addPreview(*frames[i++ % frames.size()].frame, options, update);
    bytes.push_back(static_cast<double>(update.preview_jpeg().size()));
  }
  std::sort(bytes.begin(), bytes.end());
  state.counters["jpeg_B_median"] = bytes[bytes.size() / 2];
  state.counters["jpeg_B_max"] = bytes.back();
}
BENCHMARK(BM_ScenePreview)->ArgsProduct({{0, 1, 2, 3}, {0, 1}})->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace shapesense
