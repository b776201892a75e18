// L-BFGS converges to the minimizer of Rosenbrock (2D and 100D) with the strong Wolfe and
// the Armijo line searches, and solves a quadratic.
#include "shapemap/optim/lbfgs.h"
#include "shapemap/optim/lbfgs_memory.h"

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

// The two-loop recursion with a given H0 (LbfgsMemory::direction's preconditioned form): on a
// quadratic with H0 = A^-1 and curvature pairs y = A s, BFGS keeps H = A^-1, so every
// direction is the Newton step -A^-1 g; with H0 = I it is not.
TEST(Lbfgs, PreconditionedTwoLoopWithExactH0IsNewton) {
  Quadratic q(30, 1e4, 5);
  const Eigen::LDLT<Eigen::MatrixXd> Ainv(q.A);
  LbfgsMemory H;
  H.init(30, 5);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(30), g(30), d(30), x_new(30), g_new(30);
  q(x, g);
  auto exact = [&](Eigen::VectorXd& v) { v = Ainv.solve(v); };
  auto identity = [](Eigen::VectorXd&) {};
  for (int k = 0; k < 8; ++k) {
    H.direction(g, d, exact);
    const Eigen::VectorXd newton = -Ainv.solve(g);
    EXPECT_LT((d - newton).norm(), 1e-8 * newton.norm()) << "pairs " << H.stored();
    // a step other than the Newton one, so that the pairs carry information
    x_new = x + 0.3 * d + 0.01 * Eigen::VectorXd::Unit(30, k);
    q(x_new, g_new);
    H.add_pair(x, x_new, g, g_new);
    x = x_new;
    g = g_new;
  }
  H.direction(g, d, identity);
  EXPECT_GT((d + Ainv.solve(g)).norm(), 1e-3 * Ainv.solve(g).norm());
}
