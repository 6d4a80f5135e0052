#pragma once
// Opens the source a `--source` spec names; the one parser of source specs, shared by the
// daemon and the CLI (`shapesense record --source`).

#include <memory>
#include <string>

#include "shapesense/driver/frame_source.h"

namespace shapesense {

/// Help text listing every spec openSource takes.
inline constexpr const char* kSourceSpecs =
    "synthetic[:SEED], tum:DIR, freenect[:SERIAL|INDEX], openni2[:URI], fakenect:DIR";

/// The source for `spec` ("synthetic[:SEED]", "tum:DIR", "freenect[:SERIAL|INDEX]",
/// "openni2[:URI]", "fakenect:DIR"). Recorded sources play at `pacing` and, with `loop`,
/// start again at the end. Throws std::invalid_argument for an unknown or malformed spec and
/// std::runtime_error when the source cannot be opened, with a message a person can act on.
std::unique_ptr<FrameSource> openSource(const std::string& spec, Pacing pacing, bool loop);

}  // namespace shapesense
