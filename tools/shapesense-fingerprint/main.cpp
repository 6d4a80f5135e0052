// shapesense-fingerprint: bit-exact hashes of everything the detectors output on a fixed set of
// frames, one line per (stage, frame) and one total per stage. A structural change to core/ that
// must not change behaviour is checked by running this before and after and diffing the output.
//
//   shapesense-fingerprint [--real DIR] [--synthetic-seeds N] [--per-frame]
//
// Stages hashed: normals (each method), segmentation labels and statistics (each method), Hough
// and RANSAC planes (labels and every field, the accumulated tracks too), object boxes, bowls
// (detections, geometry, boxes) and EstimateBox in each mode on fixed ROIs.

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/normals/normals.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/driver/replay_source.h"
#include "shapesense/driver/synthetic_scene.h"

namespace fs = std::filesystem;
using namespace shapesense;

namespace {

/// FNV-1a over the exact bytes of what is fed, so any change of a bit shows.
class Fnv {
 public:
  void bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) {
      hash_ ^= p[i];
      hash_ *= 0x100000001b3ULL;
    }
  }
  template <typename T>
  requires std::is_arithmetic_v<T>
  void add(T value) { bytes(&value, sizeof value); }
  void add(const Eigen::Vector3d& v) {
    for (int i = 0; i < 3; ++i) add(v[i]);
  }
  void add(const cv::Rect& r) { add(r.x), add(r.y), add(r.width), add(r.height); }
  void add(const std::string& s) {
    add(s.size());
    bytes(s.data(), s.size());
  }
  void add(const cv::Mat& m) {
    add(m.rows), add(m.cols), add(m.type());
    if (m.empty()) return;
    const cv::Mat c = m.isContinuous() ? m : m.clone();
    // NaN payloads can differ without meaning anything: hash every NaN as one pattern.
    if (c.depth() == CV_32F) {
      const float* f = c.ptr<float>();
      for (std::size_t i = 0; i < c.total() * c.channels(); ++i) add(std::isnan(f[i]) ? NAN : f[i]);
      return;
    }
    bytes(c.data, c.total() * c.elemSize());
  }
  std::uint64_t value() const { return hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

void addPlane(Fnv& h, const DetectedPlane& p) {
  h.add(p.id), h.add(p.group), h.add(p.normal), h.add(p.d), h.add(p.inliers), h.add(p.rms_m);
  h.add(p.box);
  for (const auto& v : p.polygon) h.add(v);
  for (const auto& t : p.triangles) h.add(t[0]), h.add(t[1]), h.add(t[2]);
  if (p.mean_bgr) h.add((*p.mean_bgr)[0]), h.add((*p.mean_bgr)[1]), h.add((*p.mean_bgr)[2]);
}

void addBox(Fnv& h, const BoxEstimate& b) {
  for (const auto& c : b.corners) h.add(c);
  h.add(b.stats.valid_pixels), h.add(b.stats.used_pixels), h.add(b.stats.mean_m);
  h.add(b.stats.std_m), h.add(b.stats.median_m), h.add(b.stats.min_m), h.add(b.stats.max_m);
  h.add(b.stats.near_m);
  h.add(static_cast<int>(b.mode)), h.add(b.collapsed_x), h.add(b.collapsed_y);
}

void addResults(std::map<std::string, Fnv>& stages, const std::string& prefix,
                const FrameResults& r) {
  if (r.segmentation) {
    Fnv& h = stages[prefix + "segments"];
    h.add(r.segmentation->labels);
    for (const auto& s : r.segmentation->segments) {
      h.add(s.id), h.add(s.pixels), h.add(s.centroid), h.add(s.mean_normal), h.add(s.plane_rms_m);
      h.add(s.box);
    }
  }
  if (r.planes) {
    Fnv& h = stages[prefix + "planes." + r.planes->detector];
    h.add(r.planes->frame.labels);
    for (const auto& p : r.planes->frame.planes) addPlane(h, p);
    Fnv& tracks = stages[prefix + "plane_tracks." + r.planes->detector];
    for (const auto& p : r.planes->accumulated) addPlane(tracks, p);
  }
  if (r.segmentation && r.planes) {
    Fnv& boxes = stages[prefix + "object_boxes"];
    for (const auto& b : r.object_boxes) {
      boxes.add(b.segment_id), boxes.add(b.support_plane_id), boxes.add(b.roi);
      addBox(boxes, b.box);
    }
  }
  if (r.bowls) {
    Fnv& h = stages[prefix + "bowls"];
    for (const auto& b : *r.bowls) {
      h.add(b.detection.box), h.add(b.detection.score), h.add(b.detection.view);
      if (const auto& g = b.detection.geometry) {
        h.add(g->rim_diameter_m), h.add(g->height_m), h.add(g->top_m), h.add(g->rim_to_foot_width);
        h.add(g->dish_depth), h.add(g->support_normal), h.add(g->support_d);
        h.add(g->support_plane_id);
      }
      if (b.box) addBox(h, *b.box);
    }
  }
}

/// The chains hashed: the daemon's default (kDefaultSegmentationMethod, Hough planes, boxes,
/// bowls), every other segmentation method, and RANSAC planes.
std::vector<std::pair<std::string, DetectorChain>> makeChains() {
  std::vector<std::pair<std::string, DetectorChain>> chains;
  DetectorConfig config;
  chains.emplace_back("default.", makeDetectorChain(config));
  for (auto method : kSegmentationMethods) {
    if (method == kDefaultSegmentationMethod) continue;
    DetectorConfig c;
    c.segmentation = method;
    c.planes.reset();
    c.bowls = false;
    chains.emplace_back(std::string(formatSegmentationMethod(method)) + ".", makeDetectorChain(c));
  }
  DetectorConfig ransac;
  ransac.segmentation.reset();
  ransac.planes = PlaneDetectorKind::kRansac;
  ransac.bowls = false;
  chains.emplace_back("ransac.", makeDetectorChain(ransac));
  return chains;
}

void addFrameOnlyStages(std::map<std::string, Fnv>& stages, const Frame& frame) {
  for (auto [name, method] : {std::pair{"covariance", NormalMethod::kCovariance},
                              std::pair{"gradient", NormalMethod::kAverage3dGradient},
                              std::pair{"depth_change", NormalMethod::kAverageDepthChange}}) {
    NormalParams params;
    params.method = method;
    stages[std::string("normals.") + name].add(
        computeNormals(frame.depth, frame.intrinsics, params));
  }
  const int w = frame.depth.cols, h = frame.depth.rows;
  const std::vector<std::pair<cv::Point, cv::Point>> rois = {{{w / 4, h / 4}, {w / 2, h / 2}},
                                                             {{w / 3, h / 2}, {2 * w / 3, h - 10}},
                                                             {{10, 10}, {w - 10, h - 10}}};
  for (auto mode :
       {BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained, BoxMode::kAxisAlignedFrontFace}) {
    Fnv& hash = stages[std::string("estimate_box.") + toString(mode)];
    for (const auto& [p1, p2] : rois) {
      const auto result = estimateBox(frame.depth, frame.intrinsics, p1, p2, mode);
      if (const auto* box = std::get_if<BoxEstimate>(&result)) {
        addBox(hash, *box);
      } else {
        hash.add(static_cast<int>(std::get<BoxEstimationFailure>(result).code));
      }
    }
  }
}

struct Totals {
  std::map<std::string, Fnv> per_stage;
  bool per_frame = false;
};

void hashFrame(Totals& totals, const std::string& label, const Frame& frame,
               std::vector<std::pair<std::string, DetectorChain>>& chains) {
  std::map<std::string, Fnv> stages;
  addFrameOnlyStages(stages, frame);
  for (auto& [prefix, chain] : chains) addResults(stages, prefix, chain.process(frame));
  for (auto& [stage, hash] : stages) {
    const std::uint64_t v = hash.value();
    totals.per_stage[stage].add(v);
    if (totals.per_frame) {
      std::cout << stage << ' ' << label << ' ' << std::hex << std::setw(16) << std::setfill('0')
                << v << std::dec << '\n';
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Bit-exact hashes of every detector output on a fixed set of frames"};
  std::vector<std::string> real_dirs;
  int synthetic_seeds = 6;
  int synthetic_frames = 3;
  Totals totals;
  app.add_option("--real", real_dirs, "TUM-layout recordings to hash (every frame)");
  app.add_option("--synthetic-seeds", synthetic_seeds, "synthetic scenes (seeds 1..N)")
      ->capture_default_str();
  app.add_option("--synthetic-frames", synthetic_frames, "frames of each synthetic scene")
      ->capture_default_str();
  app.add_flag("--per-frame", totals.per_frame, "also print each frame's hash per stage");
  CLI11_PARSE(app, argc, argv);

  try {
    for (int seed = 1; seed <= synthetic_seeds; ++seed) {
      auto chains = makeChains();  // fresh accumulators per sequence
      synthetic::SceneParams params;
      params.seed = static_cast<std::uint64_t>(seed);
      const synthetic::SyntheticScene scene(params);
      for (int i = 0; i < synthetic_frames; ++i) {
        const auto rendered = scene.render(static_cast<std::uint64_t>(i), (i + 1) * 33'333'333LL);
        hashFrame(totals, "synthetic:" + std::to_string(seed) + ":" + std::to_string(i),
                  rendered.frame, chains);
      }
    }
    for (const auto& dir : real_dirs) {
      auto chains = makeChains();
      ReplaySource source(dir, ReplayOptions{.pacing = Pacing::kAsFastAsPossible});
      std::stop_source never;
      for (int i = 0;; ++i) {
        SourceEvent event = source.next(never.get_token());
        if (std::holds_alternative<EndOfStream>(event)) break;
        if (const auto* error = std::get_if<SourceError>(&event)) {
          std::cerr << "warning: " << error->message << "\n";
          continue;
        }
        hashFrame(totals, fs::path(dir).filename().string() + ":" + std::to_string(i),
                  std::get<Frame>(event), chains);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "shapesense-fingerprint: " << e.what() << "\n";
    return 1;
  }
  for (auto& [stage, hash] : totals.per_stage) {
    std::cout << "total " << stage << ' ' << std::hex << std::setw(16) << std::setfill('0')
              << hash.value() << std::dec << '\n';
  }
  return 0;
}
