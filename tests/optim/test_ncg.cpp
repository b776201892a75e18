// Preconditioned nonlinear CG: Rosenbrock (FR, PR+), the effect of an exact preconditioner
// on an ill-conditioned quadratic, and the trial_step hook (taken when it decreases f,
// rejected in favour of the line search when it does not).
#include "shapemap/optim/ncg.h"

#include "objectives.h"

#include <gtest/gtest.h>

using namespace shapemap;
using namespace shapemap_test;

TEST(Ncg, RosenbrockFletcherReevesAndPolakRibierePlus) {
  for (CGBeta beta : {CGBeta::FletcherReeves, CGBeta::PolakRibierePlus, CGBeta::PolakRibiere}) {
    for (int n : {2, 100}) {
      Eigen::VectorXd x = rosenbrock_start(n);
      NcgOptions opt;
      opt.beta = beta;
      opt.max_iterations = 20000;
      opt.f_decrease_tol = -1;  // off: stop on the gradient only
      opt.grad_tol = 1e-8;
      NcgResult r = ncg_minimize(rosenbrock, nullptr, x, opt);
      EXPECT_TRUE(r.converged) << "beta " << int(beta) << " n " << n;
      EXPECT_LT((x - Eigen::VectorXd::Ones(n)).lpNorm<Eigen::Infinity>(), 1e-5)
          << "beta " << int(beta) << " n " << n << " iterations " << r.iterations;
    }
  }
}

TEST(Ncg, ExactPreconditionerConvergesAtOnce) {
  Quadratic q(100, 1e5, 5);
  const Objective f = [&](const Eigen::VectorXd& x, Eigen::VectorXd& g) { return q(x, g); };
  const Eigen::LLT<Eigen::MatrixXd> llt(q.A);
  const Preconditioner exact = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
    z = llt.solve(r);
  };
  NcgOptions opt;
  opt.max_iterations = 5000;
  opt.f_decrease_tol = -1;
  opt.grad_tol = 1e-8;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(100);
  NcgResult pre = ncg_minimize(f, exact, x, opt);
  EXPECT_TRUE(pre.converged);
  EXPECT_LE(pre.iterations, 3);
  EXPECT_LT((x - q.solution()).norm(), 1e-6 * q.solution().norm());
  x.setZero();
  NcgResult plain = ncg_minimize(f, nullptr, x, opt);
  EXPECT_GT(plain.iterations, 30 * pre.iterations);
  // A diagonal quadratic with a diagonal (Jacobi, there exact) user preconditioner.
  Eigen::VectorXd diag(100), rhs = Eigen::VectorXd::Ones(100);
  for (int i = 0; i < 100; ++i) diag(i) = std::pow(1e5, i / 99.0);
  const Objective fd = [&](const Eigen::VectorXd& y, Eigen::VectorXd& g) {
    g = diag.cwiseProduct(y) - rhs;
    return 0.5 * y.dot(diag.cwiseProduct(y)) - rhs.dot(y);
  };
  x.setZero();
  NcgResult jac = ncg_minimize(
      fd, [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = r.cwiseQuotient(diag); }, x,
      opt);
  EXPECT_TRUE(jac.converged);
  EXPECT_LE(jac.iterations, 3);
  EXPECT_LT((x - rhs.cwiseQuotient(diag)).norm(), 1e-8);
}

TEST(Ncg, TrialStepUsedWhenItDecreases) {
  Quadratic q(40, 1e2, 9);
  const Objective f = [&](const Eigen::VectorXd& x, Eigen::VectorXd& g) { return q(x, g); };
  NcgOptions opt;
  opt.max_iterations = 200;
  opt.f_decrease_tol = -1;
  opt.grad_tol = 1e-6;  // far from rounding in f, where no step can decrease it
  int calls = 0;
  // Exact minimizer along d for a quadratic: alpha = -g.d / d'Ad.
  opt.trial_step = [&](const Eigen::VectorXd&, const Eigen::VectorXd& g,
                       const Eigen::VectorXd& d) {
    ++calls;
    return -g.dot(d) / d.dot(q.A * d);
  };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(40);
  NcgResult r = ncg_minimize(f, nullptr, x, opt);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.line_searches, 0);                 // every trial step was taken
  EXPECT_EQ(r.evaluations, 1 + r.iterations);    // one evaluation per step
  EXPECT_EQ(calls, r.iterations);
  EXPECT_LE(r.iterations, 60);  // linear CG with exact steps: about n iterations
  EXPECT_LT((x - q.solution()).norm(), 1e-5 * q.solution().norm());
}

TEST(Ncg, TrialStepRejectedWhenItIncreases) {
  Quadratic q(40, 1e2, 9);
  const Objective f = [&](const Eigen::VectorXd& x, Eigen::VectorXd& g) { return q(x, g); };
  NcgOptions opt;
  opt.max_iterations = 500;
  opt.f_decrease_tol = -1;
  opt.grad_tol = 1e-6;
  int calls = 0;
  // Ten times the exact step: f increases (for a quadratic, beyond twice the minimizer).
  opt.trial_step = [&](const Eigen::VectorXd&, const Eigen::VectorXd& g,
                       const Eigen::VectorXd& d) {
    ++calls;
    return -10 * g.dot(d) / d.dot(q.A * d);
  };
  int iterations_seen = 0;
  opt.on_iteration = [&](int it, double) { iterations_seen = it; return true; };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(40);
  NcgResult r = ncg_minimize(f, nullptr, x, opt);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.line_searches, r.iterations);  // every step came from the line search
  EXPECT_EQ(calls, r.iterations);
  EXPECT_EQ(iterations_seen, r.iterations);
  EXPECT_LT((x - q.solution()).norm(), 1e-5 * q.solution().norm());
}

TEST(Ncg, OnIterationStopsAndDecreaseTolerance) {
  const Objective f = rosenbrock;
  Eigen::VectorXd x = rosenbrock_start(10);
  NcgOptions opt;
  opt.on_iteration = [](int it, double) { return it < 5; };
  NcgResult r = ncg_minimize(f, nullptr, x, opt);
  EXPECT_EQ(r.iterations, 5);
  EXPECT_FALSE(r.converged);
  // Default f_decrease_tol (1e-6) stops eventually with converged = true.
  x = rosenbrock_start(10);
  NcgOptions opt2;
  opt2.max_iterations = 100000;
  r = ncg_minimize(f, nullptr, x, opt2);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.iterations, 100000);
}
