// One linearised ICP step turning only about an axis (recognition/icp_step.h): point-to-plane
// rows of a box's corner, built for a known small motion, solved free and upright.

#include <gtest/gtest.h>

#include <vector>

#include <Eigen/Geometry>

#include "../../../core/src/recognition/icp_step.h"

namespace shapesense::detail {
namespace {

// The normal equations of point-to-plane pairs on three faces of a box corner 1 m ahead, whose
// residuals a small motion `truth` (turn, move) explains exactly: each row is (p x n, n) and
// its residual row . truth.
struct CornerEquations {
  IcpNormalMatrix normal_matrix = IcpNormalMatrix::Zero();
  IcpStep rhs = IcpStep::Zero();
  explicit CornerEquations(const IcpStep& truth) {
    const std::vector<Eigen::Vector3d> normals{Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitY(),
                                               -Eigen::Vector3d::UnitZ()};
    for (const Eigen::Vector3d& n : normals) {
      const Eigen::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
      for (int i = -3; i <= 3; ++i)
        for (int j = -3; j <= 3; ++j) {
          const Eigen::Vector3d p = Eigen::Vector3d(0.0, 0.0, 1.0) + 0.02 * i * e1 + 0.02 * j * e2;
          IcpStep row;
          row << p.cross(n), n;
          normal_matrix += row * row.transpose();
          rhs += row * row.dot(truth);
        }
    }
  }
};

const Eigen::Vector3d kUp(0.0, -0.8, -0.6);  // unit: a support tilted towards the camera

TEST(IcpStep, AnUprightStepFindsAMotionThatTurnsAboutItsAxis) {
  IcpStep truth;
  truth << 0.03 * kUp, Eigen::Vector3d(0.01, -0.004, 0.007);
  const CornerEquations corner(truth);
  const IcpStep upright = uprightStep(corner.normal_matrix, corner.rhs, kUp);
  EXPECT_LT((upright - truth).norm(), 1e-9);
  // The axis need not be given unit.
  EXPECT_LT((uprightStep(corner.normal_matrix, corner.rhs, 3.0 * kUp) - truth).norm(), 1e-9);
}

TEST(IcpStep, AnUprightStepTurnsOnlyAboutItsAxisWhereTheFreeStepTilts) {
  const Eigen::Vector3d across = kUp.unitOrthogonal();
  IcpStep truth;
  truth << 0.03 * kUp + 0.02 * across, Eigen::Vector3d(0.01, -0.004, 0.007);
  const CornerEquations corner(truth);
  const IcpStep free = corner.normal_matrix.ldlt().solve(corner.rhs);
  EXPECT_LT((free - truth).norm(), 1e-9);
  const IcpStep upright = uprightStep(corner.normal_matrix, corner.rhs, kUp);
  // Its turn lies along the axis, with nothing across it...
  EXPECT_LT(upright.head<3>().cross(kUp).norm(), 1e-12);
  EXPECT_GT(upright.head<3>().dot(kUp), 0.0);
  // ...and it fits the pairs no better than the free step, which has one more freedom.
  const auto cost = [&](const IcpStep& x) {
    return x.dot(corner.normal_matrix * x) - 2.0 * x.dot(corner.rhs);
  };
  EXPECT_GT(cost(upright), cost(free));
}

}  // namespace
}  // namespace shapesense::detail
