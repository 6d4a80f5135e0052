// shapesense-plane-diag: why the Hough plane detector misses truth planes, on frames of the
// evaluation's scene splits (tools/eval scene_splits.h). For each missed truth plane it prints its
// name, size, range and obliquity, and the found regions that overlap it (fraction of the truth
// region, fraction of the found region, and the truth plane the found region mostly covers),
// then a count of the misses by cause: mostly unlabelled, taken by a plane of another surface,
// or found only in part. With --spurious it lists the reported planes that lie on no one truth
// plane and the surfaces they cover; with --part-residuals, for a plane found in part, where its
// unlabelled pixels lie against the found plane; with --dump-frame the depth and the truth and
// found labels of one frame (planes, and the default segmentation's segments) are written as
// images into --out. Detector parameters can be changed for experiments.
//
//   shapesense-plane-diag [--split validation] [--frames N] [--max-share S] [--quiet]
//                         [--spurious] [--part-residuals] [--dump-frame I --out DIR]
//                         [--leftover-agreement DEG ...]

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/geometry/units.h"
#include "shapesense/core/pipeline/stages.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/plane_eval.h"
#include "shapesense/eval/scene_splits.h"
#include "shapesense/eval/segment_eval.h"

using namespace shapesense;

namespace {

// Pixel counts of truth regions, found regions and each (truth, found) overlap of one frame.
struct Overlaps {
  std::map<int, long> truth_size, found_size;
  std::map<std::pair<int, int>, long> overlap;
};

Overlaps overlapsOf(const cv::Mat& planar_truth, const cv::Mat& labels) {
  Overlaps o;
  for (int v = 0; v < planar_truth.rows; ++v)
    for (int u = 0; u < planar_truth.cols; ++u) {
      const int tl = planar_truth.at<std::uint16_t>(v, u), fl = labels.at<std::uint16_t>(v, u);
      if (fl) ++o.found_size[fl];
      if (!tl) continue;
      ++o.truth_size[tl];
      ++o.overlap[{tl, fl}];
    }
  return o;
}

// Mean range and the angle between the mean line of sight and the plane's normal, over the
// truth plane's pixels.
std::pair<double, double> rangeAndObliquity(const synthetic::TruthFrame& truth, int id,
                                            const CameraIntrinsics& K, const Eigen::Vector3d& n) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  long count = 0;
  for (int v = 0; v < truth.surface_labels.rows; ++v)
    for (int u = 0; u < truth.surface_labels.cols; ++u) {
      if (truth.surface_labels.at<std::uint16_t>(v, u) != id) continue;
      const double z = truth.ideal_depth.at<float>(v, u);
      sum += Eigen::Vector3d((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
      ++count;
    }
  const Eigen::Vector3d mean = sum / std::max(1L, count);
  const double cosine = std::abs(mean.normalized().dot(n));
  return {mean.norm(), angleDegOfCosine(cosine)};
}

enum Cause { kUnlabelled, kTakenByOther, kPartial, kCauses };
const char* const kCauseNames[] = {"mostly unlabelled", "taken by another surface's plane",
                                   "found in part"};

// A miss's cause, and the found plane that covers most of the truth plane (0: none).
struct Miss {
  Cause cause;
  int most_found;
};

// Prints the found regions covering >= 5% of truth plane `id` and returns the miss.
Miss explainMiss(int id, const Overlaps& o, const PlaneDetection& out, bool quiet) {
  const long size = o.truth_size.at(id);
  long unlabelled = 0, best_px = 0;
  int best_main = 0, best_found = 0;
  for (const auto& [key, px] : o.overlap) {
    if (key.first != id) continue;
    if (key.second == 0) {
      unlabelled = px;
      if (!quiet && px >= 0.05 * size) std::printf(" [unlabelled %.2f]", double(px) / size);
      continue;
    }
    int main_truth = 0;
    long main_px = 0;
    for (const auto& [k2, px2] : o.overlap)
      if (k2.second == key.second && px2 > main_px) main_px = px2, main_truth = k2.first;
    if (px > best_px) best_px = px, best_main = main_truth, best_found = key.second;
    if (quiet || px < 0.05 * size) continue;
    const DetectedPlane& fp = out.planes[key.second - 1];
    std::printf(" [found %d (rms %.1f mm, %zu px): %.2f of truth, %.2f of found, mostly %d]",
                key.second, 1000 * fp.rms_m, fp.inliers, double(px) / size,
                double(px) / o.found_size.at(key.second), main_truth == id ? 0 : main_truth);
  }
  if (unlabelled >= best_px) return {kUnlabelled, best_found};
  return {best_main == id ? kPartial : kTakenByOther, best_found};
}

// Label images as colours (0 black), for looking at.
cv::Mat colourLabels(const cv::Mat& labels) {
  cv::Mat c(labels.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  for (int v = 0; v < labels.rows; ++v)
    for (int u = 0; u < labels.cols; ++u) {
      const int k = labels.at<std::uint16_t>(v, u);
      if (k)
        c.at<cv::Vec3b>(v, u) = cv::Vec3b(k * 97 % 200 + 55, k * 57 % 200 + 55, k * 151 % 200 + 55);
    }
  return c;
}

// The plane labels of truth and detector, and the segment labels of truth and the default
// segmentation.
void dumpLabels(const std::string& dir, const synthetic::TruthFrame& truth,
                const cv::Mat& planar_truth, const Frame& frame, const PlaneDetection& found) {
  // Depth as grey, near light and far dark over 0.4-5 m; black where there is no reading.
  cv::Mat depth_grey;
  frame.depth.convertTo(depth_grey, CV_8U, -255.0 / 4600.0, 255.0 * 5000.0 / 4600.0);
  depth_grey.setTo(0, frame.depth == 0);
  cv::imwrite(dir + "/depth.png", depth_grey);
  cv::imwrite(dir + "/planes_truth.png", colourLabels(planar_truth));
  cv::imwrite(dir + "/planes_found.png", colourLabels(found.labels));
  cv::imwrite(dir + "/segments_truth.png", colourLabels(eval::segmentTruth(truth)));
  const SegmentationResult segments = segmentFrame(frame, kDefaultSegmentationMethod, {}, &found);
  cv::imwrite(dir + "/segments_found.png", colourLabels(segments.labels));
  std::printf(
      "wrote depth, planes_truth, planes_found, segments_truth and segments_found.png in %s\n",
      dir.c_str());
}

// Reported planes not matched to a truth plane and with under 80% of their pixels on one planar
// truth surface (the evaluation's spurious planes, ignoring split and merged relations), with
// the surfaces that hold at least 2% of each.
void printSpurious(int frame, const synthetic::TruthFrame& truth, const PlaneDetection& out,
                   const eval::PlaneScore& score) {
  const auto surface = [&](int id) -> const synthetic::TruthSurface& {
    return truth.surfaces[id - 1];  // ordered by id, from 1
  };
  std::map<int, std::map<int, long>> on;  // found plane -> truth surface -> pixels
  std::map<int, long> all;
  for (int v = 0; v < out.labels.rows; ++v)
    for (int u = 0; u < out.labels.cols; ++u) {
      const int found = out.labels.at<std::uint16_t>(v, u);
      if (!found) continue;
      ++all[found];
      ++on[found][truth.surface_labels.at<std::uint16_t>(v, u)];
    }
  std::map<int, bool> matched;
  for (const auto& [truth_id, found_id] : score.matches) matched[found_id] = true;
  for (const auto& [found, pixels] : all) {
    if (matched[found]) continue;
    long on_one_plane = 0;
    for (const auto& [t, px] : on[found])
      if (t && surface(t).kind == synthetic::SurfaceKind::kPlane)
        on_one_plane = std::max(on_one_plane, px);
    if (on_one_plane >= 0.8 * pixels) continue;
    const DetectedPlane& plane = out.planes[found - 1];
    std::printf("frame %3d SPURIOUS %d (%ld px, rms %.1f mm, d %.2f m, box %d,%d %dx%d):", frame,
                found, pixels, 1000 * plane.rms_m, plane.d, plane.box.x, plane.box.y,
                plane.box.width, plane.box.height);
    for (const auto& [t, px] : on[found]) {
      if (px < 0.02 * pixels) continue;
      const bool curved = t && surface(t).kind != synthetic::SurfaceKind::kPlane;
      std::printf(" %s%s %.2f", t ? surface(t).name.c_str() : "none", curved ? "(curved)" : "",
                  double(px) / pixels);
    }
    std::printf("\n");
  }
}

// The distance of point x (m) from the plane n.X + d = 0 in sensor depth steps at its range.
double stepsOff(const Eigen::Vector3d& n, double d, const Eigen::Vector3d& x,
                const KinectNoiseModel& noise) {
  return (n.dot(x) + d) / noise.depthStep(x.z());
}

// One line per reported plane: whether it is matched to a truth plane, its pixels, RMS, mean
// range and RMS of the residuals in sensor depth steps at each pixel's range.
void printResiduals(int frame, const cv::Mat& depth_mm, const CameraIntrinsics& K,
                    const PlaneDetection& out, const eval::PlaneScore& score) {
  const KinectNoiseModel noise;
  std::map<int, bool> matched;
  for (const auto& [truth_id, found_id] : score.matches) matched[found_id] = true;
  std::map<int, double> sum_z, sum_r2;
  std::map<int, long> count;
  for (int v = 0; v < out.labels.rows; ++v)
    for (int u = 0; u < out.labels.cols; ++u) {
      const int found = out.labels.at<std::uint16_t>(v, u);
      const double z = depth_mm.at<std::uint16_t>(v, u) * 1e-3;
      if (!found || z <= 0) continue;
      const DetectedPlane& p = out.planes[found - 1];
      const Eigen::Vector3d X = K.ray(u, v) * z;
      const double r = stepsOff(p.normal, p.d, X, noise);
      sum_z[found] += z;
      sum_r2[found] += r * r;
      ++count[found];
    }
  for (const auto& [found, n] : count)
    std::printf("RESID %d %d %d %ld %.2f %.3f %.3f\n", frame, found, matched[found] ? 1 : 0, n,
                1000 * out.planes[found - 1].rms_m, sum_z[found] / n, std::sqrt(sum_r2[found] / n));
}

// For a truth plane found in part, after its MISS line: the angle between the plane that covers
// most of it and its true plane, and the RMS residuals to that found plane (and to the true one)
// in sensor depth steps, of its pixels labelled with the found plane and of those left
// unlabelled, with the share of the unlabelled within 1.5 steps of the found plane: unlabelled
// pixels that lie on the found plane are pixels its growth never reached.
void printFoundInPart(const synthetic::TruthSurface& surface, const cv::Mat& planar_truth,
                      const Frame& frame, int found, const PlaneDetection& out) {
  if (!found) return;
  const DetectedPlane& plane = out.planes[found - 1];
  const Eigen::Vector3d true_normal = surface.plane.head<3>();
  const KinectNoiseModel noise;
  struct Sums {
    double found = 0.0, truth = 0.0;
    long n = 0;
  } labelled, unlabelled;
  long unlabelled_near = 0;
  for (int v = 0; v < planar_truth.rows; ++v)
    for (int u = 0; u < planar_truth.cols; ++u) {
      const double z = frame.depth.at<std::uint16_t>(v, u) * 1e-3;
      if (planar_truth.at<std::uint16_t>(v, u) != surface.id || z <= 0) continue;
      const Eigen::Vector3d x = frame.intrinsics.ray(u, v) * z;
      const double to_found = stepsOff(plane.normal, plane.d, x, noise);
      const double to_truth = stepsOff(true_normal, surface.plane[3], x, noise);
      const int label = out.labels.at<std::uint16_t>(v, u);
      Sums* sums = label == 0 ? &unlabelled : label == found ? &labelled : nullptr;
      if (!sums) continue;
      sums->found += to_found * to_found;
      sums->truth += to_truth * to_truth;
      ++sums->n;
      if (label == 0) unlabelled_near += std::abs(to_found) < 1.5;
    }
  const auto rms = [](double sum, long n) { return std::sqrt(sum / std::max(n, 1L)); };
  const double angle =
      std::acos(std::min(1.0, std::abs(plane.normal.dot(true_normal)))) * 180.0 / M_PI;
  std::printf(
      " || found %d %.2f deg off; labelled rms %.2f steps (true plane %.2f); unlabelled %ld px, "
      "rms %.2f steps (true plane %.2f), within 1.5 steps %.2f",
      found, angle, rms(labelled.found, labelled.n), rms(labelled.truth, labelled.n), unlabelled.n,
      rms(unlabelled.found, unlabelled.n), rms(unlabelled.truth, unlabelled.n),
      double(unlabelled_near) / std::max(unlabelled.n, 1L));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Missed truth planes of the Hough plane detector on the evaluation's scenes"};
  std::string split_name = "validation";
  int frames = 100;
  double max_share = 1.0;
  bool quiet = false;
  app.add_option("--split", split_name, "train, validation or test");
  app.add_option("--frames", frames, "frames of the split")->check(CLI::PositiveNumber);
  app.add_option("--max-share", max_share, "only truth planes below this share of the image");
  app.add_flag("--quiet", quiet, "only the counts");
  bool show_spurious = false;
  int dump_frame = -1;
  std::string out_dir = ".";
  app.add_flag("--spurious", show_spurious, "list the spurious planes");
  bool show_residuals = false;
  app.add_flag("--residuals", show_residuals,
               "per reported plane: frame, id, matched, pixels, RMS mm, mean range m, RMS in "
               "depth steps");
  bool show_part_residuals = false;
  app.add_flag("--part-residuals", show_part_residuals,
               "after each truth plane found in part: the found plane's angle to it and the "
               "residuals of its labelled and unlabelled pixels in depth steps");
  app.add_option("--dump-frame", dump_frame, "write the label images of this frame");
  app.add_option("--out", out_dir, "folder for --dump-frame's images")
      ->check(CLI::ExistingDirectory);
  HoughPlaneParams params;  // HoughPlaneParams' documentation says what each one does
  app.add_option("--leftover-agreement", params.leftover_normal_agreement_deg);
  app.add_option("--leftover-fraction", params.leftover_min_inlier_fraction);
  app.add_option("--two-face-gain", params.two_face_gain);
  app.add_option("--step-noise-sigmas", params.normals.depth_change_noise_sigmas);
  app.add_option("--merge-occluded", params.labeling.merge_occluded_pieces);
  app.add_option("--merge-coplanar", params.labeling.merge_coplanar_regions);
  app.add_option("--vote-spread", params.vote_max_normal_spread_deg);
  app.add_option("--min-plane-samples", params.min_plane_samples);
  app.add_option("--max-curvature", params.labeling.max_plane_curvature_per_m);
  app.add_option("--curved-rms-ratio", params.labeling.curved_rms_ratio);
  app.add_option("--curved-pair-rms-factor", params.labeling.curved_pair_rms_factor);
  app.add_option("--curved-pair-max-angle", params.labeling.curved_pair_max_angle_deg);
  app.add_option("--noise-steps", params.labeling.tolerance.noise_steps);
  app.add_option("--adaptive-factor", params.labeling.adaptive_tolerance_factor);
  app.add_option("--min-tolerance-steps", params.labeling.min_tolerance_steps);
  app.add_option("--grow-normal", params.labeling.grow_max_normal_deg);
  app.add_option("--grow-unreliable-normal", params.labeling.grow_max_unreliable_normal_deg);
  app.add_option("--crease-passes", params.labeling.crease_max_passes);
  app.add_option("--minor-face-gain", params.labeling.minor_face_gain);
  app.add_option("--minor-face-angle", params.labeling.minor_face_min_angle_deg);
  app.add_option("--minor-face-gap", params.labeling.minor_face_min_gap_steps);
  app.add_option("--crease-window", params.labeling.crease_window_px);
  app.add_option("--crease-mean-sigmas", params.labeling.crease_mean_sigmas);
  app.add_option("--crease-outside-sigmas", params.labeling.crease_outside_sigmas);
  app.add_option("--crease-outside-share", params.labeling.crease_min_outside_share);
  CLI11_PARSE(app, argc, argv);
  const auto split = eval::parseSplit(split_name);
  if (!split) {
    std::fprintf(stderr, "unknown split %s\n", split_name.c_str());
    return 2;
  }

  HoughPlaneDetector det(params);
  eval::PlaneScore total, plain, clutter;
  std::array<int, kCauses> causes{};
  for (int i = 0; i < frames; ++i) {
    const eval::EvalScene scene = eval::evalScene(*split, i);
    const auto f = synthetic::SyntheticScene(scene.params).render(scene.frame_index, 0);
    const auto out = det.detect(f.frame.depth, f.frame.intrinsics);
    const auto score = eval::scorePlanes(out.labels, out.planes, f.truth);
    total.add(score);
    (scene.curved_clutter ? clutter : plain).add(score);
    const cv::Mat truth = eval::planarTruth(f.truth);
    if (i == dump_frame) dumpLabels(out_dir, f.truth, truth, f.frame, out);
    const Overlaps o = overlapsOf(truth, out.labels);
    std::map<int, bool> correct;
    for (const auto& [tid, fid] : score.matches) correct[tid] = true;
    if (show_spurious) printSpurious(i, f.truth, out, score);
    if (show_residuals) printResiduals(i, f.frame.depth, f.frame.intrinsics, out, score);
    for (const auto& ts : f.truth.surfaces) {
      const auto size = o.truth_size.find(ts.id);
      if (ts.kind != synthetic::SurfaceKind::kPlane || size == o.truth_size.end()) continue;
      const double share = double(size->second) / truth.total();
      if (share < eval::kPlaneSizeBinEdges[0] || share >= max_share || correct[ts.id]) continue;
      const auto [range, obliquity] =
          rangeAndObliquity(f.truth, ts.id, f.frame.intrinsics, ts.plane.head<3>());
      if (!quiet)
        std::printf("frame %3d MISS %-18s %5.2f%% %.2f m %4.0f deg:", i, ts.name.c_str(),
                    100.0 * share, range, obliquity);
      const Miss miss = explainMiss(ts.id, o, out, quiet);
      ++causes[miss.cause];
      if (show_part_residuals && !quiet && miss.cause == kPartial)
        printFoundInPart(ts, truth, f.frame, miss.most_found, out);
      if (!quiet) std::printf("\n");
    }
  }
  std::printf("correct %.3f (%d/%d)\n", total.correctFraction(), total.correct,
              total.truth_regions);
  std::printf("spurious per frame: plain %.2f, curved clutter %.2f (%d on curved)\n",
              plain.spuriousPerFrame(), clutter.spuriousPerFrame(), clutter.spurious_on_curved);
  for (int c = 0; c < kCauses; ++c) std::printf("missed, %s: %d\n", kCauseNames[c], causes[c]);
  return 0;
}
