// The Y-step preconditioner K = kappa L_X + diag(d) of elastic correspondence
// (surface/elastic_preconditioner.h): K is the Hessian (by central differences of an
// analytic gradient) of kappa/2 sum_t a^_t tr(g^_t^-1 g_t(Y)) (Eq. 7's tr G term) plus
// beta |Y - P X~|_X^2 (Eq. 3/4) with d = 2 beta m, and apply() solves with it.
#include "shapemap/generate.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/surface/elastic_preconditioner.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <random>

using namespace shapemap;

namespace {

// kappa/2 sum_t a^_t tr(g^-1 g(Y)) + beta sum_i m_i |y_i - p_i|^2 and its gradient (3n, row-major).
double model_energy(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, const Eigen::VectorXd& m,
                    const Eigen::VectorXd& p, double kappa, double beta, const Eigen::VectorXd& y,
                    Eigen::VectorXd& g) {
  g.setZero(y.size());
  double E = 0;
  for (int f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d x0 = X.row(F(f, 0)), x1 = X.row(F(f, 1)), x2 = X.row(F(f, 2));
    const Eigen::Vector3d u1 = x1 - x0, u2 = x2 - x0;
    Eigen::Matrix2d gh;
    gh << u1.dot(u1), u1.dot(u2), u1.dot(u2), u2.dot(u2);
    const double a = 0.5 * u1.cross(u2).norm();
    const Eigen::Matrix2d h = gh.inverse();
    const Eigen::Vector3d y0 = y.segment<3>(3 * F(f, 0));
    const Eigen::Vector3d e1 = y.segment<3>(3 * F(f, 1)) - y0, e2 = y.segment<3>(3 * F(f, 2)) - y0;
    const double t = h(0, 0) * e1.dot(e1) + 2 * h(0, 1) * e1.dot(e2) + h(1, 1) * e2.dot(e2);
    E += 0.5 * kappa * a * t;
    const Eigen::Vector3d g1 = kappa * a * (h(0, 0) * e1 + h(0, 1) * e2);
    const Eigen::Vector3d g2 = kappa * a * (h(0, 1) * e1 + h(1, 1) * e2);
    g.segment<3>(3 * F(f, 1)) += g1;
    g.segment<3>(3 * F(f, 2)) += g2;
    g.segment<3>(3 * F(f, 0)) -= g1 + g2;
  }
  for (int i = 0; i < X.rows(); ++i) {
    const Eigen::Vector3d r = y.segment<3>(3 * i) - p.segment<3>(3 * i);
    E += beta * m(i) * r.squaredNorm();
    g.segment<3>(3 * i) += 2 * beta * m(i) * r;
  }
  return E;
}

}  // namespace

// The surface both tests precondition on: a 500-vertex generated creature.
class ElasticPreconditionerOnCreature : public ::testing::Test {
 protected:
  const GeneratedPair pair = make_creature_pair(2, PairKind::NonIsometric, 500);
  const Eigen::MatrixXd& X = pair.A.V;
  const Eigen::MatrixXi& F = pair.A.F;
  const int n = int(X.rows());
};

TEST_F(ElasticPreconditionerOnCreature, IsTheHessianOfTheModelAndSolvesWithIt) {
  const double kappa = 20, beta = 3e3;
  const Eigen::VectorXd m = lumped_mass(X, F);
  std::mt19937 rng(3);
  std::normal_distribution<double> N(0, 1);
  Eigen::VectorXd y(3 * n), p(3 * n);
  for (int i = 0; i < 3 * n; ++i) y(i) = X(i / 3, i % 3) + 0.05 * N(rng), p(i) = N(rng);
  // gradient against energy (central differences)
  Eigen::VectorXd g, gp, gm;
  model_energy(X, F, m, p, kappa, beta, y, g);
  double max_err = 0;
  const double h = 1e-6;
  for (int j = 0; j < 3 * n; j += 7) {
    Eigen::VectorXd yp = y, ym = y;
    yp(j) += h;
    ym(j) -= h;
    const double fd = (model_energy(X, F, m, p, kappa, beta, yp, gp) - model_energy(X, F, m, p, kappa, beta, ym, gm)) / (2 * h);
    max_err = std::max(max_err, std::abs(fd - g(j)));
  }
  EXPECT_LT(max_err, 1e-6 * std::max(1.0, g.cwiseAbs().maxCoeff()));
  // Hessian (differences of the gradient) against K: K^-1 (H e_j) = e_j
  ElasticPreconditioner K(X, F, kappa);
  K.set_diagonal(2 * beta * m);
  double max_col = 0;
  for (int j = 0; j < 3 * n; j += 5) {
    Eigen::VectorXd yp = y, ym = y;
    yp(j) += h;
    ym(j) -= h;
    model_energy(X, F, m, p, kappa, beta, yp, gp);
    model_energy(X, F, m, p, kappa, beta, ym, gm);
    Eigen::VectorXd col = (gp - gm) / (2 * h), back(3 * n);
    K.apply(col.data(), back.data());
    back(j) -= 1;
    max_col = std::max(max_col, back.cwiseAbs().maxCoeff());
    // quadratic form: e_j' K e_j = H_jj
    Eigen::VectorXd e = Eigen::VectorXd::Unit(3 * n, j);
    EXPECT_NEAR(K.quadratic_form(e.data()), col(j), 1e-6 * std::abs(col(j)));
  }
  EXPECT_LT(max_col, 1e-6);
  // apply in place (in == out)
  Eigen::VectorXd v = y, w(3 * n);
  K.apply(v.data(), w.data());
  K.apply(v.data(), v.data());
  EXPECT_EQ((v - w).cwiseAbs().maxCoeff(), 0.0);
}

// update_diagonal (ElasticOptions::precondition_refactor_tol): a diagonal within the factor
// (1 + tol) of the factored one keeps the factorization (solves and x'Kx unchanged), and
// the bound it relies on holds: x'K_new x / x'K_old x lies in [1/(1+tol), 1+tol]; one entry
// beyond the factor refactors and solves as a fresh factorization of the new diagonal does.
TEST_F(ElasticPreconditionerOnCreature, LaggedRefactorizationWithinTheFactor) {
  const double kappa = 20, tol = 0.25;
  const Eigen::VectorXd d0 = 2e3 * lumped_mass(X, F);
  ElasticPreconditioner K(X, F, kappa);
  EXPECT_TRUE(K.update_diagonal(d0, tol));  // the first call always factors
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(1 / 1.2, 1.2);
  std::normal_distribution<double> N(0, 1);
  Eigen::VectorXd d1 = d0;
  for (int i = 0; i < n; ++i) d1(i) *= U(rng);
  Eigen::VectorXd x(3 * n);
  for (int i = 0; i < 3 * n; ++i) x(i) = N(rng);
  Eigen::VectorXd s0(3 * n), s1(3 * n);
  K.apply(x.data(), s0.data());
  const double q0 = K.quadratic_form(x.data());
  EXPECT_FALSE(K.update_diagonal(d1, tol));
  K.apply(x.data(), s1.data());
  EXPECT_EQ((s1 - s0).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(K.quadratic_form(x.data()), q0);
  // the bound, with a fresh factorization of d1
  ElasticPreconditioner K1(X, F, kappa);
  K1.set_diagonal(d1);
  const double ratio = K1.quadratic_form(x.data()) / q0;
  EXPECT_LE(ratio, 1 + tol);
  EXPECT_GE(ratio, 1 / (1 + tol));
  // one entry beyond the factor: refactored, and it solves with the new K
  Eigen::VectorXd d2 = d1;
  d2(n / 2) = 1.3 * d0(n / 2);
  EXPECT_TRUE(K.update_diagonal(d2, tol));
  ElasticPreconditioner K2(X, F, kappa);
  K2.set_diagonal(d2);
  Eigen::VectorXd a(3 * n), b(3 * n);
  K.apply(x.data(), a.data());
  K2.apply(x.data(), b.data());
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-12 * b.cwiseAbs().maxCoeff());
  // tol = 0: always refactors
  EXPECT_TRUE(K.update_diagonal(d2, 0));
}
