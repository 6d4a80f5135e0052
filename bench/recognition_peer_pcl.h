#pragma once
// Peer of taught-object recognition (issue 22): PCL's correspondence-grouping pipeline (the
// "3D Object Recognition based on Correspondence Grouping" tutorial) behind the scoring's
// Recognizer interface (recognition_eval.h): uniform-sampling keypoints, SHOT descriptors,
// model-scene correspondences by nearest descriptor, geometric-consistency grouping; the
// largest cluster's pose refined by PCL's ICP on the scene's surface (the tutorial stops at the
// grouping; the refinement gives it the same chance at a 1 cm / 5 deg tolerance as PPF's ICP
// and our own). Bench-only: PCL is linked into the benchmark executable only, never into
// shapesense (scripts/deps --bench-peers installs it).
//
// Points and normals are shapesense's surface (surfaceCloudFromDepth: 5 mm voxels, the
// organised normals) for the model and the scene alike, as for the PPF peer, so that the peers
// differ from our method in the recognition only.

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include <pcl/console/print.h>
#include <pcl/correspondence.h>
#include <pcl/features/shot_omp.h>
#include <pcl/filters/uniform_sampling.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/recognition/cg/geometric_consistency.h>
#include <pcl/registration/icp.h>
#include <pcl/search/kdtree.h>

#include "shapesense/core/recognition/surface_cloud.h"
#include "shapesense/eval/recognizer.h"

namespace shapesense::bench {

struct PclShotParams {
  /// Keypoint spacing (uniform sampling) on the model and on the scene (m): the tutorial's
  /// 1 cm and 3 cm.
  double model_keypoint_spacing_m = 0.01;
  double scene_keypoint_spacing_m = 0.03;
  /// SHOT support radius (m): the tutorial's 2 cm holds only ~50 surface points at 5 mm
  /// voxels; 3 cm (~110) describes more of the shape.
  double descriptor_radius_m = 0.03;
  /// A scene descriptor corresponds to its nearest model descriptor when their squared
  /// distance is below this (the tutorial's 0.25).
  float max_descriptor_distance_sq = 0.25f;
  /// Scene descriptors matched to each model descriptor (nearest first).
  int matches_per_model_descriptor = 3;
  /// Geometric consistency: correspondences agree when their pair distances differ by at most
  /// `consensus_size_m` (the tutorial's 1 cm); a cluster needs `min_cluster_size` of them (the
  /// tutorial's 5).
  double consensus_size_m = 0.01;
  int min_cluster_size = 5;
  /// ICP of the model's surface on the scene's: iterations and farthest pair (m).
  int icp_iterations = 30;
  double icp_max_distance_m = 0.01;
  /// Fewest descriptors a taught surface needs to be a model.
  int min_model_descriptors = 5;
};

class PclShotRecognizer final : public eval::Recognizer {
 public:
  explicit PclShotRecognizer(const PclShotParams& params = {}) : params_(params) {
    // SHOT logs every keypoint whose reference frame is undefined; those are dropped anyway.
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  }

  std::string name() const override { return "PCL SHOT+GC"; }

  std::unique_ptr<Model> teach(const std::string&, const cv::Mat& depth_mm,
                               const CameraIntrinsics& intrinsics, const cv::Mat& mask) override {
    auto model = std::make_unique<ShotModel>();
    describeSurface(surfaceCloudFromDepth(depth_mm, intrinsics, mask),
                    params_.model_keypoint_spacing_m, *model);
    if (static_cast<int>(model->descriptors->size()) < params_.min_model_descriptors)
      throw std::invalid_argument("too few SHOT descriptors for a model");
    return model;
  }

  std::unique_ptr<Scene> describe(const cv::Mat& depth_mm,
                                  const CameraIntrinsics& intrinsics) override {
    auto scene = std::make_unique<ShotScene>();
    describeSurface(surfaceCloudFromDepth(depth_mm, intrinsics), params_.scene_keypoint_spacing_m,
                    *scene);
    scene->point_index->setInputCloud(scene->points);
    if (!scene->descriptors->empty()) scene->descriptor_index.setInputCloud(scene->descriptors);
    return scene;
  }

  std::optional<eval::RecognizerDetection> find(const Model& model_base,
                                                const Scene& scene_base) override {
    const auto& model = static_cast<const ShotModel&>(model_base);
    const auto& scene = static_cast<const ShotScene&>(scene_base);
    if (scene.descriptors->empty()) return std::nullopt;

    // Correspondences: each model descriptor's nearest scene descriptors. The tutorial pairs
    // each scene descriptor with its nearest model descriptor instead: on a whole frame that is
    // thousands of correspondences, most of them under its distance threshold, for a grouping
    // quadratic in them (4.0 s per model on validation case 0, against 2.3-3.4 s this way).
    auto correspondences = pcl::make_shared<pcl::Correspondences>();
    std::vector<int> nearest(params_.matches_per_model_descriptor);
    std::vector<float> distance_sq(params_.matches_per_model_descriptor);
    for (std::size_t i = 0; i < model.descriptors->size(); ++i) {
      const int n = scene.descriptor_index.nearestKSearch(
          (*model.descriptors)[i], params_.matches_per_model_descriptor, nearest, distance_sq);
      for (int k = 0; k < n; ++k)
        if (distance_sq[k] < params_.max_descriptor_distance_sq)
          correspondences->emplace_back(static_cast<int>(i), nearest[k], distance_sq[k]);
    }

    pcl::GeometricConsistencyGrouping<pcl::PointXYZ, pcl::PointXYZ> grouping;
    grouping.setGCSize(params_.consensus_size_m);
    grouping.setGCThreshold(params_.min_cluster_size);
    grouping.setInputCloud(model.described_points);
    grouping.setSceneCloud(scene.described_points);
    grouping.setModelSceneCorrespondences(correspondences);
    std::vector<Eigen::Matrix4f, Eigen::aligned_allocator<Eigen::Matrix4f>> poses;
    std::vector<pcl::Correspondences> clusters;
    grouping.recognize(poses, clusters);
    if (poses.empty()) return std::nullopt;
    std::size_t best = 0;
    for (std::size_t i = 1; i < clusters.size(); ++i)
      if (clusters[i].size() > clusters[best].size()) best = i;

    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
    icp.setMaximumIterations(params_.icp_iterations);
    icp.setMaxCorrespondenceDistance(params_.icp_max_distance_m);
    icp.setInputSource(model.points);
    // The scene's k-d tree is built once per frame (describe), not once per model.
    icp.setSearchMethodTarget(scene.point_index, true);
    icp.setInputTarget(scene.points);
    pcl::PointCloud<pcl::PointXYZ> aligned;
    icp.align(aligned, poses[best]);

    eval::RecognizerDetection out;
    out.camera_from_model.matrix() =
        icp.hasConverged() ? icp.getFinalTransformation() : poses[best];
    out.score = static_cast<double>(clusters[best].size());
    return out;
  }

 private:
  using Cloud = pcl::PointCloud<pcl::PointXYZ>;
  using Descriptors = pcl::PointCloud<pcl::SHOT352>;

  struct Described {
    Cloud::Ptr points = pcl::make_shared<Cloud>();
    pcl::PointCloud<pcl::Normal>::Ptr normals = pcl::make_shared<pcl::PointCloud<pcl::Normal>>();
    Cloud::Ptr described_points = pcl::make_shared<Cloud>();  ///< keypoints with a descriptor
    Descriptors::Ptr descriptors = pcl::make_shared<Descriptors>();
  };
  struct ShotModel final : Model, Described {};
  struct ShotScene final : Scene, Described {
    pcl::KdTreeFLANN<pcl::SHOT352> descriptor_index;
    pcl::search::KdTree<pcl::PointXYZ>::Ptr point_index =
        pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
  };

  // Points and normals, keypoints every `spacing_m`, their SHOT descriptors over the whole
  // surface; keypoints whose descriptor is undefined (too few neighbours) are dropped.
  void describeSurface(const SurfaceCloud& surface, double spacing_m, Described& out) const {
    for (std::size_t i = 0; i < surface.size(); ++i) {
      const auto& p = surface.points[i];
      const auto& n = surface.normals[i];
      out.points->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
      out.normals->push_back(pcl::Normal(n.x(), n.y(), n.z()));
    }
    if (out.points->empty()) return;
    auto keypoints = pcl::make_shared<Cloud>();
    pcl::UniformSampling<pcl::PointXYZ> sampling;
    sampling.setInputCloud(out.points);
    sampling.setRadiusSearch(spacing_m);
    sampling.filter(*keypoints);

    // One thread: every method is timed on one core.
    pcl::SHOTEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::SHOT352> shot(1);
    shot.setRadiusSearch(params_.descriptor_radius_m);
    shot.setInputCloud(keypoints);
    shot.setInputNormals(out.normals);
    shot.setSearchSurface(out.points);
    Descriptors descriptors;
    shot.compute(descriptors);
    for (std::size_t i = 0; i < descriptors.size(); ++i) {
      if (!std::isfinite(descriptors[i].descriptor[0])) continue;
      out.described_points->push_back((*keypoints)[i]);
      out.descriptors->push_back(descriptors[i]);
    }
  }

  PclShotParams params_;
};

}  // namespace shapesense::bench
