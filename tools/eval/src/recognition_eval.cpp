#include "shapesense/eval/recognition_eval.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "shapesense/core/boxes/segment_box.h"
#include "shapesense/core/geometry/order_statistics.h"
#include "shapesense/core/geometry/units.h"
#include "shapesense/core/pipeline/detector_chain.h"

namespace shapesense::eval {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// An object of a case as an operator marks it in the teach view: the same pixels for every
// method.
struct TeachingExample {
  std::uint16_t id = 0;
  std::string name;
  std::string kind;
  cv::Mat mask;            ///< the object's pixels in the teach frame
  Eigen::Vector3d centre;  ///< the truth centre, teach camera frame
  Eigen::Matrix3d axes;    ///< the truth axes (columns), teach camera frame
  Eigen::Vector3d size;    ///< the truth extent along each axis
};

struct TaughtObject {
  const TeachingExample* example = nullptr;
  std::unique_ptr<Recognizer::Model> model;
};

const synthetic::TruthObject* objectById(const synthetic::TruthFrame& truth, std::uint16_t id) {
  for (const auto& o : truth.objects)
    if (o.id == id) return &o;
  return nullptr;
}

// The pixels of every teachable object of the case under its truth image box, as an operator
// drawing a rectangle would mark it; `refused` counts the objects the ROI does not mark.
std::vector<TeachingExample> markTeachableObjects(const RecognitionCase& c, int& refused) {
  const Frame& frame = c.teach.rendered.frame;
  const FrameResults results = makeDetectorChain(DetectorConfig{}).process(frame);
  std::vector<TeachingExample> out;
  if (!results.segmentation || !results.planes) return out;
  for (std::uint16_t id : teachableObjects(c)) {
    const synthetic::TruthObject& object = *objectById(c.teach.rendered.truth, id);
    const cv::Rect roi = object.image_box;
    const auto marked = objectUnderRoi(frame.depth, frame.intrinsics, roi.tl(),
                                       roi.br() - cv::Point(1, 1), results.segmentation->labels,
                                       results.segmentation->segments, results.planes->frame);
    const auto* roi_object = std::get_if<RoiObject>(&marked);
    if (!roi_object) {
      ++refused;
      continue;
    }
    out.push_back(TeachingExample{id, object.name, object.kind, roi_object->mask, object.center,
                                  object.rotation, object.size});
  }
  return out;
}

std::vector<TaughtObject> teachExamples(Recognizer& recognizer, const Frame& frame,
                                        const std::vector<TeachingExample>& examples,
                                        RecognitionScore& score) {
  std::vector<TaughtObject> out;
  for (const TeachingExample& example : examples) {
    try {
      out.push_back(
          {&example, recognizer.teach(example.name, frame.depth, frame.intrinsics, example.mask)});
      ++score.taught;
    } catch (const std::invalid_argument&) {
      ++score.refused;
    }
  }
  return out;
}

// The one place a detection is judged, for the scoring and for withMinScore alike. Returns
// whether it found a required object.
bool countDetection(const ScoredDetection& d, const PoseTolerance& tolerance,
                    RecognitionScore& score) {
  const bool required = d.visible_share >= tolerance.min_visible_share;
  const bool right = d.error.translation_m <= tolerance.translation_m &&
                     d.error.rotation_deg <= tolerance.rotation_deg;
  if (right && d.visible_share >= tolerance.min_visible_share_present) {
    if (required) {
      ++score.found;
      ++score.by_kind[d.kind].found;
      score.translation_errors_m.push_back(d.error.translation_m);
      score.rotation_errors_deg.push_back(d.error.rotation_deg);
    }
    return required;
  }
  ++score.false_detections;
  if (required) ++score.wrong_pose;
  return false;
}

// The turns (model frame) that take a box with sides `size` along `axes` onto itself, to
// within `alike_m` at every corner: of the 24 that take its axes onto its axes (the signed
// permutations with determinant 1), those whose permuted sides differ from its own by at most
// 2 alike_m in norm. The corner (s/2) goes to P (s/2), nearest to the corner with its signs, so
// it moves by |P| s - s over 2.
std::vector<Eigen::Matrix3d> cuboidTurns(const Eigen::Matrix3d& axes, const Eigen::Vector3d& size,
                                         double alike_m) {
  Eigen::Matrix3d unit_axes;
  for (int k = 0; k < 3; ++k) unit_axes.col(k) = axes.col(k).normalized();
  std::vector<Eigen::Matrix3d> turns;
  std::array<int, 3> order{0, 1, 2};
  do {
    for (int signs = 0; signs < 8; ++signs) {
      Eigen::Matrix3d p = Eigen::Matrix3d::Zero();
      for (int row = 0; row < 3; ++row) p(row, order[row]) = (signs >> row & 1) ? -1.0 : 1.0;
      if (p.determinant() < 0.0) continue;
      const Eigen::Vector3d moved = p.cwiseAbs() * size - size;
      // Half turns move no corner: they are always in, whatever the tolerance.
      if (moved.norm() > 2.0 * alike_m + 1e-12) continue;
      turns.push_back(unit_axes * p * unit_axes.transpose());
    }
  } while (std::next_permutation(order.begin(), order.end()));
  return turns;
}

}  // namespace

double RecognitionScore::falsePerFrameForFive() const {
  if (views == 0 || taught == 0) return 0.0;
  const double models_per_case = static_cast<double>(taught) / std::max(cases, 1);
  return static_cast<double>(false_detections) / views * 5.0 / models_per_case;
}

ObjectSymmetry symmetryOfKind(const std::string& kind) {
  for (const char* revolved : {"tin", "cup", "lid", "bowl", "torus", "bin", "column"})
    if (kind == revolved) return ObjectSymmetry::kAxial;
  if (kind == "box" || kind == "book" || kind == "board") return ObjectSymmetry::kCuboid;
  return ObjectSymmetry::kNone;
}

PoseErrorDeg poseError(const Eigen::Isometry3f& estimated, const Eigen::Isometry3d& truth,
                       const Eigen::Vector3d& centre, const Eigen::Matrix3d& axes,
                       ObjectSymmetry symmetry, const Eigen::Vector3d& size, double alike_m) {
  const Eigen::Isometry3d e = estimated.cast<double>();
  PoseErrorDeg out;
  // Every symmetry turns about the centre, so the error there does not depend on it.
  out.translation_m = (e * centre - truth * centre).norm();
  if (symmetry == ObjectSymmetry::kAxial) {
    const Eigen::Vector3d axis = axes.col(2);
    out.rotation_deg = angleDegOfCosine(
        (e.linear() * axis).normalized().dot((truth.linear() * axis).normalized()));
    return out;
  }
  std::vector<Eigen::Matrix3d> turns{Eigen::Matrix3d::Identity()};
  if (symmetry == ObjectSymmetry::kCuboid) turns = cuboidTurns(axes, size, alike_m);
  out.rotation_deg = 180.0;
  for (const Eigen::Matrix3d& turn : turns) {
    const Eigen::Matrix3d r = e.linear() * (truth.linear() * turn).transpose();
    out.rotation_deg = std::min(out.rotation_deg, angleDegOfCosine((r.trace() - 1.0) / 2.0));
  }
  return out;
}

RecognitionScore scoreRecognition(Split split, int first, int count, int other_views,
                                  const ObjectModelParams& model_params,
                                  const ObjectMatchParams& match_params,
                                  const PoseTolerance& tolerance) {
  ShapesenseRecognizer ours(model_params, match_params);
  return scoreRecognizers({&ours}, split, first, count, other_views, tolerance).front();
}

std::vector<RecognitionScore> scoreRecognizers(const std::vector<Recognizer*>& recognizers,
                                               Split split, int first, int count, int other_views,
                                               const PoseTolerance& tolerance) {
  std::vector<RecognitionScore> scores(recognizers.size());
  for (int index = first; index < first + count; ++index) {
    const RecognitionCase c = recognitionCase(split, index, other_views);
    int refused_by_roi = 0;
    const std::vector<TeachingExample> examples = markTeachableObjects(c, refused_by_roi);
    for (std::size_t r = 0; r < recognizers.size(); ++r) {
      RecognitionScore& score = scores[r];
      ++score.cases;
      score.refused += refused_by_roi;
      const std::vector<TaughtObject> taught =
          teachExamples(*recognizers[r], c.teach.rendered.frame, examples, score);
      for (std::size_t view_index = 0; view_index < c.others.size(); ++view_index) {
        const RecognitionView& view = c.others[view_index];
        ++score.views;
        const Frame& frame = view.rendered.frame;
        const Eigen::Isometry3d truth = teachToView(c, view);
        auto start = Clock::now();
        const auto scene = recognizers[r]->describe(frame.depth, frame.intrinsics);
        score.describe_ms_total += msSince(start);
        for (const TaughtObject& t : taught) {
          const double share = visibleShare(c, view, t.example->id);
          const bool required = share >= tolerance.min_visible_share;
          if (required) {
            ++score.required;
            ++score.by_kind[t.example->kind].required;
          }
          start = Clock::now();
          const auto detection = recognizers[r]->find(*t.model, *scene);
          score.find_ms_total += msSince(start);
          ++score.searches;
          std::optional<PoseErrorDeg> error;
          bool found = false;
          if (detection) {
            error = poseError(detection->camera_from_model, truth, t.example->centre,
                              t.example->axes, symmetryOfKind(t.example->kind), t.example->size,
                              tolerance.translation_m);
            const ScoredDetection scored{t.example->kind, detection->score, share, *error};
            score.detections.push_back(scored);
            found = countDetection(scored, tolerance, score);
          }
          if (required && !found) {
            RecognitionMiss& miss = score.misses.emplace_back();
            miss.case_index = index;
            miss.view = static_cast<int>(view_index);
            miss.object = t.example->name;
            miss.visible_share = share;
            miss.detected = error;
            miss.truth_check = recognizers[r]->checkPose(*t.model, *scene, truth.cast<float>());
            if (detection)
              miss.reported_check =
                  recognizers[r]->checkPose(*t.model, *scene, detection->camera_from_model);
          }
        }
      }
    }
  }
  return scores;
}

RecognitionScore withMinScore(const RecognitionScore& score, double min_score,
                              const PoseTolerance& tolerance) {
  RecognitionScore out = score;
  out.found = out.wrong_pose = out.false_detections = 0;
  out.translation_errors_m.clear();
  out.rotation_errors_deg.clear();
  out.detections.clear();
  out.misses.clear();
  for (auto& [kind, recall] : out.by_kind) recall.found = 0;
  for (const ScoredDetection& d : score.detections) {
    if (d.score < min_score) continue;
    out.detections.push_back(d);
    countDetection(d, tolerance, out);
  }
  return out;
}

std::string formatRecallByKind(const RecognitionScore& score) {
  std::ostringstream out;
  out << "recall by kind:";
  const char* separator = " ";
  for (const auto& [kind, recall] : score.by_kind) {
    out << separator << kind << " " << recall.found << " of " << recall.required;
    separator = ", ";
  }
  return out.str();
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

std::string formatRecognitionMisses(const RecognitionScore& score) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  for (const RecognitionMiss& m : score.misses) {
    out << "missed: case " << m.case_index << " view " << m.view << " " << m.object << ", "
        << std::setprecision(2) << m.visible_share << " visible; ";
    if (m.detected) {
      out << "reported " << std::setprecision(1) << 1e3 * m.detected->translation_m << " mm, "
          << m.detected->rotation_deg << " deg off";
    } else {
      out << "not reported";
    }
    if (m.truth_check) {
      out << "; the truth pose " << (m.truth_check->failed.empty() ? "passes the check" : "fails: ")
          << m.truth_check->failed << "\n    truth:    " << m.truth_check->figures;
    }
    if (m.reported_check) out << "\n    reported: " << m.reported_check->figures;
    out << "\n";
  }
  return out.str();
}

}  // namespace shapesense::eval
