// ARAP distortion with signed singular values (symmetric-volume-maps Eqs. 19, 20, 26):
// rotations cost nothing, the signed-SVD convention, and finite-difference gradients
// including inverted and flat tets.
#include "shapemap/geometry/svd3.h"
#include "shapemap/optim/block_hessian.h"
#include "shapemap/volume/sarap.h"
#include "volume_test_util.h"
#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include "geometry/fixtures.h"
#include <functional>
#include <random>

using namespace shapemap;
using shapemap::testing::random_rotation;
using shapemap::test_volume::grid_box;

namespace {

// Brute-force min over SO(3) of ||J - R||_F^2 by a dense sweep plus local refinement.
double min_over_rotations(const Eigen::Matrix3d& J) {
  // Closest rotation: polar factor with a sign fix = U diag(1,1,det(UV^T)) V^T.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(J, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (U * V.transpose()).determinant() > 0 ? 1 : -1;
  return (J - U * D * V.transpose()).squaredNorm();
}

// Largest |central difference - G| over all coordinates of X, relative to max(1, max |G|).
double fd_gradient_error(const std::function<double(const Eigen::MatrixXd&)>& E,
                         const Eigen::MatrixXd& X, const Eigen::MatrixXd& G, double h = 1e-6) {
  double maxerr = 0, maxg = 0;
  for (int i = 0; i < X.rows(); ++i)
    for (int d = 0; d < 3; ++d) {
      Eigen::MatrixXd Xp = X, Xm = X;
      Xp(i, d) += h;
      Xm(i, d) -= h;
      maxerr = std::max(maxerr, std::abs((E(Xp) - E(Xm)) / (2 * h) - G(i, d)));
      maxg = std::max(maxg, std::abs(G(i, d)));
    }
  return maxerr / std::max(1.0, maxg);
}
}  // namespace

TEST(Sarap, ZeroForRotationsAndTranslations) {
  TetMesh m = grid_box(3, 2, 2, 1.0, 0.7, 0.5);
  ArapEnergy e(m.V, m.T);
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::Matrix3d R = random_rotation(rng);
    Eigen::RowVector3d t(0.3 * trial, -1.0, 2.0);
    Eigen::MatrixXd X = (m.V * R.transpose()).rowwise() + t;
    Eigen::MatrixXd G;
    double E = e.energy(X, &G);
    EXPECT_NEAR(E, 0.0, 1e-20 + 1e-12);
    EXPECT_LT(G.cwiseAbs().maxCoeff(), 1e-9);
  }
  // A uniform scaling by s costs 3 (s-1)^2 per unit weight; weights sum to 1/2 (Eq. 20).
  EXPECT_NEAR(e.weights().sum(), 0.5, 1e-12);
  EXPECT_NEAR(e.energy(1.5 * m.V), 0.5 * 3 * 0.25, 1e-10);
}

TEST(Sarap, SignedSingularValueConvention) {
  // A reflection is not a rotation: the signed convention gives sigma = (1,1,-1), f = 4,
  // whereas unsigned singular values would give 0.
  Eigen::Matrix3d Refl = Eigen::Vector3d(1, 1, -1).asDiagonal();
  EXPECT_NEAR(arap_distortion(Refl), 4.0, 1e-12);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-2, 2);
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Matrix3d J;
    for (int i = 0; i < 9; ++i) J(i) = u(rng);
    SignedSVD3 s = signed_svd3(J);
    EXPECT_NEAR(s.U.determinant(), 1.0, 1e-9);
    EXPECT_NEAR(s.V.determinant(), 1.0, 1e-9);
    EXPECT_GE(s.S(0), s.S(1) - 1e-12);
    EXPECT_GE(s.S(1), std::abs(s.S(2)) - 1e-12);
    if (J.determinant() < 0) EXPECT_LT(s.S(2), 0);
    EXPECT_LT((s.U * s.S.asDiagonal() * s.V.transpose() - J).norm(), 1e-9);
    // Eq. 19 with signed values equals the distance to SO(3).
    EXPECT_NEAR(arap_distortion(J), min_over_rotations(J), 1e-9);
  }
}

TEST(Sarap, GradientMatchesFiniteDifferencesWithInvertedTets) {
  TetMesh m = grid_box(2, 2, 2, 1.0, 1.0, 1.0);
  ArapEnergy e(m.V, m.T);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  Eigen::MatrixXd X = m.V;
  for (int i = 0; i < X.size(); ++i) X(i) += u(rng);
  // Flip a few tets: move one vertex through the opposite face.
  X.row(m.T(0, 0)) = X.row(m.T(0, 1)) + 1.2 * (X.row(m.T(0, 1)) - X.row(m.T(0, 0)));
  Eigen::VectorXd det = e.determinants(X);
  int inverted = 0;
  for (int k = 0; k < det.size(); ++k) inverted += det(k) <= 0;
  ASSERT_GT(inverted, 0);
  Eigen::MatrixXd G;
  e.energy(X, &G);
  EXPECT_LT(fd_gradient_error([&](const Eigen::MatrixXd& Y) { return e.energy(Y); }, X, G), 1e-6);
  // Restricted evaluation: same gradient on the vertices of the listed tets' interiors.
  std::vector<int> all(m.T.rows());
  for (int k = 0; k < int(all.size()); ++k) all[k] = k;
  Eigen::MatrixXd G2;
  EXPECT_NEAR(e.energy(X, all, &G2), e.energy(X), 1e-12);
  EXPECT_LT((G2 - G).cwiseAbs().maxCoeff(), 1e-12);
}

// The post-repair penalty (SigmaPenalty): zero while every signed singular value is above
// the floor, the closed form on a diagonal J, and its gradient against finite differences
// with inverted and flattened tets.
TEST(Sarap, SigmaPenaltyClosedFormAndGradient) {
  const SigmaPenalty pen{0.1, 2.0};
  const Eigen::Matrix3d Jok = Eigen::Vector3d(0.5, 1.2, 0.2).asDiagonal();
  EXPECT_NEAR(penalized_arap_distortion(Jok, pen), arap_distortion(Jok), 1e-14);
  // diag(1, 0.05, -0.2): det < 0, so the smallest singular value carries the sign:
  // signed sigma = (1, 0.2, -0.05), and only -0.05 is below the floor: t = 1.5.
  const Eigen::Matrix3d Jbad = Eigen::Vector3d(1.0, 0.05, -0.2).asDiagonal();
  const double expect = arap_distortion(Jbad) + 2.0 * std::pow(1.5, 6);
  EXPECT_NEAR(penalized_arap_distortion(Jbad, pen), expect, 1e-9 * expect);

  TetMesh m = grid_box(2, 2, 2, 1.0, 1.0, 1.0);
  ArapEnergy e(m.V, m.T);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.35, 0.35);
  Eigen::MatrixXd X = m.V;
  for (int i = 0; i < X.size(); ++i) X(i) += u(rng);
  X.row(m.T(0, 0)) = X.row(m.T(0, 1)) + 1.1 * (X.row(m.T(0, 1)) - X.row(m.T(0, 0)));
  std::vector<int> all(m.T.rows());
  for (int k = 0; k < int(all.size()); ++k) all[k] = k;
  Eigen::VectorXd det = e.determinants(X);
  int low = 0;
  for (int k = 0; k < det.size(); ++k) low += det(k) < 0.1;
  ASSERT_GT(low, 0);
  Eigen::MatrixXd G;
  const double E = e.energy(X, all, &G, pen);
  EXPECT_GT(E, e.energy(X) + 1e-6);  // the penalty is active
  EXPECT_LT(fd_gradient_error([&](const Eigen::MatrixXd& Y) { return e.energy(Y, all, nullptr, pen); }, X, G),
            1e-5);
}

TEST(Sarap, FlatTetsHaveFiniteEnergyAndGradient) {
  TetMesh m = grid_box(1, 1, 1, 1.0, 1.0, 1.0);
  ArapEnergy e(m.V, m.T);
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(m.V.rows(), 3);  // everything collapsed
  Eigen::MatrixXd G;
  double E = e.energy(X, &G);
  EXPECT_NEAR(E, 0.5 * 3.0, 1e-12);  // sigma = 0: f = 3 per tet, weights sum to 1/2
  EXPECT_TRUE(G.allFinite());
}

// arap_distortion(J) takes the closest rotation from Horn's quaternion matrix when its
// largest eigenvalue is well separated and from the signed SVD otherwise: both must give
// Eq. 19 and the Sec. 5.2 gradient U diag(2(sigma - 1)) V^T of the signed SVD.
TEST(Sarap, DistortionAndGradientMatchTheSignedSVD) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0, 1);
  for (int trial = 0; trial < 2000; ++trial) {
    const double scale = trial < 500 ? 0.01 : trial < 1000 ? 0.3 : trial < 1500 ? 1.0 : 3.0;
    Eigen::Matrix3d J = random_rotation(rng);
    for (int i = 0; i < 9; ++i) J(i) += scale * n(rng);
    if (trial % 7 == 0) J.col(2) = 0.5 * J.col(0) - 0.25 * J.col(1);  // flat
    if (trial % 11 == 0) J.col(0) = -J.col(0);                        // inverted
    SignedSVD3 s = signed_svd3(J);
    const double f_ref = (s.S.array() - 1.0).square().sum();
    const Eigen::Matrix3d G_ref = s.U * (2.0 * (s.S.array() - 1.0)).matrix().asDiagonal() * s.V.transpose();
    Eigen::Matrix3d G;
    const double f = arap_distortion(J, &G);
    const double tol = 1e-11 * (1.0 + J.squaredNorm());
    ASSERT_NEAR(f, f_ref, tol) << "trial " << trial;
    // Flat J: the closest rotation is not unique, only f is defined; skip the gradient.
    if (std::abs(s.S(1) + s.S(2)) > 1e-6 * s.S(0)) {
      EXPECT_LT((G - G_ref).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + J.norm())) << "trial " << trial;
    }
    EXPECT_NEAR(arap_distortion(J, nullptr), f, 1e-14 * (1.0 + f));
  }
}

// ---- The analytic eigensystem Hessian (issue 19: projected Newton) ----

namespace {
// Corner-major gradient (12) of w f(J(x)) for one tet, from arap_distortion's dJ.
Eigen::Matrix<double, 12, 1> tet_gradient(const Eigen::Matrix<double, 4, 3>& x, const Eigen::Matrix3d& Dm_inv) {
  Eigen::Matrix3d Ds;
  for (int j = 0; j < 3; ++j) Ds.col(j) = (x.row(j + 1) - x.row(0)).transpose();
  Eigen::Matrix3d G;
  arap_distortion(Ds * Dm_inv, &G);
  const Eigen::Matrix3d H = G * Dm_inv.transpose();
  Eigen::Matrix<double, 12, 1> g;
  for (int j = 0; j < 3; ++j) g.segment<3>(3 * (j + 1)) = H.col(j);
  g.segment<3>(0) = -(H.col(0) + H.col(1) + H.col(2));
  return g;
}
Eigen::Matrix<double, 12, 12> fd_hessian(const Eigen::Matrix<double, 4, 3>& x, const Eigen::Matrix3d& Dm_inv) {
  Eigen::Matrix<double, 12, 12> H;
  const double h = 1e-6;
  for (int i = 0; i < 12; ++i) {
    Eigen::Matrix<double, 4, 3> xp = x, xm = x;
    xp(i / 3, i % 3) += h;
    xm(i / 3, i % 3) -= h;
    H.col(i) = (tet_gradient(xp, Dm_inv) - tet_gradient(xm, Dm_inv)) / (2 * h);
  }
  return H;
}
Eigen::Matrix<double, 4, 3> rest_tet() {
  Eigen::Matrix<double, 4, 3> x;
  x << 0, 0, 0, 1, 0.1, 0, 0.2, 0.9, 0.1, 0.1, 0.2, 1.1;
  return x;
}
}  // namespace

// The exact (unprojected) eigensystem Hessian equals finite differences of the Eq. 26
// gradient, for stretched, compressed, sheared and inverted tets.
TEST(SarapHessian, ExactMatchesFiniteDifferences) {
  const Eigen::Matrix<double, 4, 3> X0 = rest_tet();
  Eigen::Matrix3d Dm;
  for (int j = 0; j < 3; ++j) Dm.col(j) = (X0.row(j + 1) - X0.row(0)).transpose();
  const Eigen::Matrix3d Dm_inv = Dm.inverse();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  int inverted = 0;
  for (int trial = 0; trial < 60; ++trial) {
    Eigen::Matrix<double, 4, 3> x = X0;
    for (int i = 0; i < 12; ++i) x(i) += u(rng) * (trial % 3 == 0 ? 1.5 : 1.0);
    Eigen::Matrix3d Ds;
    for (int j = 0; j < 3; ++j) Ds.col(j) = (x.row(j + 1) - x.row(0)).transpose();
    const SignedSVD3 s = signed_svd3(Ds * Dm_inv);
    if (s.S(1) + s.S(2) < 0.05 || s.S(1) - std::abs(s.S(2)) < 0.05) continue;  // away from kinks
    inverted += s.S(2) < 0;
    const Eigen::Matrix<double, 12, 12> H = arap_tet_hessian(x, Dm_inv, 1.0, false), F = fd_hessian(x, Dm_inv);
    EXPECT_LT((H - F).cwiseAbs().maxCoeff(), 1e-5 * (1 + F.cwiseAbs().maxCoeff())) << "trial " << trial;
  }
  EXPECT_GT(inverted, 3);  // inverted tets were among the cases
}

// Projected: positive semi-definite everywhere (inverted and flat tets too), equal to the
// exact Hessian where that is already PSD (a stretched tet), and not PSD-clamped away: it
// keeps the exact Hessian's null space of rigid motions at the rest shape.
TEST(SarapHessian, ProjectedIsPositiveSemiDefinite) {
  const Eigen::Matrix<double, 4, 3> X0 = rest_tet();
  Eigen::Matrix3d Dm;
  for (int j = 0; j < 3; ++j) Dm.col(j) = (X0.row(j + 1) - X0.row(0)).transpose();
  const Eigen::Matrix3d Dm_inv = Dm.inverse();
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  int negative_exact = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Matrix<double, 4, 3> x = X0;
    for (int i = 0; i < 12; ++i) x(i) += u(rng);
    if (trial % 10 == 0) x.row(3) = (x.row(0) + x.row(1) + x.row(2)) / 3;  // flat
    const Eigen::Matrix<double, 12, 12> H = arap_tet_hessian(x, Dm_inv, 1.0, true);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> es(H);
    EXPECT_GT(es.eigenvalues().minCoeff(), -1e-9 * (1 + es.eigenvalues().maxCoeff())) << trial;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> ex(arap_tet_hessian(x, Dm_inv, 1.0, false));
    negative_exact += ex.eigenvalues().minCoeff() < -1e-6;
  }
  EXPECT_GT(negative_exact, 20);  // the projection had work to do
  // Stretched by 2 (sigma_j + sigma_k = 4 > 2): exact = projected.
  const Eigen::Matrix<double, 4, 3> x2 = 2.0 * X0;
  EXPECT_LT((arap_tet_hessian(x2, Dm_inv, 1.0, true) - arap_tet_hessian(x2, Dm_inv, 1.0, false)).cwiseAbs().maxCoeff(),
            1e-12);
  // At rest: translations and rotations cost nothing to second order (null space of 6).
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> es(arap_tet_hessian(X0, Dm_inv, 1.0, true));
  int zero = 0;
  for (int i = 0; i < 12; ++i) zero += std::abs(es.eigenvalues()(i)) < 1e-9;
  EXPECT_EQ(zero, 6);
}

// ArapEnergy::add_hessian assembles the per-tet Hessians of Eq. 20 (weights v_k / 2c):
// against a dense finite-difference Hessian of the whole energy at a stretched map.
TEST(SarapHessian, AssembledMatchesFiniteDifferencesOfTheEnergyGradient) {
  TetMesh m = grid_box(2, 2, 1, 1.0, 0.8, 0.5);
  ArapEnergy e(m.V, m.T);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  Eigen::MatrixXd X = 1.8 * m.V;  // stretched: the projection changes nothing
  for (int i = 0; i < X.size(); ++i) X(i) += u(rng);
  std::vector<int> all(m.num_vertices());
  for (int v = 0; v < m.num_vertices(); ++v) all[v] = v;
  BlockHessian H(m.T, m.num_vertices(), all);
  e.add_hessian(X, 1.0, H);
  const int N = 3 * m.num_vertices();
  Eigen::MatrixXd D = Eigen::MatrixXd(Eigen::SparseMatrix<double>(H.matrix().selfadjointView<Eigen::Lower>()));
  const double h = 1e-6;
  double err = 0, scale = 0;
  for (int i = 0; i < N; ++i) {
    Eigen::MatrixXd Xp = X, Xm = X, Gp, Gm;
    Xp(i / 3, i % 3) += h;
    Xm(i / 3, i % 3) -= h;
    e.energy(Xp, &Gp);
    e.energy(Xm, &Gm);
    for (int j = 0; j < N; ++j) {
      const double fd = (Gp(j / 3, j % 3) - Gm(j / 3, j % 3)) / (2 * h);
      err = std::max(err, std::abs(fd - D(j, i)));
      scale = std::max(scale, std::abs(fd));
    }
  }
  EXPECT_LT(err, 1e-6 * scale);
}
