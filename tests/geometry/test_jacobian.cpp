// Per-element Jacobians against affine maps.
#include "geometry/fixtures.h"
#include "shapemap/geometry/jacobian.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <random>

using namespace shapemap;

TEST(Jacobian, TetJacobianOfAffineMapIsItsMatrix) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  shapemap::testing::tet_grid(3, 0.2, 1, V, T);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int rep = 0; rep < 5; ++rep) {
    Eigen::Matrix3d A;
    for (int i = 0; i < 9; ++i) A(i) = U(rng);
    if (rep == 0) A.col(0) = -A.col(0);  // orientation reversing too
    const Eigen::RowVector3d b(U(rng), U(rng), U(rng));
    const Eigen::MatrixXd X = (V * A.transpose()).rowwise() + b;
    const auto Dm_inv = tet_rest_inverse(V, T);
    std::vector<Eigen::Matrix3d> J;
    tet_jacobians(X, T, Dm_inv, J);
    ASSERT_EQ(J.size(), size_t(T.rows()));
    for (const auto& Jt : J) EXPECT_LT((Jt - A).cwiseAbs().maxCoeff(), 1e-12);
  }
  // Degenerate rest tet.
  Eigen::MatrixXd Vd(4, 3);
  Vd << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  Eigen::MatrixXi Td(1, 4);
  Td << 0, 1, 2, 3;
  EXPECT_THROW(tet_rest_inverse(Vd, Td), std::runtime_error);
}

TEST(Jacobian, TriangleJacobiansGiveMetricDistortion) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  shapemap::testing::icosphere(1, 1.0, V, F);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::Matrix3d A;
  for (int i = 0; i < 9; ++i) A(i) = U(rng);
  A += 2 * Eigen::Matrix3d::Identity();
  const Eigen::MatrixXd X = V * A.transpose();
  std::vector<Eigen::Matrix2d> J, Ir, Ix;
  triangle_jacobians(V, X, F, J);
  first_fundamental_forms(V, F, Ir);
  first_fundamental_forms(X, F, Ix);
  ASSERT_EQ(J.size(), size_t(F.rows()));
  for (int f = 0; f < F.rows(); ++f) {
    // Edge-coordinate forms are exact: I = E^T E.
    Eigen::Matrix<double, 3, 2> E;
    E.col(0) = (X.row(F(f, 1)) - X.row(F(f, 0))).transpose();
    E.col(1) = (X.row(F(f, 2)) - X.row(F(f, 0))).transpose();
    EXPECT_LT((Ix[f] - E.transpose() * E).cwiseAbs().maxCoeff(), 1e-12);
    // J^T J (rest frame) and Ibar^{-1} I (edge coordinates) are similar matrices:
    // same trace and determinant. det J > 0 (both frames follow the face orientation).
    const Eigen::Matrix2d C = J[f].transpose() * J[f];
    const Eigen::Matrix2d D = Ir[f].inverse() * Ix[f];
    EXPECT_NEAR(C.trace(), D.trace(), 1e-10 * D.trace());
    EXPECT_NEAR(C.determinant(), D.determinant(), 1e-10 * D.determinant());
    EXPECT_GT(J[f].determinant(), 0);
  }
  // A rigid motion has a rotation Jacobian.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  triangle_jacobians(V, (V * R.transpose()).rowwise() + Eigen::RowVector3d(1, 2, 3), F, J);
  for (const auto& Jf : J) EXPECT_LT((Jf - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
}
