// Registration through the ball (isovolumetric-ball-parameterization.txt, Sec. 7).
#include "ball_test_mesh.h"
#include "shapemap/error.h"
#include "shapemap/maps.h"
#include "shapemap/volume/register.h"
#include <gtest/gtest.h>
#include <Eigen/Geometry>

using namespace shapemap;
using namespace shapemap::testing_ball;

TEST(BallRegister, VertexVolumesAndProcrustes) {
  const TetMesh m = blob_tets(3, Eigen::Vector3d(1.0, 0.8, 0.6), 0.1);
  const Eigen::VectorXd w = vertex_volumes(m.V, m.T);
  EXPECT_NEAR(w.sum(), tet_volumes(m.V, m.T).sum(), 1e-12);
  EXPECT_GT(w.minCoeff(), 0.0);
  // f = R^T v (rows) -> the optimal g is R, for any positive weights and scale.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -1, 0.5).normalized()).toRotationMatrix();
  const Eigen::MatrixXd f = 0.7 * m.V * R;  // row v^T R = (R^T v)^T
  const Eigen::Matrix3d g = ball_procrustes_rotation(f, m.V, w);
  EXPECT_LT((g - R).norm(), 1e-10);
  EXPECT_NEAR(g.determinant(), 1.0, 1e-12);
  // Homotopy endpoints.
  EXPECT_EQ((linear_homotopy_frame(m.V, f, 0, 3) - m.V).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT((linear_homotopy_frame(m.V, f, 2, 3) - f).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((linear_homotopy_frame(m.V, f, 1, 3) - 0.5 * (m.V + f)).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_THROW(linear_homotopy_frame(m.V, f, 3, 3), InputError);
  EXPECT_THROW(linear_homotopy_frame(m.V, f, 0, 1), InputError);
}

TEST(BallRegister, SelfRegistrationIsIdentity) {
  const TetMesh A = blob_tets(5, Eigen::Vector3d(1.0, 0.7, 0.5), 0.1);
  RegisterOptions o;
  o.ball.max_iterations = 60;
  const RegisterResult r = register_through_ball(A, A, o);
  EXPECT_LT((r.h - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  validate_map(r.map_AB, A.num_vertices(), A.num_tets(), 4, "map");
  EXPECT_LT((r.A_on_B - A.V).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(r.d_phi_relative, 1e-9);
  validate_map(r.map_BA, A.num_vertices(), A.num_tets(), 4, "map_BA");
  EXPECT_LT((r.B_on_A - A.V).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(BallRegister, DeformedRemeshedPair) {
  // A and a rotated, slightly deformed remeshing B: the registration recovers the rotation
  // (through g_A, g_B) and maps A close to B's shape.
  const TetMesh A = blob_tets(6, Eigen::Vector3d(1.0, 0.7, 0.5), 0.05);
  TetMesh B = blob_tets(5, Eigen::Vector3d(1.05, 0.68, 0.5), 0.08);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  B.V = (B.V * R.transpose()).eval();
  RegisterOptions o;
  o.ball.max_iterations = 100;
  const RegisterResult r = register_through_ball(A, B, o, {}, "A.vtk", "B.vtk");
  validate_map(r.map_AB, A.num_vertices(), B.num_tets(), 4, "map");
  EXPECT_LT((linear_homotopy_frame(A.V, r.A_on_B, 3, 4) - r.A_on_B).cwiseAbs().maxCoeff(), 1e-12);
  // Location report: A's boundary vertices sit on the unit sphere, outside B's inscribed
  // polyhedral ball, so they are snapped (by less than the gap between sphere and
  // polyhedron); interior vertices land inside B's ball mesh.
  EXPECT_GE(r.located_AB.outside, int(r.ball_A.boundary.size()) / 2);
  EXPECT_LE(r.located_AB.outside_interior, r.located_AB.outside);
  EXPECT_GT(r.located_AB.max_snap, 0.0);
  EXPECT_LT(r.located_AB.max_snap, 0.2);
  EXPECT_LE(r.located_AB.max_snap_interior, r.located_AB.max_snap);
  // phi(A) occupies B: every image lies within B's bounding box (slightly enlarged).
  const Eigen::RowVector3d lo = B.V.colwise().minCoeff(), hi = B.V.colwise().maxCoeff();
  for (int i = 0; i < A.num_vertices(); ++i)
    for (int d = 0; d < 3; ++d) {
      EXPECT_GE(r.A_on_B(i, d), lo(d) - 1e-9);
      EXPECT_LE(r.A_on_B(i, d), hi(d) + 1e-9);
    }
  // The displacement is dominated by the 0.3 rad rotation about z of a shape of radius ~1:
  // measured d(phi) 0.06 (volume-weighted mean |v - phi(v)|); a wrong h (e.g. a flip)
  // gives > 0.5.
  EXPECT_LT(r.d_phi, 0.4);
  EXPECT_GT(r.d_phi, 0.01);
  // The reverse map psi = f_A^{-1} h^{-1} f_B from the same ball maps: psi(phi(v)) returns
  // to v up to interpolation error (psi interpolated linearly in B's tet containing phi(v),
  // edges ~0.4; measured mean 0.012); a psi built with h instead of h^{-1} is off by the
  // 0.3 rad rotation twice, ~0.3 at radius 0.5.
  validate_map(r.map_BA, B.num_vertices(), A.num_tets(), 4, "map_BA");
  ASSERT_EQ(r.B_on_A.rows(), B.num_vertices());
  double round_trip = 0;
  for (int i = 0; i < A.num_vertices(); ++i) {
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int c = 0; c < 4; ++c) p += r.map_AB.bary(i, c) * r.B_on_A.row(B.T(r.map_AB.elem(i), c));
    round_trip += (p - A.V.row(i)).norm() / A.num_vertices();
  }
  EXPECT_LT(round_trip, 0.03);
}

TEST(BallRegister, RejectsNonBall) {
  const TetMesh A = blob_tets(3, Eigen::Vector3d(1, 1, 1), 0.0);
  const TetMesh B = hollow_cube(4);
  try {
    register_through_ball(A, B, {}, {}, "a.vtk", "b.vtk");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("b.vtk: ", 0), 0u) << e.what();
  }
}
