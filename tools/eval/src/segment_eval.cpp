#include "shapesense/eval/segment_eval.h"

#include <algorithm>
#include <map>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "shapesense/driver/tum_recording.h"

namespace shapesense::eval {
namespace {

constexpr double kOverlap = 0.8;
constexpr double kMinTruthFraction = 0.005;
constexpr double kObjectCoverage = 0.8;
constexpr double kForeignShare = 0.2;
constexpr double kTableWhole = 0.8;

bool isCurvedObjectKind(const std::string& kind) {
  for (const char* curved :
       {"bowl", "cup", "tin", "ball", "bin", "column", "torus", "mound", "lid"})
    if (kind == curved) return true;
  return false;
}

// The first label after every surface id: curved objects' regions take labels from it on, so
// the two never collide.
std::uint16_t firstObjectRegion(const synthetic::TruthFrame& truth) {
  std::uint16_t next = 1;
  for (const auto& s : truth.surfaces) next = std::max<std::uint16_t>(next, s.id + 1);
  return next;
}

}  // namespace

int osdOwner(int label) {
  if (label >= 1 && label <= 9) return -1;
  return label >= 20 ? label / 10 : 0;
}

bool isCurvedObjectRegion(int label, const synthetic::TruthFrame& truth) {
  return label >= firstObjectRegion(truth);
}

cv::Mat segmentTruth(const synthetic::TruthFrame& truth) {
  std::uint16_t next = firstObjectRegion(truth);
  std::map<std::uint16_t, std::uint16_t> object_region;
  for (const auto& o : truth.objects)
    if (isCurvedObjectKind(o.kind)) object_region[o.id] = next++;
  std::vector<std::uint16_t> region_of_surface(65536, 0);
  for (const auto& s : truth.surfaces) {
    const auto it = object_region.find(s.object_id);
    region_of_surface[s.id] = it != object_region.end() ? it->second : s.id;
  }
  cv::Mat out(truth.surface_labels.size(), CV_16UC1);
  for (int v = 0; v < out.rows; ++v) {
    const auto* in = truth.surface_labels.ptr<std::uint16_t>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    for (int u = 0; u < out.cols; ++u) o[u] = region_of_surface[in[u]];
  }
  return out;
}

SegCompScore scoreSegments(const cv::Mat& regions, const synthetic::TruthFrame& truth) {
  return scoreSegments(regions, segmentTruth(truth));
}

SegCompScore scoreSegments(const cv::Mat& regions, const cv::Mat& truth_regions) {
  return scoreSegmentation(regions, truth_regions, kOverlap, kMinTruthFraction);
}

std::vector<LabelledFrame> loadLabelledRecording(const std::filesystem::path& dir) {
  const TumIndex index = readTumIndex(dir);
  std::vector<LabelledFrame> frames;
  for (const auto& entry : index.depth) {
    const std::string name = entry.relative_path.filename().string();
    const cv::Mat labels = cv::imread((dir / "labels" / name).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat raw = cv::imread((dir / entry.relative_path).string(), cv::IMREAD_UNCHANGED);
    if (labels.empty() || raw.empty() || labels.type() != CV_16UC1 || raw.type() != CV_16UC1 ||
        labels.size() != raw.size())
      continue;
    LabelledFrame f;
    f.name = name;
    raw.convertTo(f.frame.depth, CV_16UC1, 1000.0 / index.camera.depth_scale);
    f.frame.intrinsics = index.camera.intrinsics;
    f.frame.timestamp_ns = entry.timestamp_ns;
    f.labels = labels;
    frames.push_back(std::move(f));
  }
  if (frames.empty()) throw std::runtime_error("no labelled frame in " + dir.string());
  return frames;
}

void RealSegmentScore::add(const RealSegmentScore& o) {
  frames += o.frames;
  objects += o.objects;
  kept_apart += o.kept_apart;
  table_whole += o.table_whole;
}

RealSegmentScore scoreRealSegments(const cv::Mat& regions, const cv::Mat& labels,
                                   const cv::Mat& depth_mm) {
  CV_Assert(regions.type() == CV_16UC1 && labels.type() == CV_16UC1 && depth_mm.type() == CV_16UC1);
  CV_Assert(regions.size() == labels.size() && regions.size() == depth_mm.size());
  std::map<int, int> owner_pixels;                 // owner -> pixels with depth
  std::map<int, std::map<int, int>> region_owner;  // region -> owner -> pixels
  std::map<int, int> region_pixels;                // region -> labelled pixels with depth
  for (int v = 0; v < labels.rows; ++v)
    for (int u = 0; u < labels.cols; ++u) {
      if (!depth_mm.at<std::uint16_t>(v, u)) continue;
      const int owner = osdOwner(labels.at<std::uint16_t>(v, u));
      if (!owner) continue;
      ++owner_pixels[owner];
      if (const int r = regions.at<std::uint16_t>(v, u)) {
        ++region_owner[r][owner];
        ++region_pixels[r];
      }
    }
  RealSegmentScore s;
  s.frames = 1;
  for (const auto& [owner, pixels] : owner_pixels) {
    if (owner < 0) continue;
    ++s.objects;
    int covered = 0;
    bool holds_foreign = false;
    for (const auto& [r, by_owner] : region_owner) {
      const auto it = by_owner.find(owner);
      if (it == by_owner.end() || 2 * it->second <= region_pixels[r]) continue;
      covered += it->second;
      for (const auto& [other, n] : by_owner)
        if (other != owner && n >= kForeignShare * owner_pixels[other]) holds_foreign = true;
    }
    if (covered >= kObjectCoverage * pixels && !holds_foreign) ++s.kept_apart;
  }
  s.table_whole = tableCoverage(regions, labels, depth_mm) >= kTableWhole ? 1 : 0;
  return s;
}

double tableCoverage(const cv::Mat& regions, const cv::Mat& labels, const cv::Mat& depth_mm) {
  CV_Assert(regions.type() == CV_16UC1 && labels.type() == CV_16UC1 && depth_mm.type() == CV_16UC1);
  CV_Assert(regions.size() == labels.size() && regions.size() == depth_mm.size());
  std::map<int, int> overlap;
  int table = 0;
  for (int v = 0; v < regions.rows; ++v)
    for (int u = 0; u < regions.cols; ++u) {
      if (osdOwner(labels.at<std::uint16_t>(v, u)) != -1 || !depth_mm.at<std::uint16_t>(v, u))
        continue;
      ++table;
      if (const int id = regions.at<std::uint16_t>(v, u)) ++overlap[id];
    }
  int best = 0;
  for (const auto& [id, count] : overlap) best = std::max(best, count);
  return table ? static_cast<double>(best) / table : 0.0;
}

}  // namespace shapesense::eval
