// Harmonic extension on tet meshes: exactness on affine data, the maximum principle, and
// the defining equation at every free vertex checked row by row.
#include "geometry/fixtures.h"
#include "shapemap/error.h"
#include "shapemap/geometry/harmonic_extension.h"
#include "shapemap/geometry/laplacian.h"
#include <Eigen/Sparse>
#include <gtest/gtest.h>
#include <algorithm>
#include <random>

using namespace shapemap;
using shapemap::testing::tet_grid;

namespace {

// The grid's boundary vertices fixed, its interior free.
std::vector<char> boundary_fixed(const Eigen::MatrixXd& V, const std::vector<int>& interior) {
  std::vector<char> fixed(V.rows(), 1);
  for (int v : interior) fixed[v] = 0;
  return fixed;
}

}  // namespace

TEST(HarmonicExtension, ExtendsAffineDataExactlyOnTheCubeGrid) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  std::vector<int> interior;
  tet_grid(5, 0.0, 1, V, T, &interior);  // Kuhn cubes: no negative cotangent weight
  Eigen::Matrix3d A;
  A << 1.2, -0.3, 0.1, 0.4, 0.9, -0.2, 0.0, 0.5, 1.1;
  const Eigen::MatrixXd affine = (V * A.transpose()).rowwise() + Eigen::RowVector3d(0.3, -1.0, 2.0);
  Eigen::MatrixXd X = affine;
  for (int v : interior) X.row(v).setZero();  // what is there must not matter
  const Eigen::MatrixXd H = harmonic_extension(V, T, X, boundary_fixed(V, interior));
  EXPECT_LT((H - affine).cwiseAbs().maxCoeff(), 1e-10);
}

TEST(HarmonicExtension, SolvesItsEquationAndObeysTheMaximumPrinciple) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  std::vector<int> interior;
  tet_grid(5, 0.35, 7, V, T, &interior);  // jittered: some cotangent weights are negative
  const std::vector<char> fixed = boundary_fixed(V, interior);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::MatrixXd X(V.rows(), 2);
  for (int v = 0; v < V.rows(); ++v) X.row(v) << U(rng), U(rng);
  const Eigen::MatrixXd H = harmonic_extension(V, T, X, fixed);
  // Fixed rows kept; free rows inside the fixed rows' range, column by column.
  for (int v = 0; v < V.rows(); ++v)
    if (fixed[v]) EXPECT_EQ(H.row(v), X.row(v));
  for (int c = 0; c < 2; ++c) {
    double lo = 1e300, hi = -1e300;
    for (int v = 0; v < V.rows(); ++v)
      if (fixed[v]) lo = std::min(lo, X(v, c)), hi = std::max(hi, X(v, c));
    for (int v : interior) {
      EXPECT_GE(H(v, c), lo - 1e-12);
      EXPECT_LE(H(v, c), hi + 1e-12);
    }
  }
  // Each free row: sum_u w_vu (H_v - H_u) = 0 with w = max(0, cotangent weight) + eps and
  // eps = 1e-3 of the mean positive weight (the header's definition), from the Laplacian.
  const Eigen::SparseMatrix<double> L = tet_cotan_laplacian(V, T);
  double sum = 0;
  int count = 0, dropped = 0;
  for (int c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it)
      if (it.row() != it.col()) {
        if (it.value() < 0) sum -= it.value(), ++count;
        else if (it.value() > 0) ++dropped;
      }
  ASSERT_GT(dropped, 0) << "the jitter should give negative cotangent weights";
  const double eps = 1e-3 * sum / count;
  Eigen::MatrixXd residual = Eigen::MatrixXd::Zero(V.rows(), 2);
  for (int c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it)
      if (it.row() != it.col())
        residual.row(it.row()) += (std::max(0.0, -it.value()) + eps) * (H.row(it.row()) - H.row(c));
  for (int v : interior) EXPECT_LT(residual.row(v).norm(), 1e-10) << "vertex " << v;
}

TEST(HarmonicExtension, RefusesAComponentWithoutFixedVertices) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  tet_grid(2, 0.0, 1, V, T);
  EXPECT_THROW(harmonic_extension(V, T, V, std::vector<char>(V.rows(), 0)), Error);
  EXPECT_THROW(harmonic_extension(V, T, V, std::vector<char>(3, 1)), Error);
}
