// Latitude-longitude map (latitude_longitude.h): on the round sphere it must reproduce the
// sphere up to a rotation (the analytic reference: latitude circles are the level sets of
// the harmonic latitude by symmetry, the polar angle by area is then exact, the harmonic
// longitude is the azimuth); on a 16:1 ellipsoid the poles sit at the ends of the long axis
// and the latitude grows along it.
#include "shapemap/generate.h"
#include "shapemap/mesh.h"
#include "shapemap/volume/latitude_longitude.h"
#include <gtest/gtest.h>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <vector>
#include <cstdio>

using namespace shapemap;

TEST(LatitudeLongitude, RoundSphereIsARotation) {
  const TriMesh s = make_sphere(2000);
  const LatitudeLongitudeMap ll = latitude_longitude_map(s);
  ASSERT_EQ(ll.S.rows(), s.V.rows());
  const Eigen::MatrixXd V = s.V.rowwise().normalized();
  EXPECT_LT((ll.S.rowwise().norm().array() - 1).abs().maxCoeff(), 1e-12);
  EXPECT_NEAR(ll.S(ll.pole_a, 2), 1.0, 1e-12);
  EXPECT_NEAR(ll.S(ll.pole_b, 2), -1.0, 1e-12);
  EXPECT_LT(V.row(ll.pole_a).dot(V.row(ll.pole_b)), -0.99);  // antipodal
  EXPECT_EQ(ll.latitude(ll.pole_a), 0.0);
  EXPECT_EQ(ll.latitude(ll.pole_b), 1.0);
  ASSERT_GE(ll.date_line.size(), 3u);
  EXPECT_EQ(ll.date_line.front(), ll.pole_a);
  EXPECT_EQ(ll.date_line.back(), ll.pole_b);
  // Best rotation R with S ~ V R (Procrustes), then the residual.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(V.transpose() * ll.S, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  const double det = R.determinant();
  const Eigen::VectorXd res = (V * R - ll.S).rowwise().norm();
  std::printf("sphere %d vertices: det %.3f, residual mean %.4g max %.4g, folded %d\n", int(V.rows()), det,
              res.mean(), res.maxCoeff(), int(s.F.rows()) - positive_origin_cones(ll.S, s.F));
  EXPECT_GT(det, 0);  // orientation kept, not mirrored
  EXPECT_LT(res.mean(), 0.02);
  EXPECT_LT(res.maxCoeff(), 0.08);
  EXPECT_EQ(positive_origin_cones(ll.S, s.F), int(s.F.rows()));
}

TEST(LatitudeLongitude, ElongatedEllipsoidPolesAtTheEnds) {
  TriMesh s = make_sphere(2500);
  s.V.col(2) *= 16.0;
  const LatitudeLongitudeMap ll = latitude_longitude_map(s);
  ASSERT_EQ(ll.S.rows(), s.V.rows());
  const double zmax = s.V.col(2).cwiseAbs().maxCoeff();
  EXPECT_GT(std::abs(s.V(ll.pole_a, 2)), 0.99 * zmax);
  EXPECT_GT(std::abs(s.V(ll.pole_b, 2)), 0.99 * zmax);
  EXPECT_LT(s.V(ll.pole_a, 2) * s.V(ll.pole_b, 2), 0.0);
  // The latitude grows along the axis: Spearman rank correlation of u with the signed axis
  // coordinate (u is log-like next to the point poles, so not linear there).
  const Eigen::Index n = s.V.rows();
  const double sgn = s.V(ll.pole_a, 2) < 0 ? 1.0 : -1.0;
  auto ranks = [n](const Eigen::VectorXd& x) {
    std::vector<int> o(n);
    for (Eigen::Index i = 0; i < n; ++i) o[i] = int(i);
    std::sort(o.begin(), o.end(), [&](int p, int q) { return x(p) < x(q); });
    Eigen::VectorXd r(n);
    for (Eigen::Index k = 0; k < n; ++k) r(o[k]) = double(k);
    return r;
  };
  const Eigen::VectorXd ru = ranks(ll.latitude), rz = ranks(sgn * s.V.col(2));
  const double d2 = (ru - rz).squaredNorm(), nn = double(n);
  const double spearman = 1 - 6 * d2 / (nn * (nn * nn - 1));
  const int folded = int(s.F.rows()) - positive_origin_cones(ll.S, s.F);
  std::printf("ellipsoid 16:1: Spearman(latitude, axis) %.5f, folded %d of %d\n", spearman, folded, int(s.F.rows()));
  EXPECT_GT(spearman, 0.99);
  EXPECT_EQ(folded, 0);  // measured: Spearman 0.9998, 0 folded of 5,120
}
