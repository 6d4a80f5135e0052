// Tests of the bowl evaluation: the difficult rule and VOC matching with difficult boxes.
#include <gtest/gtest.h>

#include "shapesense/core/bowls/bowl_eval.h"

namespace shapesense {
namespace {

TEST(BowlEval, DifficultRuleCoversTinySparseAndMostlyHiddenBowls) {
  const cv::Rect box(100, 100, 40, 30);  // 1200 px
  EXPECT_FALSE(isDifficultBowl(box, 900, 0.95));
  EXPECT_FALSE(isDifficultBowl(box, 900, kMinVisibleBowlFraction));
  EXPECT_TRUE(isDifficultBowl(box, 900, 0.49));            // less than half of the bowl seen
  EXPECT_TRUE(isDifficultBowl(box, 299, 1.0));             // under a quarter of the box covered
  EXPECT_TRUE(isDifficultBowl({0, 0, 19, 30}, 500, 1.0));  // too narrow
  EXPECT_TRUE(isDifficultBowl({0, 0, 40, 11}, 400, 1.0));  // too low
  // Training keeps partly hidden bowls: only the tiny-or-sparse part applies there.
  EXPECT_FALSE(isTinyOrSparseBowl(box, 900));
  EXPECT_TRUE(isTinyOrSparseBowl(box, 299));
}

TEST(BowlEval, DifficultBoxesAreNeitherMissesNorFalsePositives) {
  BowlEvalFrame frame;
  frame.truth = {{{10, 10, 40, 30}, false}, {{200, 10, 40, 30}, true}, {{400, 10, 40, 30}, false}};
  frame.detections = {{{11, 10, 40, 30}, 30.0, "middle"},   // the first bowl
                      {{201, 11, 40, 30}, 25.0, "middle"},  // the difficult one: ignored
                      {{300, 300, 40, 30}, 20.0, "side"}};  // nothing there
  const BowlEvalResult r = evaluateBowlDetections({frame}, 0.5, 1.0);
  EXPECT_EQ(r.positives, 2);
  EXPECT_EQ(r.true_positives, 1);
  EXPECT_EQ(r.false_positives, 1);
  EXPECT_DOUBLE_EQ(r.max_recall, 0.5);
  // Precision 1 up to recall 0.5, never more recall: all-point AP = 0.5.
  EXPECT_NEAR(r.ap, 0.5, 1e-9);
}

}  // namespace
}  // namespace shapesense
