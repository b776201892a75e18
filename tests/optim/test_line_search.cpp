// Line searches: the strong Wolfe conditions hold on return (asserted), x_new / g_new are
// the point and gradient at alpha; Armijo gives sufficient decrease.
#include "shapemap/optim/line_search.h"

#include "objectives.h"

#include <gtest/gtest.h>
#include <cmath>

using namespace shapemap;
using namespace shapemap_test;

namespace {

void expect_strong_wolfe(const Objective& f, const Eigen::VectorXd& x, const Eigen::VectorXd& d,
                         double alpha0, double c1, double c2) {
  Eigen::VectorXd g(x.size()), x_new, g_new;
  const double fx = f(x, g);
  const double dphi0 = g.dot(d);
  ASSERT_LT(dphi0, 0);
  LineSearchResult r = strong_wolfe_search(f, x, fx, g, d, alpha0, c1, c2, 60, x_new, g_new);
  ASSERT_TRUE(r.ok);
  EXPECT_GT(r.alpha, 0);
  EXPECT_LE(r.evaluations, 60);
  // x_new, g_new, f are those of x + alpha d.
  EXPECT_LT((x_new - (x + r.alpha * d)).norm(), 1e-14 * (1 + x.norm()));
  Eigen::VectorXd g_check(x.size());
  EXPECT_DOUBLE_EQ(f(x_new, g_check), r.f);
  EXPECT_LT((g_check - g_new).norm(), 1e-12 * (1 + g_check.norm()));
  // Strong Wolfe: sufficient decrease and curvature.
  EXPECT_LE(r.f, fx + c1 * r.alpha * dphi0);
  EXPECT_LE(std::abs(g_new.dot(d)), c2 * std::abs(dphi0));
}

}  // namespace

TEST(LineSearch, StrongWolfeOnRosenbrock) {
  const Objective f = rosenbrock;
  std::mt19937 rng(7);
  std::normal_distribution<double> n01(0, 1);
  int cases = 0;
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::VectorXd x(6), g(6);
    for (int i = 0; i < 6; ++i) x(i) = 1.5 * n01(rng);
    f(x, g);
    // Steepest descent and a random descent direction; small, unit and huge first steps.
    Eigen::VectorXd d = -g;
    if (trial % 2) {
      for (int i = 0; i < 6; ++i) d(i) = n01(rng);
      if (d.dot(g) > 0) d = -d;
    }
    const double alpha0 = trial % 3 == 0 ? 1e-6 : (trial % 3 == 1 ? 1.0 : 1e3);
    for (double c2 : {0.9, 0.1}) {
      expect_strong_wolfe(f, x, d, alpha0, 1e-4, c2);
      ++cases;
    }
  }
  EXPECT_EQ(cases, 100);
}

TEST(LineSearch, StrongWolfeOnQuadraticAndNonFinite) {
  Quadratic q(20, 1e3, 3);
  const Objective f = [&](const Eigen::VectorXd& x, Eigen::VectorXd& g) { return q(x, g); };
  Eigen::VectorXd x = Eigen::VectorXd::Ones(20), g(20);
  f(x, g);
  expect_strong_wolfe(f, x, -g, 1.0, 1e-4, 0.1);
  expect_strong_wolfe(f, x, -g, 1e-8, 1e-4, 0.9);
  // A function that is +inf beyond a barrier (x >= 1): the search must back off.
  // f = -log(1-x) + x^2 - 2x, f' = 1/(1-x) + 2x - 2; at 0: f' = -1.
  const Objective bar = [](const Eigen::VectorXd& x, Eigen::VectorXd& g) {
    g.resize(1);
    if (x(0) >= 1) {
      g(0) = 0;
      return std::numeric_limits<double>::infinity();
    }
    g(0) = 1.0 / (1 - x(0)) + 2 * x(0) - 2;
    return -std::log(1 - x(0)) + x(0) * x(0) - 2 * x(0);
  };
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(1), d = Eigen::VectorXd::Ones(1);
  expect_strong_wolfe(bar, x0, d, 10.0, 1e-4, 0.5);
}

TEST(LineSearch, RejectsAscentDirection) {
  const Objective f = rosenbrock;
  Eigen::VectorXd x = rosenbrock_start(4), g(4), x_new, g_new;
  const double fx = f(x, g);
  LineSearchResult r = strong_wolfe_search(f, x, fx, g, g, 1.0, 1e-4, 0.9, 40, x_new, g_new);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.alpha, 0);
  EXPECT_EQ(x_new, x);
  r = armijo_search(f, x, fx, g, g, 1.0, 1e-4, 40, x_new, g_new);
  EXPECT_FALSE(r.ok);
}

TEST(LineSearch, ArmijoSufficientDecrease) {
  const Objective f = rosenbrock;
  Eigen::VectorXd x = rosenbrock_start(10), g(10), x_new, g_new;
  const double fx = f(x, g);
  LineSearchResult r = armijo_search(f, x, fx, g, -g, 1.0, 1e-4, 60, x_new, g_new);
  ASSERT_TRUE(r.ok);
  EXPECT_LE(r.f, fx - 1e-4 * r.alpha * g.squaredNorm());
  // Halving from 1: alpha is a power of two.
  EXPECT_EQ(std::log2(r.alpha), std::round(std::log2(r.alpha)));
  Eigen::VectorXd g_check(10);
  EXPECT_DOUBLE_EQ(f(x_new, g_check), r.f);
  EXPECT_LT((g_check - g_new).norm(), 1e-12 * g_check.norm());
}
