// Anderson acceleration (anderson.h): on a linear contraction x <- M x + b, whose fixed
// point is known in closed form, it must reach the fixed point in far fewer iterations
// than the plain iteration; with memory n it is exact after n + 1 steps (GMRES
// equivalence, Walker & Ni 2011); with memory 0 it is the plain iteration.
#include "shapemap/optim/anderson.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <random>

using namespace shapemap;

namespace {
struct LinearMap {
  Eigen::MatrixXd M;
  Eigen::VectorXd b, fixed;
  explicit LinearMap(int n) {
    std::mt19937 rng(7);
    std::normal_distribution<double> g(0, 1);
    Eigen::MatrixXd Q(n, n);
    for (int i = 0; i < Q.size(); ++i) Q(i) = g(rng);
    Q = Eigen::HouseholderQR<Eigen::MatrixXd>(Q).householderQ();
    Eigen::VectorXd lam(n);  // slow modes: spectral radius 0.99
    for (int i = 0; i < n; ++i) lam(i) = 0.99 * (1.0 - double(i) / n);
    M = Q * lam.asDiagonal() * Q.transpose();
    b.resize(n);
    for (int i = 0; i < n; ++i) b(i) = g(rng);
    fixed = (Eigen::MatrixXd::Identity(n, n) - M).lu().solve(b);
  }
  Eigen::VectorXd G(const Eigen::VectorXd& x) const { return M * x + b; }
};

int iterations_to(const LinearMap& L, int memory, double tol, int cap) {
  AndersonAcceleration aa(memory);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(L.b.size());
  for (int k = 0; k < cap; ++k) {
    if ((x - L.fixed).norm() < tol * L.fixed.norm()) return k;
    x = aa.step(x, L.G(x));
  }
  return cap;
}
}  // namespace

TEST(Anderson, MemoryZeroIsThePlainIteration) {
  LinearMap L(20);
  AndersonAcceleration aa(0);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(20), y = x;
  for (int k = 0; k < 5; ++k) {
    x = aa.step(x, L.G(x));
    y = L.G(y);
  }
  EXPECT_LT((x - y).norm(), 1e-14 * y.norm());
  EXPECT_EQ(aa.history(), 0);
}

TEST(Anderson, AcceleratesASlowContraction) {
  LinearMap L(40);
  const int plain = iterations_to(L, 0, 1e-8, 5000);
  const int accelerated = iterations_to(L, 5, 1e-8, 5000);
  EXPECT_GT(plain, 1000);  // 0.99^k < 1e-8 needs ~1800 steps
  EXPECT_LT(accelerated, plain / 10);
}

TEST(Anderson, FullMemoryIsExactAfterDimensionPlusOneSteps) {
  LinearMap L(6);
  AndersonAcceleration aa(6);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
  for (int k = 0; k < 8; ++k) x = aa.step(x, L.G(x));
  EXPECT_LT((x - L.fixed).norm(), 1e-8 * L.fixed.norm());
}

TEST(Anderson, ResetForgetsTheHistory) {
  LinearMap L(10);
  AndersonAcceleration aa(3);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(10);
  for (int k = 0; k < 4; ++k) x = aa.step(x, L.G(x));
  EXPECT_EQ(aa.history(), 3);
  aa.reset();
  EXPECT_EQ(aa.history(), 0);
  const Eigen::VectorXd gx = L.G(x);
  EXPECT_EQ(aa.step(x, gx), gx);  // first pair after a reset: the plain step
}
