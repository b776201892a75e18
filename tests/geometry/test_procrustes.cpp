// Best rotation (orthogonal Procrustes without reflections) against the exact answer and a
// brute-force search over rotations.
#include "shapemap/geometry/procrustes.h"
#include "geometry/fixtures.h"
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <random>

using namespace shapemap;
using shapemap::testing::random_rotation;

namespace {

double procrustes_misfit(const Eigen::Matrix3d& R, const Eigen::MatrixXd& P, const Eigen::MatrixXd& Q) {
  return (P * R.transpose() - Q).squaredNorm();  // rows: sum_i ||R p_i - q_i||^2
}

}  // namespace

TEST(Procrustes, RecoversAnExactRotation) {
  std::mt19937 rng(7);
  std::normal_distribution<double> N;
  for (int rep = 0; rep < 50; ++rep) {
    const Eigen::Matrix3d R0 = random_rotation(rng);
    Eigen::MatrixXd P(6, 3);
    for (Eigen::Index i = 0; i < P.size(); ++i) P(i) = N(rng);
    const Eigen::MatrixXd Q = P * R0.transpose();
    const Eigen::Matrix3d R = procrustes_rotation(Q.transpose() * P);  // C = sum q p^T
    EXPECT_LE((R - R0).norm(), 1e-12) << "rep " << rep;
  }
}

TEST(Procrustes, BeatsEveryRotationOfABruteForceSearchAndNeverReflects) {
  std::mt19937 rng(11);
  std::normal_distribution<double> N;
  for (int rep = 0; rep < 20; ++rep) {
    Eigen::MatrixXd P(5, 3), Q(5, 3);
    for (Eigen::Index i = 0; i < P.size(); ++i) P(i) = N(rng), Q(i) = N(rng);
    if (rep % 2 == 1) Q.col(0) = -P.col(0) + 0.1 * Q.col(0);  // a mirror image: det C < 0
    const Eigen::Matrix3d R = procrustes_rotation(Q.transpose() * P);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
    EXPECT_LE((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    const double best = procrustes_misfit(R, P, Q);
    for (int k = 0; k < 20000; ++k) EXPECT_GE(procrustes_misfit(random_rotation(rng), P, Q), best - 1e-12);
  }
}
