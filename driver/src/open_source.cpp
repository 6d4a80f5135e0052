#include "shapesense/driver/open_source.h"

#include <stdexcept>

#include "shapesense/driver/live_sources.h"
#include "shapesense/driver/replay_source.h"
#include "shapesense/driver/synthetic_source.h"

namespace shapesense {

std::unique_ptr<FrameSource> openSource(const std::string& spec, Pacing pacing, bool loop) {
  const auto colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  const std::string argument = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (kind == "synthetic") {
    synthetic::SyntheticSourceOptions synthetic_options;
    synthetic_options.pacing = pacing;
    if (!argument.empty()) {
      try {
        std::size_t used = 0;
        synthetic_options.scene.seed = std::stoull(argument, &used);
        if (used != argument.size()) throw std::invalid_argument(argument);
      } catch (const std::exception&) {
        throw std::invalid_argument("--source synthetic:SEED needs a whole number, got '" +
                                    argument + "'");
      }
    }
    return std::make_unique<synthetic::SyntheticSource>(synthetic_options);
  }
  if (kind == "tum") {
    if (argument.empty())
      throw std::invalid_argument("--source tum:DIR needs a recording directory");
    return std::make_unique<ReplaySource>(argument, ReplayOptions{.pacing = pacing, .loop = loop});
  }
  if (auto live = openLiveSource(kind, argument)) return live;
  throw std::invalid_argument("unknown source '" + spec + "': use " + std::string(kSourceSpecs));
}

}  // namespace shapesense
