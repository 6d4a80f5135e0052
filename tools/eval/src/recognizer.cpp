#include "shapesense/eval/recognizer.h"

#include <cstdio>

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

std::optional<PoseVerdict> Recognizer::checkPose(const Model&, const Scene&,
                                                 const Eigen::Isometry3f&) {
  return std::nullopt;
}

std::optional<PoseVerdict> ShapesenseRecognizer::checkPose(
    const Model& model, const Scene& scene, const Eigen::Isometry3f& camera_from_model) {
  PoseCheck check = checkObjectPose(static_cast<const ShapesenseModel&>(model).model,
                                    static_cast<const ShapesenseScene&>(scene).surface,
                                    camera_from_model, match_params_);
  char figures[160];
  std::snprintf(figures, sizeof figures,
                "confirmed %d, contradicted %d, score %.4f, outline seen %d, continued %d",
                check.confirmed, check.contradicted, check.score, check.outline_seen,
                check.outline_continued);
  return PoseVerdict{std::move(check.failed), figures};
}

}  // namespace shapesense::eval
