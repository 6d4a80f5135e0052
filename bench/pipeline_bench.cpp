// Frames per second through the daemon's pipeline (source -> cache -> detector thread) with
// no detector stages, for a replayed recording and the synthetic source.

#include <benchmark/benchmark.h>

#include "shapesense/driver/replay_source.h"
#include "shapesense/driver/synthetic_source.h"
#include "shapesense/server/pipeline.h"

namespace shapesense {
namespace {

/// Ends another source after `limit` frames so a run has a fixed length.
class LimitedSource : public FrameSource {
 public:
  LimitedSource(std::unique_ptr<FrameSource> inner, std::uint64_t limit)
      : inner_(std::move(inner)), limit_(limit) {}
  std::string describe() const override { return inner_->describe(); }
  SourceEvent next(std::stop_token stop) override {
    if (delivered_ == limit_) return EndOfStream{};
    auto event = inner_->next(stop);
    if (std::holds_alternative<Frame>(event)) ++delivered_;
    return event;
  }

 private:
  std::unique_ptr<FrameSource> inner_;
  std::uint64_t limit_;
  std::uint64_t delivered_ = 0;
};

void runPipeline(benchmark::State& state,
                 const std::function<std::unique_ptr<FrameSource>()>& make) {
  const std::uint64_t frames = static_cast<std::uint64_t>(state.range(0));
  for (auto _ : state) {
    FrameCache cache;
    SummaryHub hub;
    Pipeline pipeline(std::make_unique<LimitedSource>(make(), frames), DetectorChain{}, cache, hub);
    pipeline.start();
    pipeline.waitUntilDrained(std::chrono::minutes(5));
    pipeline.stop();
    benchmark::DoNotOptimize(cache.range());
  }
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(frames * state.iterations()),
                                                  benchmark::Counter::kIsRate);
}

void BM_PipelineReplay(benchmark::State& state) {
  const std::string dir = std::string(SHAPESENSE_SHARED_DIR) + "/data/real/mosd_tabletop";
  runPipeline(state, [&] {
    return std::make_unique<ReplaySource>(
        dir, ReplayOptions{.pacing = Pacing::kAsFastAsPossible, .loop = true});
  });
}
BENCHMARK(BM_PipelineReplay)->Arg(120)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_PipelineSynthetic(benchmark::State& state) {
  runPipeline(state, [] {
    synthetic::SyntheticSourceOptions options;
    options.pacing = Pacing::kAsFastAsPossible;
    return std::make_unique<synthetic::SyntheticSource>(options);
  });
}
BENCHMARK(BM_PipelineSynthetic)->Arg(120)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace shapesense
