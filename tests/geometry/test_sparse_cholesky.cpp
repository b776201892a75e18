// SparseCholesky (CHOLMOD) against dense solves.
#include "geometry/fixtures.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <random>

using namespace shapemap;

namespace {
Eigen::SparseMatrix<double> test_matrix(double shift) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  shapemap::testing::icosphere(2, 1.0, V, F);
  Eigen::SparseMatrix<double> A = cotan_laplacian(V, F);
  const Eigen::VectorXd M = lumped_mass(V, F);
  for (int i = 0; i < A.rows(); ++i) A.coeffRef(i, i) += shift * M(i);
  A.makeCompressed();
  return A;
}
}  // namespace

TEST(SparseCholesky, SolvesMatchDenseAndRefactor) {
  const Eigen::SparseMatrix<double> A = test_matrix(1.0);
  SparseCholesky chol;
  chol.compute(A);
  EXPECT_EQ(chol.rows(), A.rows());
  const Eigen::MatrixXd B = Eigen::MatrixXd::Random(A.rows(), 5);
  const Eigen::MatrixXd ref = Eigen::MatrixXd(A).ldlt().solve(B);
  EXPECT_LT((chol.solve(B) - ref).norm(), 1e-10 * ref.norm());
  const Eigen::VectorXd x = chol.solve(Eigen::VectorXd(B.col(2)));
  EXPECT_LT((x - ref.col(2)).norm(), 1e-10 * ref.norm());
  // Lower triangle only gives the same factor.
  SparseCholesky lower;
  lower.compute(Eigen::SparseMatrix<double>(A.triangularView<Eigen::Lower>()));
  EXPECT_LT((lower.solve(B) - ref).norm(), 1e-10 * ref.norm());
  // Refactor with the same pattern, different values.
  const Eigen::SparseMatrix<double> A2 = test_matrix(3.0);
  chol.factorize(A2);
  const Eigen::MatrixXd ref2 = Eigen::MatrixXd(A2).ldlt().solve(B);
  EXPECT_LT((chol.solve(B) - ref2).norm(), 1e-10 * ref2.norm());
  // Move.
  SparseCholesky moved = std::move(chol);
  EXPECT_LT((moved.solve(B) - ref2).norm(), 1e-10 * ref2.norm());
}

TEST(SparseCholesky, ConcurrentSolvesAreSafe) {
  const Eigen::SparseMatrix<double> A = test_matrix(1.0);
  SparseCholesky chol;
  chol.compute(A);
  const int k = 16;
  const Eigen::MatrixXd B = Eigen::MatrixXd::Random(A.rows(), k);
  std::vector<Eigen::VectorXd> serial(k), parallel(k);
  for (int c = 0; c < k; ++c) serial[c] = chol.solve(Eigen::VectorXd(B.col(c)));
#pragma omp parallel for num_threads(4) schedule(dynamic, 1)
  for (int c = 0; c < k; ++c) parallel[c] = chol.solve(Eigen::VectorXd(B.col(c)));
  for (int c = 0; c < k; ++c) EXPECT_EQ(serial[c], parallel[c]);
}

TEST(SparseCholesky, RejectsIndefiniteAndMisuse) {
  SparseCholesky chol;
  EXPECT_THROW(chol.solve(Eigen::VectorXd(Eigen::VectorXd::Ones(3))), shapemap::Error);
  // Laplacian without shift is singular, with a negative shift indefinite.
  EXPECT_THROW(chol.compute(test_matrix(-1.0)), shapemap::Error);
  chol.compute(test_matrix(1.0));
  EXPECT_THROW(chol.solve(Eigen::VectorXd(Eigen::VectorXd::Ones(3))), shapemap::Error);
}
