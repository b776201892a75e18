// Isovolumetric energy, L_V(f), AST and the VSEM fixed point
// (isovolumetric-ball-parameterization.txt Eqs. 2, 3, 8, 11-13).
#include "ball_test_mesh.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/volume/vsem.h"
#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

using namespace shapemap;
using namespace shapemap::testing_ball;

namespace {

TetMesh small_blob() { return blob_tets(4, Eigen::Vector3d(1.0, 0.8, 0.6), 0.1); }

Eigen::MatrixXd affine(const Eigen::MatrixXd& V, const Eigen::Matrix3d& A, const Eigen::Vector3d& b) {
  return ((V * A.transpose()).rowwise() + b.transpose()).eval();
}

// A smooth nonlinear map close to the identity.
Eigen::MatrixXd wiggle(const Eigen::MatrixXd& V, double eps) {
  Eigen::MatrixXd f = V;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    f(i, 0) += eps * std::sin(2 * V(i, 1) + 0.3);
    f(i, 1) += eps * std::cos(1.7 * V(i, 2)) * V(i, 0);
    f(i, 2) += eps * V(i, 0) * V(i, 1);
  }
  return f;
}

}  // namespace

TEST(Vsem, EnergiesOnIdentityScalingAndAffineMaps) {
  const TetMesh m = small_blob();
  IsovolumetricEnergy E(m.V, m.T);
  const double Ve = E.domain_volume();
  EXPECT_NEAR(Ve, tet_volumes(m.V, m.T).sum(), 1e-12);
  // Identity: E_V = V(e), V(f) = V(e), E_I = 0 (Theorem 1).
  EXPECT_NEAR(E.stretch_energy(m.V), Ve, 1e-12);
  EXPECT_NEAR(E.image_volume(m.V), Ve, 1e-12);
  EXPECT_NEAR(E.energy(m.V), 0.0, 1e-12);
  // Uniform scaling by s: |f(tau)| = s^3 |tau|, E_V = s^6 V(e), E_I = 0.
  const double s = 1.7;
  const Eigen::MatrixXd fs = s * m.V;
  EXPECT_NEAR(E.stretch_energy(fs), std::pow(s, 6) * Ve, 1e-9);
  EXPECT_NEAR(E.image_volume(fs), std::pow(s, 3) * Ve, 1e-10);
  EXPECT_NEAR(E.energy(fs), 0.0, 1e-9);
  // Affine map x -> A x + b: constant det A, volume-preserving up to c = det A.
  Eigen::Matrix3d A;
  A << 1.2, 0.3, -0.1, 0.0, 0.9, 0.2, 0.1, -0.2, 1.1;
  const double d = A.determinant();
  const Eigen::MatrixXd fa = affine(m.V, A, Eigen::Vector3d(0.5, -1, 2));
  EXPECT_NEAR(E.stretch_energy(fa), d * d * Ve, 1e-10);
  EXPECT_NEAR(E.image_volume(fa), d * Ve, 1e-10);
  EXPECT_NEAR(E.energy(fa), 0.0, 1e-10);
  // A non-volume-preserving map: E_I > 0, and equals the definition (Eq. 2a).
  const Eigen::MatrixXd fw = wiggle(m.V, 0.2);
  const Eigen::VectorXd vf = tet_volumes(fw, m.T), ve = tet_volumes(m.V, m.T);
  double EV = 0;
  for (int t = 0; t < vf.size(); ++t) EV += vf(t) * vf(t) / ve(t);
  EXPECT_NEAR(E.stretch_energy(fw), EV, 1e-12);
  EXPECT_NEAR(E.energy(fw), Ve / vf.sum() * EV - vf.sum(), 1e-12);
  EXPECT_GT(E.energy(fw), 1e-6);
  // V(f) by tets equals the boundary-cone formula of Sec. 3.
  double cone = 0;
  const Eigen::MatrixXi& Fb = E.boundary_faces();
  for (int k = 0; k < Fb.rows(); ++k)
    cone += Eigen::Vector3d(fw.row(Fb(k, 0))).dot(Eigen::Vector3d(fw.row(Fb(k, 1))).cross(Eigen::Vector3d(fw.row(Fb(k, 2))))) / 6.0;
  EXPECT_NEAR(E.image_volume(fw), cone, 1e-12);
}

TEST(Vsem, LaplacianMatchesEnergyAndCotanWeights) {
  const TetMesh m = small_blob();
  IsovolumetricEnergy E(m.V, m.T);
  const Eigen::MatrixXd f = wiggle(m.V, 0.15);
  Eigen::SparseMatrix<double> L;
  E.stretch_laplacian(f, L);
  // Eq. 3a: E_V = 1/2 tr(f^T L_V(f) f).
  EXPECT_NEAR(0.5 * f.cwiseProduct(L * f).sum(), E.stretch_energy(f), 1e-11);
  // Eq. 8: grad E_V = 3 L_V(f) f.
  const Eigen::MatrixXd G = E.stretch_gradient(f);
  EXPECT_LT((G - 3.0 * (L * f)).cwiseAbs().maxCoeff(), 1e-11);
  // Eq. 3c: l cot(theta) |f(tau)| / (9 |tau|) = (2/3) (|f(tau)|/|tau|) * tet_cotan_weights(f).
  Eigen::MatrixXd W;
  E.stretch_weights(f, W);
  const Eigen::MatrixXd Wc = tet_cotan_weights(f, m.T);
  const Eigen::VectorXd vf = tet_volumes(f, m.T), ve = tet_volumes(m.V, m.T);
  double err = 0;
  for (int t = 0; t < W.rows(); ++t)
    for (int e = 0; e < 6; ++e)
      err = std::max(err, std::abs(W(t, e) - (2.0 / 3.0) * std::abs(vf(t)) / ve(t) * Wc(t, e)));
  EXPECT_LT(err, 1e-11);
  // Identity: L_V(e) = (2/3) tet cotan Laplacian.
  Eigen::SparseMatrix<double> Le;
  E.stretch_laplacian(m.V, Le);
  const Eigen::SparseMatrix<double> Lc = tet_cotan_laplacian(m.V, m.T);
  EXPECT_LT(Eigen::MatrixXd(Le - (2.0 / 3.0) * Lc).cwiseAbs().maxCoeff(), 1e-11);
  // PSD convention: rows sum to zero.
  EXPECT_LT((L * Eigen::VectorXd::Ones(L.cols())).cwiseAbs().maxCoeff(), 1e-11);
}

TEST(Vsem, CartesianGradientMatchesFiniteDifferences) {
  const TetMesh m = small_blob();
  IsovolumetricEnergy E(m.V, m.T);
  Eigen::MatrixXd f = wiggle(m.V, 0.2);
  Eigen::MatrixXd G;
  const double e0 = E.energy_and_gradient(f, G);
  EXPECT_NEAR(e0, E.energy(f), 1e-14);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> pick(0, m.num_vertices() - 1);
  const double h = 1e-6;
  double maxerr = 0, maxg = 0;
  for (int s = 0; s < 40; ++s) {
    const int i = pick(rng), d = s % 3;
    Eigen::MatrixXd fp = f, fm = f;
    fp(i, d) += h;
    fm(i, d) -= h;
    const double fd = (E.energy(fp) - E.energy(fm)) / (2 * h);
    maxerr = std::max(maxerr, std::abs(fd - G(i, d)));
    maxg = std::max(maxg, std::abs(G(i, d)));
  }
  EXPECT_LT(maxerr, 1e-6 * std::max(1.0, maxg));
}

TEST(Vsem, AnisotropicScalingNormalizesExtents) {
  TetMesh m = blob_tets(4, Eigen::Vector3d(3.0, 1.0, 0.5), 0.0);
  Eigen::AngleAxisd rot(0.7, Eigen::Vector3d(1, 2, 3).normalized());
  m.V = ((m.V * rot.toRotationMatrix().transpose()).rowwise() + Eigen::RowVector3d(4, -2, 1)).eval();
  const AnisotropicScaling a = anisotropic_scaling(m.V);
  EXPECT_NEAR(a.rotation.determinant(), 1.0, 1e-12);
  const Eigen::MatrixXd P = a.apply(m.V);
  for (int l = 0; l < 3; ++l) EXPECT_NEAR(P.col(l).cwiseAbs().maxCoeff(), 1.0, 1e-12);
  EXPECT_LT(P.colwise().mean().norm(), 1e-12);
  // Principal axes: the covariance of P is diagonal.
  const Eigen::Matrix3d C = P.transpose() * P;
  EXPECT_LT(std::abs(C(0, 1)) + std::abs(C(0, 2)) + std::abs(C(1, 2)), 1e-8 * C.trace());
  // Orientation kept: tets stay positive.
  EXPECT_GT(tet_volumes(P, m.T).minCoeff(), 0.0);
}

TEST(Vsem, FixedPointOnAffineBoundaryReproducesAffineMap) {
  // With boundary data from an affine map, the harmonic (L_V(e)) solve reproduces it
  // exactly (linear precision), and every fixed-point update keeps it (E_I = 0).
  const TetMesh m = small_blob();
  const TetBoundary tb = boundary_surface(m);
  Eigen::Matrix3d A;
  A << 0.8, 0.1, 0.0, -0.1, 1.1, 0.2, 0.0, 0.3, 0.9;
  const Eigen::MatrixXd fa = affine(m.V, A, Eigen::Vector3d(0.1, 0.2, 0.3));
  Eigen::MatrixXd fB(tb.to_volume.size(), 3);
  for (int k = 0; k < fB.rows(); ++k) fB.row(k) = fa.row(tb.to_volume(k));
  VsemOptions o;
  o.iterations = 3;
  const VsemResult r = vsem_fixed_point(m.V, m.T, tb.to_volume, fB, o);
  EXPECT_LT((r.f - fa).cwiseAbs().maxCoeff(), 1e-9);
  ASSERT_EQ(r.energies.size(), 4u);
  for (double e : r.energies) EXPECT_NEAR(e, 0.0, 1e-10);
}

TEST(Vsem, RenumberingPutsInteriorFirstInZOrderAndKeepsOrientation) {
  // The blob with its vertices shuffled (mesh generators number vertices without locality).
  const TetMesh b = blob_tets(12, Eigen::Vector3d(1.0, 0.8, 0.6), 0.1);
  std::vector<int> sh(size_t(b.num_vertices()));
  std::iota(sh.begin(), sh.end(), 0);
  std::shuffle(sh.begin(), sh.end(), std::mt19937(7));
  TetMesh m;
  m.V.resize(b.V.rows(), 3);
  for (size_t i = 0; i < sh.size(); ++i) m.V.row(sh[i]) = b.V.row(Eigen::Index(i));
  m.T = b.T;
  for (Eigen::Index k = 0; k < m.T.size(); ++k) m.T(k) = sh[size_t(b.T(k))];
  const TetBoundary tb = boundary_surface(m);
  std::vector<char> isb(size_t(m.num_vertices()), 0);
  for (Eigen::Index k = 0; k < tb.to_volume.size(); ++k) isb[size_t(tb.to_volume(k))] = 1;
  Eigen::VectorXi perm, iperm;
  const int nI = interior_first_order(isb, perm, iperm, &m.V);
  const int n = m.num_vertices();
  EXPECT_EQ(nI, n - int(tb.to_volume.size()));
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(iperm(perm(i)), i);                 // inverse permutations
    EXPECT_EQ(perm(i) < nI, isb[size_t(i)] == 0);  // interior first
  }
  // Z-order: consecutive vertices are much closer than in the shuffled input order.
  auto mean_step = [&](const Eigen::VectorXi& order) {
    double s = 0;
    for (int k = 1; k < nI; ++k) s += (m.V.row(order(k)) - m.V.row(order(k - 1))).norm();
    return s / (nI - 1);
  };
  Eigen::VectorXi plain_perm, plain_iperm;
  interior_first_order(isb, plain_perm, plain_iperm);
  for (int k = 1; k < nI; ++k) EXPECT_LT(plain_iperm(k - 1), plain_iperm(k));  // without V: input order
  std::printf("mean distance between consecutive interior vertices: Z-order %.4f, shuffled %.4f\n",
              mean_step(iperm), mean_step(plain_iperm));
  EXPECT_LT(mean_step(iperm), 0.5 * mean_step(plain_iperm));

  const Eigen::MatrixXi Tp = renumber_tets(m.T, perm);
  ASSERT_EQ(Tp.rows(), m.T.rows());
  Eigen::MatrixXd Vp(n, 3);
  for (int i = 0; i < n; ++i) Vp.row(perm(i)) = m.V.row(i);
  // Same tets (as oriented volumes), rows sorted by their smallest vertex.
  const Eigen::VectorXd v0 = tet_volumes(m.V, m.T), v1 = tet_volumes(Vp, Tp);
  EXPECT_GT(v1.minCoeff(), 0.0);  // orientation kept
  EXPECT_NEAR(v0.sum(), v1.sum(), 1e-12);
  std::vector<double> s0(v0.data(), v0.data() + v0.size()), s1(v1.data(), v1.data() + v1.size());
  std::sort(s0.begin(), s0.end());
  std::sort(s1.begin(), s1.end());
  for (size_t k = 0; k < s0.size(); ++k) EXPECT_NEAR(s0[k], s1[k], 1e-15);
  for (Eigen::Index t = 1; t < Tp.rows(); ++t) EXPECT_LE(Tp.row(t - 1).minCoeff(), Tp.row(t).minCoeff());
}
