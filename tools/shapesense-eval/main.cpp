// shapesense-eval: the quality of the detectors on a split of the evaluation's scene
// distribution and on the labelled real recordings, as tables. Choose parameters on the
// validation split and on mosd_learn; report the test split, mosd_test and mosd_tabletop.
//
//   shapesense-eval --split validation [--frames 60] [--real DIR ...] [--methods all]
//                   [--recognition-cases N] [--list-recognition-misses]
//
// Planes: the daemon's default Hough detector, SegComp (T = 0.8) against the planar truth by
// the truth plane's share of the image; spurious planes per frame on plain scenes and on scenes
// with curved clutter, and what they cover (eval::PlaneScore); median angle and distance errors of
// the correct planes; correct and spurious by the sensor's disparity noise (the split draws
// 0.04-0.15 px). On real frames: the table found as one plane. Segments: SegComp against the truth
// an operator wants (planar faces apart, curved objects whole) and, on real frames, the objects
// kept apart. Boxes: EstimateBox in mode 2 (the seed's best) and mode 4 (segments) with each
// object's own image bounds as the ROI; the share of the object's visible points inside its box and
// the box's volume over that of the camera-axis box of those points. Recognition (taught objects):
// the split's recognition cases, each object taught through its image box in one view and looked
// for in three others; recall at <= 1 cm and 5 deg where half of it shows, false detections.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "shapesense/core/boxes/segment_box.h"
#include "shapesense/core/geometry/order_statistics.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/pipeline/stages.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/eval/box_eval.h"
#include "shapesense/eval/plane_eval.h"
#include "shapesense/eval/recognition_eval.h"
#include "shapesense/eval/scene_splits.h"
#include "shapesense/eval/segment_eval.h"

using namespace shapesense;

namespace {

// Boxes of the modes compared, by mode number.
using BoxScores = std::map<int, eval::BoxModeScore>;

// The sensor noise bins of the planes' table by noise: the split draws 0.04-0.15 px of
// disparity noise; a Kinect v1 reads 0.05-0.08 px (measured on the real recordings).
constexpr double kSplitNoisePx[] = {0.04, 0.15};  // eval::evalScene's range
constexpr double kNoiseBinEdgesPx[] = {0.075, 0.11};
constexpr int kNoiseBins = std::size(kNoiseBinEdgesPx) + 1;

int noiseBin(double disparity_noise_px) {
  int bin = 0;
  for (const double edge : kNoiseBinEdgesPx) bin += disparity_noise_px >= edge;
  return bin;
}

struct SyntheticResults {
  eval::PlaneScore planes_plain, planes_clutter;
  eval::PlaneScore planes_by_noise[kNoiseBins];
  std::map<SegmentationMethod, SegCompScore> segments;  // summed counts, mean pixel accuracy
  BoxScores boxes;
  int frames = 0;
};

// Objects smaller than this share of the image are not boxed (an operator cannot draw them).
constexpr double kMinBoxedObjectShare = 0.001;

// Scores mode 2 and mode 4 on one object marked by its image bounds.
void scoreObjectBoxes(const Frame& frame, const eval::BoxTarget& target,
                      const SegmentationResult& segments, const PlaneDetection& planes,
                      BoxScores& scores) {
  const cv::Point p1 = target.roi.tl(), p2 = target.roi.br() - cv::Point(1, 1);
  const auto& points = target.points;
  const auto contained =
      estimateBox(frame.depth, frame.intrinsics, p1, p2, BoxMode::kAxisAlignedContained);
  const auto* box2 = std::get_if<BoxEstimate>(&contained);
  scores[2].add(box2 ? &box2->corners : nullptr, points);
  const auto from_segments = boxFromSegments(frame.depth, frame.intrinsics, p1, p2, segments.labels,
                                             segments.segments, planes);
  const auto* box4 = std::get_if<BoxEstimate>(&from_segments);
  scores[4].add(box4 ? &box4->corners : nullptr, points);
}

double quantileOrZero(std::vector<double> values, double q) {
  return values.empty() ? 0.0 : quantile(values, q);
}

void printBoxTable(const BoxScores& scores) {
  std::printf(
      "| mode | objects | no box | mean share of points inside | objects >= 0.95 inside | "
      "volume / points' box, median | p90 | objects >= 0.95 inside with volume <= 1.5 |\n"
      "|---|---|---|---|---|---|---|---|\n");
  for (const auto& [mode, s] : scores) {
    constexpr double kNoVolumeLimit = std::numeric_limits<double>::infinity();
    std::printf("| %d (%s) | %d | %d | %.3f | %.3f | %.2f | %.2f | %.3f |\n", mode,
                toString(static_cast<BoxMode>(mode)), s.objects, s.failed, s.meanCoverage(),
                s.shareMeeting(0.95, kNoVolumeLimit), quantileOrZero(s.volume_ratio, 0.5),
                quantileOrZero(s.volume_ratio, 0.9), s.shareMeeting(0.95, 1.5));
  }
}

const char* outcomeName(SegCompOutcome outcome) {
  switch (outcome) {
    case SegCompOutcome::kCorrect:
      return "correct";
    case SegCompOutcome::kOverSegmented:
      return "split";
    case SegCompOutcome::kUnderSegmented:
      return "merged";
    case SegCompOutcome::kNone:
      break;
  }
  return "missed";
}

// The name of truth region `label` of segmentTruth(truth).
std::string truthRegionName(int label, const synthetic::TruthFrame& truth) {
  if (eval::isCurvedObjectRegion(label, truth)) return "curved object";
  for (const auto& surface : truth.surfaces)
    if (surface.id == label) return surface.name;
  return "?";
}

// One line per truth region the default segmentation does not get right: the frame, the
// surface's name ("curved object" for the one region of an object with a curved surface), its
// pixels and what became of it; then the found region covering most of it: its share of the
// truth region, the truth region's share of it, whether most of it is a detected plane's, and
// the other truth region it holds most of.
void listSegmentMisses(int frame, const cv::Mat& found, const cv::Mat& plane_labels,
                       const synthetic::TruthFrame& truth) {
  const cv::Mat truth_regions = eval::segmentTruth(truth);
  const SegCompScore score = eval::scoreSegments(found, truth_regions);
  // (found, truth) -> pixels; found -> pixels, and pixels on a detected plane.
  std::map<std::pair<int, int>, int> overlap;
  std::map<int, int> found_pixels, found_on_plane;
  for (int v = 0; v < found.rows; ++v)
    for (int u = 0; u < found.cols; ++u) {
      const int f = found.at<std::uint16_t>(v, u), t = truth_regions.at<std::uint16_t>(v, u);
      if (!f || !t) continue;
      ++overlap[{f, t}];
      ++found_pixels[f];
      found_on_plane[f] += plane_labels.at<std::uint16_t>(v, u) != 0;
    }
  for (const SegCompTruthRegion& region : score.truth) {
    if (!region.considered || region.outcome == SegCompOutcome::kCorrect) continue;
    std::printf("frame %3d %-26s %6d px: %-6s", frame, truthRegionName(region.label, truth).c_str(),
                region.pixels, outcomeName(region.outcome));
    int best = 0, best_pixels = 0;
    for (const auto& [key, pixels] : overlap)
      if (key.second == region.label && pixels > best_pixels)
        best = key.first, best_pixels = pixels;
    if (best) {
      int other = 0, other_pixels = 0;
      for (const auto& [key, pixels] : overlap)
        if (key.first == best && key.second != region.label && pixels > other_pixels)
          other = key.second, other_pixels = pixels;
      const double size = found_pixels[best];
      std::printf("  found %.2f of it, it %.2f of found, %s", best_pixels / double(region.pixels),
                  best_pixels / size, found_on_plane[best] >= 0.5 * size ? "plane" : "object");
      if (other)
        std::printf(", with %s %.2f", truthRegionName(other, truth).c_str(), other_pixels / size);
    }
    std::printf("\n");
  }
}

void addSegComp(const SegCompScore& s, SegCompScore& total) {
  total.truth_regions += s.truth_regions;
  total.correct += s.correct;
  total.over_segmented += s.over_segmented;
  total.under_segmented += s.under_segmented;
  total.missed += s.missed;
  total.noise += s.noise;
  total.pixel_accuracy += s.pixel_accuracy;  // divided by the frame count when printed
}

SyntheticResults evaluateSynthetic(eval::Split split, int frames,
                                   const std::vector<SegmentationMethod>& methods,
                                   bool list_segment_misses) {
  const DetectorConfig config;
  HoughPlaneDetector hough(config.hough_params);
  SyntheticResults results;
  for (int i = 0; i < frames; ++i) {
    const eval::EvalScene scene = eval::evalScene(split, i);
    const synthetic::SyntheticScene generator(scene.params);
    const synthetic::RenderedFrame rendered = generator.render(scene.frame_index, 0);
    const PlaneDetection planes = hough.detect(rendered.frame.depth, rendered.frame.intrinsics);
    const eval::PlaneScore score = eval::scorePlanes(planes.labels, planes.planes, rendered.truth);
    (scene.curved_clutter ? results.planes_clutter : results.planes_plain).add(score);
    results.planes_by_noise[noiseBin(scene.params.kinect.disparity_noise_px)].add(score);
    for (const SegmentationMethod m : methods) {
      const SegmentationResult seg =
          segmentFrame(rendered.frame, m, config.segmentation_params, &planes);
      addSegComp(eval::scoreSegments(seg.labels, rendered.truth), results.segments[m]);
    }
    const Frame& frame = rendered.frame;
    const SegmentationResult default_segments =
        segmentFrame(frame, kDefaultSegmentationMethod, config.segmentation_params, &planes);
    if (list_segment_misses)
      listSegmentMisses(i, default_segments.labels, planes.labels, rendered.truth);
    for (const auto& target : eval::syntheticBoxTargets(rendered, kMinBoxedObjectShare))
      scoreObjectBoxes(frame, target, default_segments, planes, results.boxes);
    ++results.frames;
  }
  return results;
}

void printPlaneTable(const char* title, const eval::PlaneScore& s) {
  std::printf(
      "\n%s: %d frames, %d truth planes, correct %.3f, spurious %.2f / frame (%d of %d "
      "reported, %d on curved surfaces)\n",
      title, s.frames, s.truth_regions, s.correctFraction(), s.spuriousPerFrame(), s.spurious,
      s.reported, s.spurious_on_curved);
  std::printf(
      "spurious planes by what they cover: a crease %d, parallel surfaces %d, coplanar "
      "touching surfaces %d, curved surfaces %d, other %d\n",
      s.spurious_across_crease, s.spurious_parallel, s.spurious_coplanar, s.spurious_on_curved,
      s.spurious_other);
  std::printf("| truth plane, share of image | correct | split | merged | missed | n |\n");
  std::printf("|---|---|---|---|---|---|\n");
  const char* bins[] = {"0.5-1%", "1-2%", "2-5%", "5% and more"};
  for (int b = 0; b < eval::kPlaneSizeBins; ++b) {
    const auto& o = s.by_size[b];
    std::printf("| %s | %d | %d | %d | %d | %d |\n", bins[b], o.correct, o.split, o.merged,
                o.missed, o.total());
  }
  std::printf("median error of correct planes: %.2f deg, %.1f mm\n", eval::median(s.angle_deg),
              1e3 * eval::median(s.dist_m));
}

void printSynthetic(eval::Split split, const SyntheticResults& r) {
  std::printf("# Split %s, %d frames\n", std::string(eval::formatSplit(split)).c_str(), r.frames);
  eval::PlaneScore all = r.planes_plain;
  all.add(r.planes_clutter);
  printPlaneTable("Planes, all scenes", all);
  printPlaneTable("Planes, plain scenes", r.planes_plain);
  printPlaneTable("Planes, scenes with curved clutter", r.planes_clutter);
  std::printf("\nPlanes by the sensor's disparity noise:\n");
  std::printf("| noise (px) | frames | truth planes | correct | spurious / frame |\n");
  std::printf("|---|---|---|---|---|\n");
  for (int b = 0; b < kNoiseBins; ++b) {
    const eval::PlaneScore& s = r.planes_by_noise[b];
    const double low = b == 0 ? kSplitNoisePx[0] : kNoiseBinEdgesPx[b - 1];
    const double high = b + 1 == kNoiseBins ? kSplitNoisePx[1] : kNoiseBinEdgesPx[b];
    std::printf("| %.3g-%.3g | %d | %d | %.3f | %.2f |\n", low, high, s.frames, s.truth_regions,
                s.correctFraction(), s.spuriousPerFrame());
  }
  std::printf("\nSegments (planar faces apart, curved objects whole):\n");
  std::printf(
      "| method | correct | split | merged | missed | pixel accuracy "
      "|\n|---|---|---|---|---|---|\n");
  for (const auto& [m, s] : r.segments)
    std::printf("| %s | %.3f | %d | %d | %d | %.3f |\n",
                std::string(formatSegmentationMethod(m)).c_str(),
                s.truth_regions ? double(s.correct) / s.truth_regions : 0.0, s.over_segmented,
                s.under_segmented, s.missed, r.frames ? s.pixel_accuracy / r.frames : 0.0);
  std::printf("\nBoxes (ROI = the object's image bounds; objects of >= %.1f%% of the image):\n",
              100 * kMinBoxedObjectShare);
  printBoxTable(r.boxes);
}

void evaluateReal(const std::filesystem::path& dir,
                  const std::vector<SegmentationMethod>& methods) {
  const std::vector<eval::LabelledFrame> frames = eval::loadLabelledRecording(dir);
  const DetectorConfig config;
  HoughPlaneDetector hough(config.hough_params);
  int table_one_plane = 0;
  std::map<SegmentationMethod, eval::RealSegmentScore> segments;
  BoxScores boxes;
  for (const auto& f : frames) {
    const PlaneDetection planes = hough.detect(f.frame.depth, f.frame.intrinsics);
    table_one_plane += eval::tableCoverage(planes.labels, f.labels, f.frame.depth) >= 0.8;
    const SegmentationResult default_segments =
        segmentFrame(f.frame, kDefaultSegmentationMethod, config.segmentation_params, &planes);
    for (const auto& target : eval::realBoxTargets(f, kMinBoxedObjectShare))
      scoreObjectBoxes(f.frame, target, default_segments, planes, boxes);
    for (const SegmentationMethod m : methods)
      segments[m].add(eval::scoreRealSegments(
          segmentFrame(f.frame, m, config.segmentation_params, &planes).labels, f.labels,
          f.frame.depth));
  }
  std::printf("\n# Real: %s, %zu labelled frames; table as one plane in %d of %zu\n",
              dir.filename().string().c_str(), frames.size(), table_one_plane, frames.size());
  std::printf("| method | objects kept apart | table one region |\n|---|---|---|\n");
  for (const auto& [m, s] : segments)
    std::printf("| %s | %.3f (%d of %d) | %d of %d |\n",
                std::string(formatSegmentationMethod(m)).c_str(), s.keptApartFraction(),
                s.kept_apart, s.objects, s.table_whole, s.frames);
  std::printf("\nBoxes of the labelled objects (ROI = the object's label bounds):\n");
  printBoxTable(boxes);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "shapesense-eval: detector quality on a split of the scene distribution and on "
      "labelled real recordings"};
  std::string split_name = "validation";
  int frames = 60;
  std::vector<std::string> real_dirs;
  std::vector<std::string> method_names = {"all"};
  app.add_option("--split", split_name, "train, validation or test")->capture_default_str();
  app.add_option("--frames", frames, "synthetic frames of the split (0 = none)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  app.add_option("--real", real_dirs, "labelled recordings (OSD layout, labels/)");
  app.add_option("--methods", method_names, "segmentation methods, or all")->capture_default_str();
  int recognition_cases = 0;
  app.add_option("--recognition-cases", recognition_cases,
                 "taught-object recognition cases of the split (0 = none)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  bool list_recognition_misses = false;
  app.add_flag("--list-recognition-misses", list_recognition_misses,
               "print each object of the recognition cases that was not found within the "
               "tolerance, and what the check says of its truth pose and of the wrong pose "
               "reported, with its figures");
  bool list_segment_misses = false;
  app.add_flag("--list-segment-misses", list_segment_misses,
               "print each truth region the default segmentation splits, merges or misses, "
               "and the found region covering most of it");
  CLI11_PARSE(app, argc, argv);

  const auto split = eval::parseSplit(split_name);
  if (!split) {
    std::fprintf(stderr, "unknown split '%s' (train, validation or test)\n", split_name.c_str());
    return 2;
  }
  std::vector<SegmentationMethod> methods;
  for (const auto& name : method_names) {
    if (name == "all") {
      methods.assign(kSegmentationMethods.begin(), kSegmentationMethods.end());
      continue;
    }
    const auto m = parseSegmentationMethod(name);
    if (!m) {
      std::fprintf(stderr, "unknown method '%s' (%s)\n", name.c_str(),
                   listSegmentationMethods().c_str());
      return 2;
    }
    methods.push_back(*m);
  }
  try {
    if (frames > 0)
      printSynthetic(*split, evaluateSynthetic(*split, frames, methods, list_segment_misses));
    for (const auto& dir : real_dirs) evaluateReal(dir, methods);
    if (recognition_cases > 0) {
      const auto score = eval::scoreRecognition(*split, 0, recognition_cases);
      if (list_recognition_misses) std::printf("%s", eval::formatRecognitionMisses(score).c_str());
      std::printf("%s\n", eval::formatRecognitionScore(
                              "recognition, " + std::string(eval::formatSplit(*split)), score)
                              .c_str());
      std::printf("%s\n", eval::formatRecallByKind(score).c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "shapesense-eval: %s\n", e.what());
    return 1;
  }
  return 0;
}
