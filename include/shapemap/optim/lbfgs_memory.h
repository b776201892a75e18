// The L-BFGS curvature memory (Nocedal & Wright Algorithm 7.4/7.5): the last `memory`
// pairs (s, y) in a circular buffer, the two-loop recursion d = -H g with the initial
// scaling gamma = s'y / y'y (Eq. 7.20), and the rule that skips pairs without positive
// curvature. Shared by lbfgs_minimize and the elastic Y steps, which keep it across outer
// iterations (warm start); allocated once.
#pragma once
#include <Eigen/Core>

namespace shapemap {

class LbfgsMemory {
 public:
  // n unknowns, at most `memory` (>= 1) pairs; starts empty.
  void init(Eigen::Index n, int memory);
  // Forgets every pair (the next direction is steepest descent).
  void reset() {
    stored_ = 0;
    newest_ = -1;
    gamma_ = 1;
  }
  int stored() const { return stored_; }
  Eigen::Index size() const { return S_.rows(); }
  // d = -H g (two-loop recursion).
  void direction(const Eigen::VectorXd& g, Eigen::VectorXd& d);
  // The same with the initial matrix H0 given by h0 (a callable that replaces its argument
  // v by H0 v, e.g. a sparse Cholesky solve) instead of gamma I: N&W Algorithm 7.4 allows any
  // symmetric positive definite H0 (a preconditioner).
  template <class ApplyH0>
  void direction(const Eigen::VectorXd& g, Eigen::VectorXd& d, ApplyH0&& h0) {
    d = g;
    for (int k = 0; k < stored_; ++k) {
      const int i = (newest_ - k + m_) % m_;
      a_(i) = rho_(i) * S_.col(i).dot(d);
      d.noalias() -= a_(i) * Y_.col(i);
    }
    h0(d);
    for (int k = stored_ - 1; k >= 0; --k) {
      const int i = (newest_ - k + m_) % m_;
      const double b = rho_(i) * Y_.col(i).dot(d);
      d.noalias() += (a_(i) - b) * S_.col(i);
    }
    d = -d;
  }
  // Adds s = x_new - x, y = g_new - g, unless s'y <= 1e-10 |s| |y| (no positive curvature).
  void add_pair(const Eigen::VectorXd& x, const Eigen::VectorXd& x_new, const Eigen::VectorXd& g,
                const Eigen::VectorXd& g_new);

 private:
  int m_ = 0;
  Eigen::MatrixXd S_, Y_;  // n × m
  Eigen::VectorXd rho_, a_;
  int stored_ = 0, newest_ = -1;
  double gamma_ = 1;
};

}  // namespace shapemap
