#include "shapesense/eval/recognition_eval.h"

#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>

#include "shapesense/core/boxes/segment_box.h"
#include "shapesense/core/geometry/order_statistics.h"
#include "shapesense/core/pipeline/detector_chain.h"

namespace shapesense::eval {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

double angleDeg(double cosine) {
  return std::acos(std::clamp(cosine, -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

struct TaughtObject {
  std::uint16_t id = 0;
  ObjectModel model;
  Eigen::Vector3d centre;  ///< the truth centre, teach camera frame
  Eigen::Vector3d axis;    ///< the truth axis 2, teach camera frame
  bool axially_symmetric = false;
};

const synthetic::TruthObject* objectById(const synthetic::TruthFrame& truth, std::uint16_t id) {
  for (const auto& o : truth.objects)
    if (o.id == id) return &o;
  return nullptr;
}

// Teaches every teachable object of the case through its truth image box, as an operator
// drawing a rectangle would.
std::vector<TaughtObject> teachCase(const RecognitionCase& c, const ObjectModelParams& params,
                                    RecognitionScore& score) {
  const Frame& frame = c.teach.rendered.frame;
  const FrameResults results = makeDetectorChain(DetectorConfig{}).process(frame);
  std::vector<TaughtObject> out;
  if (!results.segmentation || !results.planes) return out;
  for (std::uint16_t id : teachableObjects(c)) {
    const synthetic::TruthObject& object = *objectById(c.teach.rendered.truth, id);
    const cv::Rect roi = object.image_box;
    const auto marked = objectUnderRoi(frame.depth, frame.intrinsics, roi.tl(),
                                       roi.br() - cv::Point(1, 1), results.segmentation->labels,
                                       results.segmentation->segments, results.planes->frame);
    const auto* roi_object = std::get_if<RoiObject>(&marked);
    if (!roi_object) {
      ++score.refused;
      continue;
    }
    try {
      TaughtObject taught;
      taught.id = id;
      taught.model =
          teachObjectModel(object.name, frame.depth, frame.intrinsics, roi_object->mask, params);
      taught.centre = object.center;
      taught.axis = object.rotation.col(2);
      taught.axially_symmetric = object.kind == "tin" || object.kind == "cup";
      out.push_back(std::move(taught));
      ++score.taught;
    } catch (const std::invalid_argument&) {
      ++score.refused;
    }
  }
  return out;
}

}  // namespace

double RecognitionScore::falsePerFrameForFive() const {
  if (views == 0 || taught == 0) return 0.0;
  const double models_per_case = static_cast<double>(taught) / std::max(cases, 1);
  return static_cast<double>(false_detections) / views * 5.0 / models_per_case;
}

PoseErrorDeg poseError(const Eigen::Isometry3f& estimated, const Eigen::Isometry3d& truth,
                       const Eigen::Vector3d& centre, const Eigen::Vector3d& axis,
                       bool axially_symmetric) {
  const Eigen::Isometry3d e = estimated.cast<double>();
  PoseErrorDeg out;
  out.translation_m = (e * centre - truth * centre).norm();
  if (axially_symmetric) {
    out.rotation_deg =
        angleDeg((e.linear() * axis).normalized().dot((truth.linear() * axis).normalized()));
  } else {
    const Eigen::Matrix3d r = e.linear() * truth.linear().transpose();
    out.rotation_deg = angleDeg((r.trace() - 1.0) / 2.0);
  }
  return out;
}

RecognitionScore scoreRecognition(Split split, int first, int count, int other_views,
                                  const ObjectModelParams& model_params,
                                  const ObjectMatchParams& match_params,
                                  const PoseTolerance& tolerance) {
  RecognitionScore score;
  for (int index = first; index < first + count; ++index) {
    const RecognitionCase c = recognitionCase(split, index, other_views);
    ++score.cases;
    const std::vector<TaughtObject> taught = teachCase(c, model_params, score);
    for (const RecognitionView& view : c.others) {
      ++score.views;
      const Eigen::Isometry3d truth = teachToView(c, view);
      auto start = Clock::now();
      const SceneSurface scene(view.rendered.frame.depth, view.rendered.frame.intrinsics,
                               model_params);
      score.describe_ms_total += msSince(start);
      for (const TaughtObject& t : taught) {
        const double share = visibleShare(c, view, t.id);
        const bool required = share >= tolerance.min_visible_share;
        if (required) ++score.required;
        start = Clock::now();
        const auto detection = findObject(t.model, scene, match_params);
        score.find_ms_total += msSince(start);
        ++score.searches;
        if (!detection) continue;
        const PoseErrorDeg error =
            poseError(detection->camera_from_model, truth, t.centre, t.axis, t.axially_symmetric);
        const bool right = error.translation_m <= tolerance.translation_m &&
                           error.rotation_deg <= tolerance.rotation_deg;
        if (right && share >= tolerance.min_visible_share_present) {
          if (required) {
            ++score.found;
            score.translation_errors_m.push_back(error.translation_m);
            score.rotation_errors_deg.push_back(error.rotation_deg);
          }
          continue;
        }
        ++score.false_detections;
        if (required) ++score.wrong_pose;
      }
    }
  }
  return score;
}

std::string formatRecognitionScore(const std::string& label, const RecognitionScore& s) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(3);
  out << label << ": " << s.cases << " cases, " << s.views << " views; taught " << s.taught
      << " objects (" << s.refused << " refused); recall " << s.recall() << " (" << s.found
      << " of " << s.required << ", " << s.wrong_pose << " with a wrong pose); false "
      << s.false_detections << " = " << s.falsePerFrameForFive() << " per frame for five objects";
  if (!s.translation_errors_m.empty()) {
    std::vector<double> translations = s.translation_errors_m;
    std::vector<double> rotations = s.rotation_errors_deg;
    out.precision(1);
    out << "; median error " << 1e3 * quantile(translations, 0.5) << " mm, "
        << quantile(rotations, 0.5) << " deg";
  }
  out.precision(1);
  if (s.views > 0 && s.searches > 0)
    out << "; describe " << s.describe_ms_total / s.views << " ms/frame, find "
        << s.find_ms_total / s.searches << " ms/model";
  return out.str();
}

}  // namespace shapesense::eval
