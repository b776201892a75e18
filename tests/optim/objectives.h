// Test objectives for the optimizers: extended Rosenbrock and quadratics.
#pragma once
#include <Eigen/Dense>
#include <random>

namespace shapemap_test {

// f(x) = sum_i 100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2, minimum 0 at x = 1.
inline double rosenbrock(const Eigen::VectorXd& x, Eigen::VectorXd& g) {
  const Eigen::Index n = x.size();
  double f = 0;
  g.setZero(n);
  for (Eigen::Index i = 0; i + 1 < n; ++i) {
    const double a = x(i + 1) - x(i) * x(i), b = 1 - x(i);
    f += 100 * a * a + b * b;
    g(i) += -400 * a * x(i) - 2 * b;
    g(i + 1) += 200 * a;
  }
  return f;
}

// Standard start (-1.2, 1, -1.2, 1, ...).
inline Eigen::VectorXd rosenbrock_start(int n) {
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x(i) = (i % 2 == 0) ? -1.2 : 1.0;
  return x;
}

// f(x) = 1/2 x'Ax - b'x with A SPD of condition number `cond` (random eigenvectors).
struct Quadratic {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  Quadratic(int n, double cond, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> g(0, 1);
    Eigen::MatrixXd R(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) R(i, j) = g(rng);
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(R);
    Eigen::MatrixXd Q = qr.householderQ();
    Eigen::VectorXd ev(n);
    for (int i = 0; i < n; ++i) ev(i) = std::pow(cond, double(i) / (n - 1));
    A = Q * ev.asDiagonal() * Q.transpose();
    A = 0.5 * (A + A.transpose());
    b.resize(n);
    for (int i = 0; i < n; ++i) b(i) = g(rng);
  }
  double operator()(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
    grad.noalias() = A * x - b;
    return 0.5 * x.dot(A * x) - b.dot(x);
  }
  Eigen::VectorXd solution() const { return A.ldlt().solve(b); }
};

}  // namespace shapemap_test
