#pragma once
// What the recognition scoring (recognition_eval.h) needs of a method that finds taught
// objects, so that shapesense's own matching and the bench's peers (OpenCV's point-pair
// features, PCL's descriptors with correspondence grouping) are scored on exactly the same
// teaching pixels, views, tolerance and counting.

#include <memory>
#include <optional>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/recognition/object_matching.h"

namespace shapesense::eval {

/// What a method's own check says of a pose.
struct PoseVerdict {
  std::string failed;   ///< empty when the pose passes, else the rule it fails
  std::string figures;  ///< what the check measured, e.g. "confirmed 989, contradicted 0, ..."
};

struct RecognizerDetection {
  /// The model's pose in the searched camera's frame; the model's frame is the camera frame of
  /// the view it was taught from (so the identity there), as poseError expects.
  Eigen::Isometry3f camera_from_model = Eigen::Isometry3f::Identity();
  /// The method's confidence, larger is surer: a threshold on it is the method's detection
  /// threshold (withMinScore in recognition_eval.h re-counts a score at another one).
  double score = 0.0;
};

class Recognizer {
 public:
  /// What a method keeps of a taught object and of a searched frame; each method defines its own.
  struct Model {
    virtual ~Model() = default;
  };
  struct Scene {
    virtual ~Scene() = default;
  };

  virtual ~Recognizer() = default;
  virtual std::string name() const = 0;
  /// Teaches the object on `mask`'s non-zero pixels of `depth_mm` (CV_16UC1 millimetres).
  /// Throws std::invalid_argument when the method cannot teach it (too little surface...).
  virtual std::unique_ptr<Model> teach(const std::string& name, const cv::Mat& depth_mm,
                                       const CameraIntrinsics& intrinsics, const cv::Mat& mask) = 0;
  /// What the method computes once per searched frame, whatever the models looked for.
  virtual std::unique_ptr<Scene> describe(const cv::Mat& depth_mm,
                                          const CameraIntrinsics& intrinsics) = 0;
  /// The taught object in the described frame, or none.
  virtual std::optional<RecognizerDetection> find(const Model& model, const Scene& scene) = 0;
  /// What the method's own check says of the model at `camera_from_model` in the described
  /// frame; none (the default) for a method without such a check. Lists why a missed object
  /// was missed: the truth pose against the one reported.
  virtual std::optional<PoseVerdict> checkPose(const Model& model, const Scene& scene,
                                               const Eigen::Isometry3f& camera_from_model);
};

/// shapesense's own method: teachObjectModel, SceneSurface and findObject (core/recognition).
class ShapesenseRecognizer final : public Recognizer {
 public:
  explicit ShapesenseRecognizer(const ObjectModelParams& model_params = {},
                                const ObjectMatchParams& match_params = {})
      : model_params_(model_params), match_params_(match_params) {}

  std::string name() const override { return "shapesense"; }
  std::unique_ptr<Model> teach(const std::string& name, const cv::Mat& depth_mm,
                               const CameraIntrinsics& intrinsics, const cv::Mat& mask) override;
  std::unique_ptr<Scene> describe(const cv::Mat& depth_mm,
                                  const CameraIntrinsics& intrinsics) override;
  std::optional<RecognizerDetection> find(const Model& model, const Scene& scene) override;
  /// checkObjectPose's verdict and figures.
  std::optional<PoseVerdict> checkPose(const Model& model, const Scene& scene,
                                       const Eigen::Isometry3f& camera_from_model) override;

 private:
  ObjectModelParams model_params_;
  ObjectMatchParams match_params_;
};

}  // namespace shapesense::eval
