// Mass matrices and mean curvature.
#include "geometry/fixtures.h"
#include "shapemap/geometry/curvature.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/mesh.h"
#include <gtest/gtest.h>
#include <cmath>

using namespace shapemap;
using shapemap::testing::flat_grid;
using shapemap::testing::icosphere;
using shapemap::testing::tet_grid;

TEST(Mass, TotalsEqualAreaAndVolume) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  icosphere(3, 1.7, V, F);
  const double area = surface_area(V, F);
  EXPECT_NEAR(lumped_mass(V, F).sum(), area, 1e-12 * area);
  EXPECT_NEAR(voronoi_mass(V, F).sum(), area, 1e-12 * area);
  EXPECT_GT(lumped_mass(V, F).minCoeff(), 0);
  EXPECT_GT(voronoi_mass(V, F).minCoeff(), 0);
  // A jittered flat grid has obtuse triangles: the mixed areas still tile [0,1]^2.
  flat_grid(10, 10, 0.2, 3, V, F);
  EXPECT_NEAR(voronoi_mass(V, F).sum(), 1.0, 1e-12);
  EXPECT_NEAR(lumped_mass(V, F).sum(), 1.0, 1e-12);
  Eigen::MatrixXi T;
  tet_grid(3, 0.2, 4, V, T);
  EXPECT_NEAR(tet_lumped_mass(V, T).sum(), 1.0, 1e-12);
}

TEST(Mass, VoronoiCellsOfSingleTriangles) {
  // Right isosceles triangle (non-obtuse): Voronoi areas 1/4 at the right angle, 1/8 others.
  Eigen::MatrixXd V(3, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  Eigen::MatrixXi F(1, 3);
  F << 0, 1, 2;
  Eigen::VectorXd M = voronoi_mass(V, F);
  EXPECT_NEAR(M(0), 0.25, 1e-14);
  EXPECT_NEAR(M(1), 0.125, 1e-14);
  EXPECT_NEAR(M(2), 0.125, 1e-14);
  // Equilateral: a third each.
  V << 0, 0, 0, 1, 0, 0, 0.5, std::sqrt(3.0) / 2, 0;
  M = voronoi_mass(V, F);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(M(i), std::sqrt(3.0) / 12, 1e-14);
  // Obtuse at vertex 2: area/2 there, area/4 elsewhere.
  V << 0, 0, 0, 2, 0, 0, 1, 0.2, 0;
  M = voronoi_mass(V, F);
  EXPECT_NEAR(M(2), 0.1, 1e-14);
  EXPECT_NEAR(M(0), 0.05, 1e-14);
  EXPECT_NEAR(M(1), 0.05, 1e-14);
}

TEST(Curvature, SphereMeanCurvatureIsInverseRadius) {
  for (double r : {0.5, 3.0}) {
    Eigen::MatrixXd V;
    Eigen::MatrixXi F;
    icosphere(4, r, V, F);
    const Eigen::VectorXd H = mean_curvature(V, F);
    // Measured at level 4: max |H r - 1| = 8.7e-6, mean 1.7e-6 (3.5e-5 max at level 3).
    EXPECT_LT((H * r - Eigen::VectorXd::Ones(H.size())).cwiseAbs().maxCoeff(), 1e-3);
    EXPECT_LT(std::abs(H.mean() * r - 1.0), 1e-4);
    // Inward orientation flips the sign.
    Eigen::MatrixXi Fi = F;
    Fi.col(1).swap(Fi.col(2));
    EXPECT_LT(mean_curvature(V, Fi).maxCoeff(), 0);
  }
  // A flat grid has zero mean curvature in the interior.
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  std::vector<int> interior;
  flat_grid(8, 8, 0.2, 5, V, F, &interior);
  const Eigen::VectorXd H = mean_curvature(V, F);
  for (int i : interior) EXPECT_NEAR(H(i), 0.0, 1e-10);
}
