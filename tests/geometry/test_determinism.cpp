// Results of the parallel geometry operators do not depend on the thread count.
#include "geometry/fixtures.h"
#include "shapemap/geometry/geodesics.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/geometry/svd3.h"
#include <gtest/gtest.h>
#include <omp.h>
#include <random>

using namespace shapemap;

TEST(GeometryDeterminism, SameResultsWithOneAndThreeThreads) {
  const int saved = omp_get_max_threads();
  Eigen::MatrixXd V, SV;
  Eigen::MatrixXi T, F;
  shapemap::testing::tet_grid(6, 0.2, 3, V, T);
  shapemap::testing::icosphere(3, 1.0, SV, F);
  std::mt19937 rng(5);
  std::normal_distribution<double> N;
  std::vector<Eigen::Matrix3d> A(3000);
  for (auto& a : A)
    for (int i = 0; i < 9; ++i) a(i) = N(rng);
  struct Out {
    Eigen::MatrixXd L, Ltri, D;
    Eigen::VectorXd M;
    std::vector<SignedSVD3> svd;
  } out[2];
  const int threads[2] = {1, 3};
  for (int r = 0; r < 2; ++r) {
    omp_set_num_threads(threads[r]);
    out[r].L = Eigen::MatrixXd(tet_cotan_laplacian(V, T));
    out[r].Ltri = Eigen::MatrixXd(cotan_laplacian(SV, F));
    out[r].M = voronoi_mass(SV, F);
    HeatGeodesics geo(SV, F);
    out[r].D = geo.distances({0, 10, 100, 200, 300, 400, 500});
    signed_svd3_batch(A, out[r].svd);
  }
  omp_set_num_threads(saved);
  EXPECT_EQ(out[0].L, out[1].L);
  EXPECT_EQ(out[0].Ltri, out[1].Ltri);
  EXPECT_EQ(out[0].M, out[1].M);
  EXPECT_EQ(out[0].D, out[1].D);
  for (size_t i = 0; i < A.size(); ++i) {
    EXPECT_EQ(out[0].svd[i].S, out[1].svd[i].S);
    EXPECT_EQ(out[0].svd[i].U, out[1].svd[i].U);
  }
}
