// SparseCholesky (CHOLMOD) against dense solves.
#include "geometry/fixtures.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include "shapemap/task_pair.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <omp.h>
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

// Two supernodal factorizations and their solves at once (run_pair, as the volume map's
// two directions do) give the factors of one after the other, bit for bit, in every round,
// whatever BLAS is installed (a serial OpenBLAS serializes them inside); and the process-wide
// OpenMP setting that the supernodal calls change while they run is restored.
TEST(SparseCholesky, ConcurrentFactorizationsMatchOneAfterTheOther) {
  Eigen::MatrixXd V1, V2;
  Eigen::MatrixXi T1, T2;
  shapemap::testing::tet_grid(11, 0.2, 1, V1, T1);  // fill large enough for BLAS-3 supernodes
  shapemap::testing::tet_grid(10, 0.2, 2, V2, T2);
  auto spd = [](const Eigen::MatrixXd& V, const Eigen::MatrixXi& T, double shift) {
    Eigen::SparseMatrix<double> A = tet_cotan_laplacian(V, T);
    for (int i = 0; i < A.rows(); ++i) A.coeffRef(i, i) += shift;
    A.makeCompressed();
    return A;
  };
  const Eigen::SparseMatrix<double> A1 = spd(V1, T1, 0.1), A2 = spd(V2, T2, 0.2);
  const Eigen::MatrixXd B1 = Eigen::MatrixXd::Random(A1.rows(), 3), B2 = Eigen::MatrixXd::Random(A2.rows(), 3);
  SparseCholesky c1, c2;
  c1.compute(A1);
  c2.compute(A2);
  const Eigen::MatrixXd ref1 = c1.solve(B1), ref2 = c2.solve(B2);
  EXPECT_LT((Eigen::MatrixXd(A1) * ref1 - B1).norm(), 1e-8 * B1.norm());
  const int levels = omp_get_max_active_levels();
  for (int round = 0; round < 8; ++round) {
    SparseCholesky d1, d2;
    d1.analyze(A1);
    d2.analyze(A2);
    Eigen::MatrixXd x1, x2;
    run_pair([&] { d1.factorize(A1); x1 = d1.solve(B1); }, [&] { d2.factorize(A2); x2 = d2.solve(B2); }, true);
    EXPECT_EQ(x1, ref1) << "round " << round;
    EXPECT_EQ(x2, ref2) << "round " << round;
  }
  EXPECT_EQ(omp_get_max_active_levels(), levels);
}

TEST(SparseCholesky, RunPairRethrowsATaskError) {
  int ran = 0;
  EXPECT_THROW(run_pair([&] { ++ran; }, [] { throw shapemap::Error("second task"); }, true), shapemap::Error);
  EXPECT_THROW(run_pair([] { throw shapemap::Error("first task"); }, [&] { ++ran; }, false), shapemap::Error);
  EXPECT_EQ(ran, 2);  // the other task still ran to its end
}
