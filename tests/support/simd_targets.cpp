#include "simd_targets.h"

#include <cstdint>

#include <hwy/targets.h>

namespace shapesense::testing {

void forEachSimdTarget(const std::function<void(const std::string& target_name)>& body) {
  for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    body(hwy::TargetName(target));
  }
  hwy::SetSupportedTargetsForTest(0);  // 0: back to what the CPU supports
}

}  // namespace shapesense::testing
