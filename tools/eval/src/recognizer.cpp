#include "shapesense/eval/recognizer.h"

namespace shapesense::eval {
namespace {

struct ShapesenseModel final : Recognizer::Model {
  explicit ShapesenseModel(ObjectModel m) : model(std::move(m)) {}
  ObjectModel model;
};

struct ShapesenseScene final : Recognizer::Scene {
  ShapesenseScene(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                  const ObjectModelParams& params)
      : surface(depth_mm, intrinsics, params) {}
  SceneSurface surface;
};

}  // namespace

std::unique_ptr<Recognizer::Model> ShapesenseRecognizer::teach(const std::string& name,
                                                               const cv::Mat& depth_mm,
                                                               const CameraIntrinsics& intrinsics,
                                                               const cv::Mat& mask) {
  return std::make_unique<ShapesenseModel>(
      teachObjectModel(name, depth_mm, intrinsics, mask, model_params_));
}

std::unique_ptr<Recognizer::Scene> ShapesenseRecognizer::describe(
    const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics) {
  return std::make_unique<ShapesenseScene>(depth_mm, intrinsics, model_params_);
}

std::optional<RecognizerDetection> ShapesenseRecognizer::find(const Model& model,
                                                              const Scene& scene) {
  const auto detection =
      findObject(static_cast<const ShapesenseModel&>(model).model,
                 static_cast<const ShapesenseScene&>(scene).surface, match_params_);
  if (!detection) return std::nullopt;
  return RecognizerDetection{detection->camera_from_model, detection->score};
}

std::optional<std::string> Recognizer::checkPose(const Model&, const Scene&,
                                                 const Eigen::Isometry3f&) {
  return std::nullopt;
}

std::optional<std::string> ShapesenseRecognizer::checkPose(
    const Model& model, const Scene& scene, const Eigen::Isometry3f& camera_from_model) {
  return checkObjectPose(static_cast<const ShapesenseModel&>(model).model,
                         static_cast<const ShapesenseScene&>(scene).surface, camera_from_model,
                         match_params_)
      .failed;
}

}  // namespace shapesense::eval
