// The papers' metrics against answers computed by hand: an affine map's det J^ and ARAP
// energy (symmetric volume maps, Sec. 6.1), d^ between two concentric spheres (Eqs. 27-28),
// D_V of a map that scales half of a cube (isovolumetric ball, Eq. 45), and the geodesic
// error of the antipodal map on a sphere (BIM, Sec. 8.2), and the round trips behind E_R
// (Eq. 18) of a map whose way back moves each vertex by a known amount.
#include "geometry/fixtures.h"
#include "shapemap/eval/ball_metrics.h"
#include "shapemap/eval/surface_metrics.h"
#include "shapemap/eval/volume_metrics.h"
#include "volume/ball_test_mesh.h"
#include <gtest/gtest.h>
#include <cmath>

using namespace shapemap;
using testing_ball::blob_tets;
using testing_ball::cube_tets;

TEST(MetricsClosedForm, ShearHasKnownNormalizedDeterminantAndArapEnergy) {
  // X = A V with the shear A = [1 1 0; 0 1 0; 0 0 1] (det 1, so both unit-volume frames
  // keep it): J = A on every tet. Its columns normalized: (1,0,0), (1,1,0)/sqrt2, (0,0,1),
  // det J^ = 1/sqrt2. Its singular values are the golden ratio phi, 1/phi and 1, so
  // f_ARAP = (phi - 1)^2 + (1/phi - 1)^2 = 0.5278640, E_ARAP = f / 2 on unit volume.
  const TetMesh S = cube_tets(3);
  Eigen::Matrix3d A;
  A << 1, 1, 0, 0, 1, 0, 0, 0, 1;
  TetMesh T = S;
  T.V = S.V * A.transpose();
  const VolumeMapMetrics m = volume_map_metrics(S, T, T.V);
  const double phi = (1 + std::sqrt(5.0)) / 2;
  const double f = (phi - 1) * (phi - 1) + (1 / phi - 1) * (1 / phi - 1);
  EXPECT_NEAR(f, 0.5278640450, 1e-9);
  EXPECT_EQ(m.n_inv, 0);
  EXPECT_NEAR(m.det_mean, 1 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(m.det_sd, 0.0, 1e-12);
  EXPECT_NEAR(m.E_arap, f / 2, 1e-12);
  EXPECT_NEAR(m.d_max, 0.0, 1e-12);  // X is the target itself
  EXPECT_NEAR(m.d_avg, 0.0, 1e-12);
}

TEST(MetricsClosedForm, ScalingIsRigidInUnitVolumeFramesAndAMirrorInvertsEverything) {
  const TetMesh S = cube_tets(2);
  TetMesh T = S;
  T.V = 3.0 * S.V;
  const VolumeMapMetrics m = volume_map_metrics(S, T, T.V);
  EXPECT_NEAR(m.E_arap, 0.0, 1e-12);
  EXPECT_NEAR(m.det_mean, 1.0, 1e-12);
  EXPECT_EQ(m.n_inv, 0);
  Eigen::MatrixXd X = S.V;
  X.col(2) *= -1;
  const VolumeMapMetrics r = volume_map_metrics(S, S, X);
  EXPECT_EQ(r.n_inv, S.num_tets());
  // A mirror's singular values are all 1 (signed SVD: one is -1): f_ARAP = (-1 - 1)^2 = 4.
  EXPECT_NEAR(r.E_arap, 2.0, 1e-12);
}

TEST(MetricsClosedForm, RoundTripsOfAWayBackThatMovesEachVertexByAKnownAmount) {
  // P_ij puts each vertex of the cube at itself (a corner of one of its tets); X_ji moves
  // vertex v by delta_v = 0.01 (v mod 3) along x. So v's round trip is |delta_v| and, on
  // unit volume (scale s), E_R = sum_v C_v (s delta_v)^2 / c^2 with the lumped mass C_v =
  // a quarter of the unit volumes of v's tets and c = 1.
  const TetMesh S = cube_tets(3);
  const int n = S.num_vertices();
  BarycentricMap P;
  P.elem.resize(n);
  P.bary.setZero(n, 4);
  for (int k = 0; k < S.num_tets(); ++k)
    for (int q = 0; q < 4; ++q) {
      P.elem(S.T(k, q)) = k;
      P.bary.row(S.T(k, q)).setZero();
      P.bary(S.T(k, q), q) = 1;
    }
  Eigen::MatrixXd Xji = S.V;
  Eigen::VectorXd delta(n);
  for (int v = 0; v < n; ++v) Xji(v, 0) += delta(v) = 0.01 * (v % 3);
  const Eigen::VectorXd rt = round_trip_distances(S, S, P, Xji);
  for (int v = 0; v < n; ++v) EXPECT_NEAR(rt(v), delta(v), 1e-15);
  // By hand: tet volumes, the unit-volume scale, the lumped masses, the boundary.
  Eigen::VectorXd mass = Eigen::VectorXd::Zero(n);
  double volume = 0;
  for (int k = 0; k < S.num_tets(); ++k) {
    Eigen::Matrix3d D;
    for (int j = 0; j < 3; ++j) D.col(j) = (S.V.row(S.T(k, j + 1)) - S.V.row(S.T(k, 0))).transpose();
    const double vk = std::abs(D.determinant()) / 6;
    volume += vk;
    for (int q = 0; q < 4; ++q) mass(S.T(k, q)) += vk / 4;
  }
  const double s = std::cbrt(1 / volume), lo = S.V.minCoeff(), hi = S.V.maxCoeff();
  double E = 0, E_boundary = 0;
  for (int v = 0; v < n; ++v) {
    const double e = mass(v) / volume * (s * delta(v)) * (s * delta(v));
    E += e;
    const bool on_boundary = (S.V.row(v).array() == lo).any() || (S.V.row(v).array() == hi).any();
    if (on_boundary) E_boundary += e;
  }
  const VolumeMapMetrics m = volume_map_metrics(S, S, S.V, &P, &Xji);
  EXPECT_GT(E, 0);
  EXPECT_NEAR(m.E_R, E, 1e-12 * E);
  EXPECT_NEAR(m.E_R_boundary_share, E_boundary / E, 1e-12);
  EXPECT_LT(m.E_R_boundary_share, 1);  // the cube has interior vertices with delta > 0
  const double diag = (S.V.colwise().maxCoeff() - S.V.colwise().minCoeff()).norm();
  EXPECT_NEAR(m.round_trip_max, 0.02 / diag, 1e-15);
  EXPECT_NEAR(m.round_trip_avg, delta.mean() / diag, 1e-15);
}

TEST(MetricsClosedForm, HausdorffAndMeanDistanceBetweenConcentricSpheres) {
  // Source boundary on the unit sphere (the cube-to-sphere map puts the cube's faces on it
  // exactly), target the same mesh scaled by 2: every distance between the two boundaries
  // is 1 up to the chord sag of the target's (and the source's) triangles. Over the target's
  // bbox diagonal 4 sqrt3: d^_avg and d^_max = 1 / (4 sqrt3) = 0.1443, to the sag.
  const TetMesh S = blob_tets(8, Eigen::Vector3d(1, 1, 1));
  const TetBoundary b = boundary_surface(S);
  for (Eigen::Index i = 0; i < b.surface.V.rows(); ++i) ASSERT_NEAR(b.surface.V.row(i).norm(), 1.0, 1e-12);
  // Sag: 1 - the smallest distance from the origin to a boundary triangle's plane.
  double sag = 0;
  for (Eigen::Index q = 0; q < b.surface.F.rows(); ++q) {
    const Eigen::Vector3d p0 = b.surface.V.row(b.surface.F(q, 0)), p1 = b.surface.V.row(b.surface.F(q, 1)),
                          p2 = b.surface.V.row(b.surface.F(q, 2));
    const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0).normalized();
    sag = std::max(sag, 1 - std::abs(n.dot(p0)));
  }
  ASSERT_LT(sag, 0.05);
  TetMesh T = S;
  T.V = 2.0 * S.V;
  const double diag = 4 * std::sqrt(3.0);
  const VolumeMapMetrics m = volume_map_metrics(S, T, S.V);
  // Unit vertices to the radius-2 polyhedron: in [1 - 2 sag, 1]; radius-2 vertices to the
  // unit polyhedron: in [1, 1 + sag].
  EXPECT_GE(m.d_avg * diag, 1 - 2 * sag - 1e-12);
  EXPECT_LE(m.d_avg * diag, 1 + sag + 1e-12);
  EXPECT_GE(m.d_max * diag, 1 - 1e-12);
  EXPECT_LE(m.d_max * diag, 1 + sag + 1e-12);
}

TEST(MetricsClosedForm, VolumeDistortionOfAMapThatTriplesHalfTheCube) {
  // The cube's Kuhn tets all have the same volume and none straddles x = 0 (k even). The
  // map x -> 3x for x > 0 triples the volume of half the tets: the image volumes are 1/4
  // and 3/4 of the total over halves that were 1/2 each, so D_V = |1/2 - 1| = |3/2 - 1| =
  // 1/2 on every tet (Eq. 45).
  const TetMesh m = cube_tets(4);
  Eigen::MatrixXd f = m.V;
  for (Eigen::Index i = 0; i < f.rows(); ++i)
    if (f(i, 0) > 0) f(i, 0) *= 3;
  const Eigen::VectorXd D = ball_volume_distortion(m.V, m.T, f);
  ASSERT_EQ(D.size(), m.num_tets());
  for (Eigen::Index t = 0; t < D.size(); ++t) EXPECT_NEAR(D(t), 0.5, 1e-12) << t;
  // A uniform scaling keeps every volume share: D_V = 0.
  EXPECT_LT(ball_volume_distortion(m.V, m.T, 0.3 * m.V).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(MetricsClosedForm, GeodesicErrorOfTheAntipodalMapOnASphere) {
  // Every vertex of a sphere of radius r sent to its antipode, against the identity: the
  // geodesic error is pi r / sqrt(4 pi r^2) = sqrt(pi) / 2 = 0.8862 at every vertex, up to
  // the heat method's discretization error.
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  shapemap::testing::icosphere(3, 2.0, V, F);
  const int n = int(V.rows());
  // A face of each vertex (corner weight 1).
  BarycentricMap id, anti;
  id.elem.resize(n);
  id.bary.setZero(n, 3);
  for (Eigen::Index q = 0; q < F.rows(); ++q)
    for (int c = 0; c < 3; ++c) {
      id.elem(F(q, c)) = int(q);
      id.bary.row(F(q, c)).setZero();
      id.bary(F(q, c), c) = 1;
    }
  anti.elem.resize(n);
  anti.bary.setZero(n, 3);
  for (int i = 0; i < n; ++i) {
    int j = 0;
    (V.rowwise() + V.row(i)).rowwise().squaredNorm().minCoeff(&j);
    ASSERT_LT((V.row(j) + V.row(i)).norm(), 1e-9);  // the icosphere is centrally symmetric
    anti.elem(i) = id.elem(j);
    anti.bary.row(i) = id.bary.row(j);
  }
  const SurfaceErrorCurve e = surface_map_error(anti, id, V, F);
  const double exact = std::sqrt(M_PI) / 2;
  EXPECT_EQ(e.count, n);
  EXPECT_NEAR(e.mean, exact, 0.03 * exact);
  EXPECT_NEAR(e.max, exact, 0.05 * exact);
  EXPECT_EQ(e.within_0_1, 0.0);
  // The identity against itself: 0 everywhere.
  const SurfaceErrorCurve z = surface_map_error(id, id, V, F);
  EXPECT_NEAR(z.max, 0.0, 1e-9);
  EXPECT_EQ(z.within_0_1, 1.0);
}
