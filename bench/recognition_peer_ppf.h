#pragma once
// Peer of taught-object recognition (issue 22): OpenCV's point-pair-feature detector
// (cv::ppf_match_3d, Drost et al. 2010, from libopencv-contrib-dev) with its ICP, behind the
// scoring's Recognizer interface (recognition_eval.h). Bench-only: opencv_surface_matching is
// linked into the benchmark executable only, never into shapesense.
//
// Model: the taught object's surface (surfaceCloudFromDepth on its pixels: 5 mm voxels, the
// organised normals), points and normals in the teach camera's frame, so that the pose PPF
// finds is camera_from_model as the scoring wants it. Scene: the whole frame's surface the same
// way. The best-voted pose cluster is refined by OpenCV's ICP on the scene's surface; its votes
// are the detection's score (the threshold is applied by the caller, withMinScore).
//
// OpenCV's match() is made for a scene about the model's size: it samples the scene on a grid
// relative to the scene's own bounding box (1 / relativeSceneDistance cells per axis, with
// (cells + 1)^3 buckets allocated), and pairs every reference point with every sampled scene
// point. On a whole room-sized frame that is either a 15 cm grid (useless for 5-30 cm objects)
// or minutes per search. Pairs farther apart than the model's diameter cannot vote (no model
// pair has that distance), so the scene is handed to match() in overlapping blocks: cubes of
// twice the model's diameter every diameter along each axis, so that every pair of points
// within a diameter of each other lies in one block. Each block is sampled relative to its own
// box, i.e. at a step relative to the model's diameter as Drost et al. intend; the best-voted
// pose over all blocks wins.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/surface_matching.hpp>

#include "shapesense/core/recognition/surface_cloud.h"
#include "shapesense/eval/recognizer.h"

namespace shapesense::bench {

struct PpfParams {
  /// Model sampling step and pair-distance step, relative to the model's diameter (its bounding
  /// box diagonal; OpenCV quantises each axis of the box in 1 / step cells). 0.1: a 10 cm
  /// object sampled every 1 cm, a 30 cm one every 3 cm. Drost's 0.05 (a 5 mm step on a 10 cm
  /// object, the voxel) made each search 4x slower: the vote accumulator of every scene
  /// reference point is as long as the model.
  double relative_sampling_step = 0.1;
  double relative_distance_step = 0.05;
  /// Quantisation of the pair's angles (OpenCV's default 30 = 12 deg bins).
  double angle_steps = 30;
  /// Cells along each axis of a scene block (twice the model's diameter) that OpenCV samples
  /// it to (its relativeSceneDistance = 1 / cells): 10 cells are a fifth of the diameter,
  /// twice the model's step (20 cells took 4x longer, 6 s per model on one core).
  /// Every `1 / relative_scene_sample_step`-th sampled point is a reference point.
  int scene_cells = 10;
  double relative_scene_sample_step = 1.0 / 5.0;
  /// Pose clustering: poses within this share of the diameter and this angle are one.
  double relative_position_threshold = 0.1;
  double rotation_threshold_deg = 12.0;
  /// ICP refinement of the best cluster: iterations, tolerance, outlier rejection (sigma) and
  /// pyramid levels (OpenCV's sample uses 100, 0.005, 2.5, 8).
  int icp_iterations = 100;
  float icp_tolerance = 0.005f;
  float icp_rejection_scale = 2.5f;
  int icp_levels = 8;
  /// Fewest points a taught surface needs to be a model.
  int min_model_points = 50;
};

class PpfRecognizer final : public eval::Recognizer {
 public:
  explicit PpfRecognizer(const PpfParams& params = {}) : params_(params) {}

  std::string name() const override { return "OpenCV PPF"; }

  std::unique_ptr<Model> teach(const std::string&, const cv::Mat& depth_mm,
                               const CameraIntrinsics& intrinsics, const cv::Mat& mask) override {
    const SurfaceCloud surface = surfaceCloudFromDepth(depth_mm, intrinsics, mask);
    if (static_cast<int>(surface.size()) < params_.min_model_points)
      throw std::invalid_argument("too few surface points for a PPF model");
    auto model = std::make_unique<PpfModel>(params_);
    model->points = toPointNormalMat(surface);
    model->detector.trainModel(model->points);
    model->diameter = diameterOf(surface);
    model->detector.setSearchParams(params_.relative_position_threshold * model->diameter,
                                    params_.rotation_threshold_deg * CV_PI / 180.0);
    return model;
  }

  std::unique_ptr<Scene> describe(const cv::Mat& depth_mm,
                                  const CameraIntrinsics& intrinsics) override {
    auto scene = std::make_unique<PpfScene>();
    scene->points = toPointNormalMat(surfaceCloudFromDepth(depth_mm, intrinsics));
    return scene;
  }

  std::optional<eval::RecognizerDetection> find(const Model& model_base,
                                                const Scene& scene_base) override {
    const auto& model = static_cast<const PpfModel&>(model_base);
    const auto& scene = static_cast<const PpfScene&>(scene_base);
    if (scene.points.rows < params_.min_model_points) return std::nullopt;
    cv::ppf_match_3d::Pose3DPtr best_pose;
    for (const cv::Mat& block : sceneBlocks(scene.points, model.diameter)) {
      // OpenCV divides by the block's extent along each axis.
      if (block.rows < params_.min_model_points || !hasExtent(block)) continue;
      std::vector<cv::ppf_match_3d::Pose3DPtr> poses;
      model.detector.match(block, poses, params_.relative_scene_sample_step,
                           1.0 / params_.scene_cells);
      // Poses come sorted by votes.
      if (!poses.empty() && (!best_pose || poses.front()->numVotes > best_pose->numVotes))
        best_pose = poses.front();
    }
    if (!best_pose) return std::nullopt;
    std::vector<cv::ppf_match_3d::Pose3DPtr> best{best_pose};
    cv::ppf_match_3d::ICP icp(params_.icp_iterations, params_.icp_tolerance,
                              params_.icp_rejection_scale, params_.icp_levels);
    if (params_.icp_iterations > 0) icp.registerModelToScene(model.points, scene.points, best);
    eval::RecognizerDetection out;
    cv::Matx44f pose(best.front()->pose);
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) out.camera_from_model.matrix()(r, c) = pose(r, c);
    out.score = static_cast<double>(best.front()->numVotes);
    last_residual_ = best.front()->residual;
    return out;
  }

  /// ICP's residual of the last detection (for the threshold study).
  double lastResidual() const { return last_residual_; }

 private:
  struct PpfModel final : Model {
    explicit PpfModel(const PpfParams& p)
        : detector(p.relative_sampling_step, p.relative_distance_step, p.angle_steps) {}
    // match() is not const in OpenCV, though it does not change the trained model.
    mutable cv::ppf_match_3d::PPF3DDetector detector;
    cv::Mat points;  ///< N x 6 CV_32F: x y z nx ny nz
    double diameter = 0.0;
  };
  struct PpfScene final : Scene {
    cv::Mat points;
  };

  static cv::Mat toPointNormalMat(const SurfaceCloud& surface) {
    cv::Mat out(static_cast<int>(surface.size()), 6, CV_32F);
    for (int i = 0; i < out.rows; ++i) {
      float* row = out.ptr<float>(i);
      for (int k = 0; k < 3; ++k) {
        row[k] = surface.points[i][k];
        row[3 + k] = surface.normals[i][k];
      }
    }
    return out;
  }

  // The scene's points in cubes of side 2 * `diameter`, one starting at each occupied cell of a
  // grid of side `diameter`: a pair of points within `diameter` of each other falls in the
  // cube of the cell that holds their smaller coordinates along each axis.
  static std::vector<cv::Mat> sceneBlocks(const cv::Mat& points, double diameter) {
    using Cell = std::array<int, 3>;
    std::map<Cell, std::vector<int>> by_cell;
    for (int i = 0; i < points.rows; ++i) {
      const float* p = points.ptr<float>(i);
      by_cell[{static_cast<int>(std::floor(p[0] / diameter)),
               static_cast<int>(std::floor(p[1] / diameter)),
               static_cast<int>(std::floor(p[2] / diameter))}]
          .push_back(i);
    }
    std::vector<cv::Mat> blocks;
    for (const auto& [start, unused] : by_cell) {
      cv::Mat block(0, 6, CV_32F);
      for (int dx = 0; dx < 2; ++dx)
        for (int dy = 0; dy < 2; ++dy)
          for (int dz = 0; dz < 2; ++dz) {
            const auto found = by_cell.find({start[0] + dx, start[1] + dy, start[2] + dz});
            if (found == by_cell.end()) continue;
            for (int i : found->second) block.push_back(points.row(i));
          }
      blocks.push_back(block);
    }
    return blocks;
  }

  static bool hasExtent(const cv::Mat& points) {
    double low = 0.0, high = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      cv::minMaxLoc(points.col(axis), &low, &high);
      if (high - low < 1e-4) return false;
    }
    return true;
  }

  // The diagonal of the axis-aligned box of the points, as OpenCV measures the model.
  static double diameterOf(const SurfaceCloud& surface) {
    std::array<float, 3> low{}, high{};
    low.fill(std::numeric_limits<float>::max());
    high.fill(std::numeric_limits<float>::lowest());
    for (const auto& p : surface.points)
      for (int axis = 0; axis < 3; ++axis) {
        low[axis] = std::min(low[axis], p[axis]);
        high[axis] = std::max(high[axis], p[axis]);
      }
    double sum = 0.0;
    for (int axis = 0; axis < 3; ++axis) sum += std::pow(high[axis] - low[axis], 2);
    return std::sqrt(sum);
  }

  PpfParams params_;
  double last_residual_ = 0.0;
};

}  // namespace shapesense::bench
