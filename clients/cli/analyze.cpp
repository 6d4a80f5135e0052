#include "analyze.h"

#include <fstream>
#include <iostream>

#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/replay_source.h"

namespace shapesense::cli {

double secondsForJson(TimestampNs ns) {
  // Parsing the exact decimal gives the double nearest to it, which JSON prints back as the
  // same short decimal; ns / 1e9 can land one ulp away.
  return std::stod(formatNsAsSeconds(ns, 9));
}

nlohmann::json writeFrameResults(const Frame& frame, const FrameResults& results,
                                 const std::filesystem::path& out) {
  nlohmann::json json;
  const std::string stamp = formatNsAsSeconds(frame.timestamp_ns, 6);
  const auto write_labels = [&](const char* key, const char* suffix, const cv::Mat& labels) {
    const std::string relative = "labels/" + stamp + suffix;
    std::filesystem::create_directories(out / "labels");
    if (!cv::imwrite((out / relative).string(), labels)) {
      throw std::runtime_error("cannot write " + (out / relative).string());
    }
    json[key] = relative;
  };
  if (results.segmentation)
    write_labels("segment_labels", ".segments.png", results.segmentation->labels);
  json["timestamp"] = secondsForJson(frame.timestamp_ns);
  json["planes"] = nlohmann::json::array();
  if (results.planes) {
    for (const auto& plane : results.planes->frame.planes) {
      json["planes"].push_back({{"id", plane.id},
                                {"normal", {plane.normal.x(), plane.normal.y(), plane.normal.z()}},
                                {"d", plane.d},
                                {"pixels", plane.inliers}});
    }
    write_labels("plane_labels", ".planes.png", results.planes->frame.labels);
  }
  json["bowls"] = nlohmann::json::array();
  if (results.bowls) {
    for (const auto& bowl : *results.bowls) {
      const cv::Rect& box = bowl.detection.box;
      nlohmann::json entry = {{"box", {box.x, box.y, box.width, box.height}},
                              {"score", bowl.detection.score},
                              {"view", bowl.detection.view}};
      if (const auto& g = bowl.detection.geometry) {
        entry["rim_diameter_m"] = g->rim_diameter_m;
        entry["height_m"] = g->height_m;
        entry["support_plane_id"] = g->support_plane_id;
      }
      json["bowls"].push_back(std::move(entry));
    }
  }
  nlohmann::json timings = nlohmann::json::object();
  for (const auto& [stage, ms] : results.timings_ms) timings[stage] = ms;
  json["timings_ms"] = timings;
  return json;
}

AnalyzeSummary analyzeRecording(const std::filesystem::path& recording,
                                const std::filesystem::path& out, const DetectorChain& chain,
                                const std::function<void(std::size_t, std::size_t)>& progress) {
  ReplaySource source(recording, ReplayOptions{.pacing = Pacing::kAsFastAsPossible});
  std::filesystem::create_directories(out);
  std::ofstream results_file(out / "results.jsonl");
  if (!results_file) throw std::runtime_error("cannot write " + (out / "results.jsonl").string());
  AnalyzeSummary summary;
  const std::size_t total = source.frameCount();
  std::stop_source never_stopped;
  while (true) {
    SourceEvent event = source.next(never_stopped.get_token());
    if (std::holds_alternative<EndOfStream>(event)) break;
    if (auto* error = std::get_if<SourceError>(&event)) {
      std::cerr << "warning: " << error->message << "\n";
      ++summary.bad_frames;
      continue;
    }
    const Frame& frame = std::get<Frame>(event);
    const FrameResults results = chain.process(frame);
    results_file << writeFrameResults(frame, results, out).dump() << "\n";
    ++summary.frames;
    if (progress) progress(summary.frames + summary.bad_frames, total);
  }
  if (!results_file) throw std::runtime_error("cannot write " + (out / "results.jsonl").string());
  return summary;
}

}  // namespace shapesense::cli
