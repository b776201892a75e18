// L-BFGS converges to the minimizer of Rosenbrock (2D and 100D) with the strong Wolfe and
// the Armijo line searches, and solves a quadratic.
#include "shapemap/optim/lbfgs.h"

#include "objectives.h"

#include <gtest/gtest.h>

using namespace shapemap;
using namespace shapemap_test;

TEST(Lbfgs, Rosenbrock2D) {
  for (bool wolfe : {true, false}) {
    Eigen::VectorXd x = rosenbrock_start(2);
    LbfgsOptions opt;
    opt.max_iterations = 500;
    opt.grad_tol = 1e-9;
    opt.wolfe = wolfe;
    LbfgsResult r = lbfgs_minimize(rosenbrock, x, opt);
    EXPECT_TRUE(r.converged) << "wolfe " << wolfe;
    EXPECT_LT((x - Eigen::VectorXd::Ones(2)).lpNorm<Eigen::Infinity>(), 1e-6) << "wolfe " << wolfe;
    EXPECT_LT(r.f, 1e-12);
    EXPECT_LT(r.grad_norm, 1e-9);
    EXPECT_GE(r.evaluations, r.iterations);
  }
}

TEST(Lbfgs, Rosenbrock100D) {
  for (bool wolfe : {true, false}) {
    Eigen::VectorXd x = rosenbrock_start(100);
    LbfgsOptions opt;
    opt.max_iterations = 3000;
    opt.grad_tol = 1e-8;
    opt.wolfe = wolfe;
    LbfgsResult r = lbfgs_minimize(rosenbrock, x, opt);
    EXPECT_TRUE(r.converged) << "wolfe " << wolfe;
    EXPECT_LT((x - Eigen::VectorXd::Ones(100)).lpNorm<Eigen::Infinity>(), 1e-6)
        << "wolfe " << wolfe << " iterations " << r.iterations;
  }
}

TEST(Lbfgs, QuadraticAndStoppingRules) {
  Quadratic q(50, 1e3, 11);
  const Objective f = [&](const Eigen::VectorXd& x, Eigen::VectorXd& g) { return q(x, g); };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(50);
  LbfgsOptions opt;
  opt.max_iterations = 1000;
  opt.grad_tol = 1e-7;  // |f| ~ 10: f decreases below rounding past ~1e-8
  LbfgsResult r = lbfgs_minimize(f, x, opt);
  EXPECT_TRUE(r.converged);
  EXPECT_LT((x - q.solution()).norm(), 1e-6);
  // max_iterations reached: not converged.
  x.setZero();
  opt.max_iterations = 3;
  r = lbfgs_minimize(f, x, opt);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.iterations, 3);
  // Relative decrease tolerance stops early.
  x.setZero();
  opt.max_iterations = 1000;
  opt.grad_tol = 0;
  opt.f_decrease_tol = 1e-3;
  r = lbfgs_minimize(f, x, opt);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.iterations, 1000);
  // Already at the minimum: no iteration.
  x = q.solution();
  opt.grad_tol = 1e-6;
  r = lbfgs_minimize(f, x, opt);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.iterations, 0);
}
