#pragma once
// `shapesense analyze`: the daemon's detector chain over a recording, offline, into
// DIR/results.jsonl. One JSON object per depth frame, in frame order:
//   {"timestamp": <seconds as in depth.txt, a number>,
//    "planes": [{"id": k, "normal": [nx, ny, nz], "d": d, "pixels": n}, ...],
//    "plane_labels": "<uint16 PNG relative to DIR, 0 = no plane, else the plane's id>",
//    "segment_labels": "<same for segments>",
//    "bowls": [{"box": [x, y, w, h], "score": s, "view": "top|middle|side"}],  // highest score
//    first "timings_ms": {"<stage>": ms}}
// Planes satisfy n.X + d = 0 in the camera frame, unit n towards the camera, d > 0 metres.
// Fields of detectors that are not part of the chain are empty lists or absent. Frames the
// recording cannot deliver (bad files) are reported on stderr and left out.

#include <cstddef>
#include <filesystem>
#include <functional>

#include <nlohmann/json.hpp>

#include "shapesense/core/pipeline/detector_chain.h"

namespace shapesense::cli {

struct AnalyzeSummary {
  std::size_t frames = 0;      ///< lines written
  std::size_t bad_frames = 0;  ///< frames the recording could not deliver
};

/// Runs `chain` over every frame of the TUM recording in `recording` and writes
/// `out`/results.jsonl (and label images beside it). `progress(done, total)` is called per frame.
AnalyzeSummary analyzeRecording(const std::filesystem::path& recording,
                                const std::filesystem::path& out, const DetectorChain& chain,
                                const std::function<void(std::size_t, std::size_t)>& progress = {});

/// The results.jsonl object of one frame. Label images are written under `out`/labels/ and
/// named in the object by their path relative to `out`.
nlohmann::json writeFrameResults(const Frame& frame, const FrameResults& results,
                                 const std::filesystem::path& out);

/// Seconds as a JSON number that prints as the shortest decimal of `ns` (1600000000.033333,
/// not 1600000000.0333331).
double secondsForJson(TimestampNs ns);

}  // namespace shapesense::cli
