#pragma once
// Runs a test body once per SIMD target this machine can execute and the build compiled
// (Highway's run-time dispatch), so every kernel tier is checked, not only the one dispatch
// would pick. The scalar-equivalent target (EMU128 or SCALAR) is always among them.

#include <functional>
#include <string>

namespace shapesense::testing {

/// Calls body(target_name) with dispatch forced to each attainable target in turn, then
/// restores normal dispatch.
void forEachSimdTarget(const std::function<void(const std::string& target_name)>& body);

}  // namespace shapesense::testing
