// The landing's inversion barrier (inversion_barrier.h): b(d) against its closed form and
// derivatives, the per-tet Hessian against finite differences of the gradient, the
// projected Hessian positive semi-definite, the assembled energy's gradient against finite
// differences, and a Newton step that cannot turn an active tet over.
#include "shapemap/optim/block_hessian.h"
#include "shapemap/optim/newton.h"
#include "shapemap/volume/inversion_barrier.h"
#include "volume_test_util.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <cmath>
#include <random>

using namespace shapemap;
using shapemap::test_volume::grid_box;

TEST(InversionBarrier, ClampedLogBarrierClosedFormAndDerivatives) {
  const double d0 = 0.1;
  EXPECT_EQ(clamped_log_barrier(0.5, d0), 0.0);
  EXPECT_EQ(clamped_log_barrier(d0, d0), 0.0);
  EXPECT_TRUE(std::isinf(clamped_log_barrier(0.0, d0)));
  EXPECT_TRUE(std::isinf(clamped_log_barrier(-0.2, d0)));
  // b(d0/e) = -(d0/e - d0)^2 log(1/e) = (d0 (1 - 1/e))^2.
  const double d = d0 / std::exp(1.0);
  EXPECT_NEAR(clamped_log_barrier(d, d0), std::pow(d0 * (1 - 1 / std::exp(1.0)), 2), 1e-15);
  for (double x : {0.001, 0.01, 0.05, 0.09}) {
    double b1 = 0, b2 = 0;
    clamped_log_barrier(x, d0, &b1, &b2);
    const double h = 1e-7 * x;
    const double f1 = (clamped_log_barrier(x + h, d0) - clamped_log_barrier(x - h, d0)) / (2 * h);
    double p1 = 0, m1 = 0;
    clamped_log_barrier(x + h, d0, &p1);
    clamped_log_barrier(x - h, d0, &m1);
    EXPECT_NEAR(b1, f1, 1e-5 * (1 + std::abs(b1))) << x;
    EXPECT_NEAR(b2, (p1 - m1) / (2 * h), 1e-4 * (1 + std::abs(b2))) << x;
    EXPECT_LT(b1, 0) << x;  // pushes det J up
    EXPECT_GT(b2, 0) << x;  // convex in d
  }
  // C^2 at d0: value, slope and curvature go to 0.
  double b1 = 1, b2 = 1;
  clamped_log_barrier(d0 * (1 - 1e-6), d0, &b1, &b2);
  EXPECT_LT(std::abs(b1), 1e-9);
  EXPECT_LT(std::abs(b2), 1e-4);
}

namespace {
// A tet squeezed to a volume ratio inside (0, d0), with random corner noise.
Eigen::Matrix<double, 4, 3> squeezed_tet(std::mt19937& rng, const Eigen::Matrix<double, 4, 3>& X0) {
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  Eigen::Matrix<double, 4, 3> x = X0;
  x.col(2) *= 0.04;  // flattened in z: det J about 0.04
  for (int i = 0; i < 12; ++i) x(i) += 0.1 * u(rng);
  return x;
}

double tet_det(const Eigen::Matrix<double, 4, 3>& x, const Eigen::Matrix3d& Dm_inv) {
  Eigen::Matrix3d Ds;
  for (int j = 0; j < 3; ++j) Ds.col(j) = (x.row(j + 1) - x.row(0)).transpose();
  return (Ds * Dm_inv).determinant();
}
}  // namespace

TEST(InversionBarrier, TetHessianMatchesFiniteDifferencesAndProjectionIsPsd) {
  Eigen::Matrix<double, 4, 3> X0;
  X0 << 0, 0, 0, 1, 0, 0, 0.2, 0.9, 0, 0.3, 0.3, 0.8;
  Eigen::Matrix3d Dm;
  for (int j = 0; j < 3; ++j) Dm.col(j) = (X0.row(j + 1) - X0.row(0)).transpose();
  const Eigen::Matrix3d Dm_inv = Dm.inverse();
  const double d0 = 0.1;
  // The gradient in x by the chain rule through b'(det) and finite differences of b(det(x)).
  auto value = [&](const Eigen::Matrix<double, 4, 3>& x) { return clamped_log_barrier(tet_det(x, Dm_inv), d0); };
  std::mt19937 rng(3);
  int tested = 0, indefinite = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Matrix<double, 4, 3> x = squeezed_tet(rng, X0);
    const double d = tet_det(x, Dm_inv);
    if (!(d > 0.005 && d < 0.09)) continue;
    ++tested;
    const Eigen::Matrix<double, 12, 12> H = barrier_tet_hessian(x, Dm_inv, d0, 1.0, false);
    Eigen::Matrix<double, 12, 12> F;
    const double h = 1e-6;
    for (int i = 0; i < 12; ++i)
      for (int j = 0; j < 12; ++j) {
        auto at = [&](double si, double sj) {
          Eigen::Matrix<double, 4, 3> y = x;
          y(i / 3, i % 3) += si;
          y(j / 3, j % 3) += sj;
          return value(y);
        };
        F(i, j) = (at(h, h) - at(h, -h) - at(-h, h) + at(-h, -h)) / (4 * h * h);
      }
    EXPECT_LT((H - F).cwiseAbs().maxCoeff(), 1e-3 * (1 + F.cwiseAbs().maxCoeff())) << trial;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> ex(H);
    indefinite += ex.eigenvalues().minCoeff() < -1e-8;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> es(barrier_tet_hessian(x, Dm_inv, d0, 1.0, true));
    EXPECT_GT(es.eigenvalues().minCoeff(), -1e-9 * (1 + es.eigenvalues().maxCoeff())) << trial;
  }
  EXPECT_GT(tested, 20);
  EXPECT_GT(indefinite, 0);  // the projection had work to do
}

TEST(InversionBarrier, EnergyGradientMatchesFiniteDifferences) {
  TetMesh m = grid_box(2, 2, 1, 1.0, 0.8, 0.5);
  ArapEnergy arap(m.V, m.T);
  InversionBarrier barrier(arap, 0.1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.005, 0.005);
  Eigen::MatrixXd X = m.V;
  X.col(2) *= 0.06;  // every tet near flat, but positive
  for (int i = 0; i < X.size(); ++i) X(i) += u(rng);
  barrier.activate_positive(X);
  ASSERT_EQ(barrier.num_active(), int(m.T.rows()));
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(X.rows(), 3);
  const double E = barrier.energy(X, &G);
  EXPECT_GT(E, 0);
  double err = 0;
  const double h = 1e-7;
  for (int i = 0; i < X.size(); ++i) {
    Eigen::MatrixXd Xp = X, Xm = X;
    Xp(i) += h;
    Xm(i) -= h;
    err = std::max(err, std::abs((barrier.energy(Xp, nullptr) - barrier.energy(Xm, nullptr)) / (2 * h) - G(i)));
  }
  EXPECT_LT(err, 1e-5 * (1 + G.cwiseAbs().maxCoeff()));
}

// Newton on ARAP toward a target that would turn tets over, plus the barrier: the energy
// decreases and no active tet turns over.
TEST(InversionBarrier, NewtonWithBarrierKeepsActiveTetsPositive) {
  TetMesh m = grid_box(3, 2, 2, 1.0, 0.8, 0.6);
  ArapEnergy arap(m.V, m.T);
  InversionBarrier barrier(arap, 0.1);
  barrier.activate_positive(m.V);
  // Bottom vertices held where they are and top vertices pulled to z = -zmax/2 at their x
  // and y, through the bottom (a rotation cannot do it): without the barrier the minimizer
  // turns tets over.
  std::vector<int> all(m.num_vertices());
  for (int v = 0; v < m.num_vertices(); ++v) all[v] = v;
  const double zmax = m.V.col(2).maxCoeff(), k = 50.0;
  auto run = [&](bool with_barrier) {
    Eigen::MatrixXd X = m.V, G;
    auto scatter = [&](const Eigen::VectorXd& z) {
      for (int v = 0; v < m.num_vertices(); ++v) X.row(v) = z.segment<3>(3 * v).transpose();
    };
    NewtonValue f = [&](const Eigen::VectorXd& z, Eigen::VectorXd* g) {
      scatter(z);
      double E = arap.energy(X, g ? &G : nullptr);
      if (with_barrier) E += barrier.energy(X, g ? &G : nullptr);
      for (int v = 0; v < m.num_vertices(); ++v)
        if (m.V(v, 2) == zmax || m.V(v, 2) == 0) {
          Eigen::RowVector3d r = X.row(v) - m.V.row(v);
          if (m.V(v, 2) == zmax) r(2) = X(v, 2) + 0.5 * zmax;
          E += k * r.squaredNorm();
          if (g) G.row(v) += 2 * k * r;
        }
      if (g)
        for (int v = 0; v < m.num_vertices(); ++v) g->segment<3>(3 * v) = G.row(v).transpose();
      return E;
    };
    NewtonHessian hess = [&](const Eigen::VectorXd& z, BlockHessian& H) {
      scatter(z);
      arap.add_hessian(X, 1.0, H);
      if (with_barrier) barrier.add_hessian(X, 1.0, H);
      for (int v = 0; v < m.num_vertices(); ++v)
        if (m.V(v, 2) == zmax || m.V(v, 2) == 0) {
          H.add_block(v, v, 2 * k * Eigen::Matrix3d::Identity());
        }
    };
    ProjectedNewton pn(BlockHessian(m.T, m.num_vertices(), all));
    Eigen::VectorXd z(3 * m.num_vertices());
    for (int v = 0; v < m.num_vertices(); ++v) z.segment<3>(3 * v) = m.V.row(v).transpose();
    NewtonOptions o;
    o.max_iterations = 40;
    const double f0 = f(z, nullptr);
    const NewtonResult r = pn.minimize(f, hess, z, o);
    EXPECT_LT(r.f, f0);
    scatter(z);
    const Eigen::VectorXd d = arap.determinants(X);
    return int((d.array() <= 0).count());
  };
  EXPECT_GT(run(false), 0);  // the pull does turn tets over without the barrier
  EXPECT_EQ(run(true), 0);
}
