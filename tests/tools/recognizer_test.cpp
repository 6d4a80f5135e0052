// The recognizer interface of the recognition scoring: every method is taught from the same
// pixels and searched in the same views, shapesense's own method scores through it as
// scoreRecognition does, and withMinScore re-counts a score at a higher detection threshold.

#include "shapesense/eval/recognizer.h"

#include <gtest/gtest.h>

#include <limits>

#include "shapesense/eval/recognition_eval.h"

namespace shapesense::eval {
namespace {

// Teaches anything and "finds" every model where it was taught, with a score that grows with
// each call: enough to check what the scoring counts, without any matching.
class TaughtPoseRecognizer final : public Recognizer {
 public:
  std::string name() const override { return "taught pose"; }
  std::unique_ptr<Model> teach(const std::string&, const cv::Mat&, const CameraIntrinsics&,
                               const cv::Mat& mask) override {
    EXPECT_GT(cv::countNonZero(mask), 0);
    return std::make_unique<Model>();
  }
  std::unique_ptr<Scene> describe(const cv::Mat&, const CameraIntrinsics&) override {
    return std::make_unique<Scene>();
  }
  std::optional<RecognizerDetection> find(const Model&, const Scene&) override {
    return RecognizerDetection{Eigen::Isometry3f::Identity(), static_cast<double>(++calls_)};
  }

 private:
  int calls_ = 0;
};

void expectSameCounts(const RecognitionScore& a, const RecognitionScore& b) {
  EXPECT_EQ(a.cases, b.cases);
  EXPECT_EQ(a.views, b.views);
  EXPECT_EQ(a.taught, b.taught);
  EXPECT_EQ(a.refused, b.refused);
  EXPECT_EQ(a.required, b.required);
  EXPECT_EQ(a.found, b.found);
  EXPECT_EQ(a.wrong_pose, b.wrong_pose);
  EXPECT_EQ(a.false_detections, b.false_detections);
  EXPECT_EQ(a.translation_errors_m, b.translation_errors_m);
  EXPECT_EQ(a.rotation_errors_deg, b.rotation_errors_deg);
  EXPECT_EQ(a.searches, b.searches);
  ASSERT_EQ(a.by_kind.size(), b.by_kind.size());
  for (const auto& [kind, recall] : a.by_kind) {
    ASSERT_TRUE(b.by_kind.contains(kind)) << kind;
    EXPECT_EQ(recall.required, b.by_kind.at(kind).required) << kind;
    EXPECT_EQ(recall.found, b.by_kind.at(kind).found) << kind;
  }
}

// The kinds' counts add up to the totals.
void expectKindsAddUp(const RecognitionScore& s) {
  int required = 0, found = 0;
  for (const auto& [kind, recall] : s.by_kind) {
    required += recall.required;
    found += recall.found;
  }
  EXPECT_EQ(required, s.required);
  EXPECT_EQ(found, s.found);
}

TEST(Recognizer, EveryMethodIsScoredOnTheSameObjectsAndViewsAsOurs) {
  const RecognitionScore alone = scoreRecognition(Split::kValidation, 0, 2);
  ShapesenseRecognizer ours;
  TaughtPoseRecognizer taught_pose;
  const auto scores = scoreRecognizers({&taught_pose, &ours}, Split::kValidation, 0, 2);
  ASSERT_EQ(scores.size(), 2u);
  // Ours scored beside another method: exactly what scoreRecognition counts alone.
  expectSameCounts(scores[1], alone);
  ASSERT_GT(alone.required, 0);
  expectKindsAddUp(alone);
  EXPECT_GE(alone.by_kind.size(), 2u);  // the cases hold several kinds of object
  // The other method is taught the same objects and asked about the same (object, view) pairs.
  const RecognitionScore& other = scores[0];
  EXPECT_EQ(other.taught + other.refused, alone.taught + alone.refused);
  EXPECT_EQ(other.searches, alone.searches);
  EXPECT_EQ(other.required, alone.required);
  // It answers every search: each detection is counted once, found or false.
  EXPECT_EQ(static_cast<int>(other.detections.size()), other.searches);
  EXPECT_LE(other.found + other.false_detections, other.searches);
}

TEST(Recognizer, WithMinScoreDropsOnlyTheDetectionsBelowTheThreshold) {
  TaughtPoseRecognizer taught_pose;
  const RecognitionScore score = scoreRecognizers({&taught_pose}, Split::kValidation, 0, 1).front();
  ASSERT_GT(score.searches, 2);
  expectSameCounts(withMinScore(score, -std::numeric_limits<double>::infinity()), score);

  const RecognitionScore none = withMinScore(score, std::numeric_limits<double>::infinity());
  EXPECT_EQ(none.found + none.false_detections + none.wrong_pose, 0);
  EXPECT_TRUE(none.detections.empty());
  EXPECT_EQ(none.required, score.required);
  expectKindsAddUp(none);
  EXPECT_EQ(none.searches, score.searches);

  // Scores are 1, 2, 3...: a threshold of 3 keeps all but the first two.
  const RecognitionScore most = withMinScore(score, 3.0);
  EXPECT_EQ(most.detections.size(), score.detections.size() - 2);
  EXPECT_LE(most.false_detections, score.false_detections);
  EXPECT_GE(most.false_detections, score.false_detections - 2);
}

}  // namespace
}  // namespace shapesense::eval
