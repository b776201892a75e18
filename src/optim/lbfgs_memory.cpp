// L-BFGS curvature memory and two-loop recursion (see the header).
#include "shapemap/optim/lbfgs_memory.h"
#include <algorithm>
#include <cmath>

namespace shapemap {

void LbfgsMemory::init(Eigen::Index n, int memory) {
  m_ = std::max(1, memory);
  S_.resize(n, m_);
  Y_.resize(n, m_);
  rho_.resize(m_);
  a_.resize(m_);
  reset();
}

void LbfgsMemory::direction(const Eigen::VectorXd& g, Eigen::VectorXd& d) {
  d = g;
  for (int k = 0; k < stored_; ++k) {
    const int i = (newest_ - k + m_) % m_;
    a_(i) = rho_(i) * S_.col(i).dot(d);
    d.noalias() -= a_(i) * Y_.col(i);
  }
  d *= gamma_;
  for (int k = stored_ - 1; k >= 0; --k) {
    const int i = (newest_ - k + m_) % m_;
    const double b = rho_(i) * Y_.col(i).dot(d);
    d.noalias() += (a_(i) - b) * S_.col(i);
  }
  d = -d;
}

void LbfgsMemory::add_pair(const Eigen::VectorXd& x, const Eigen::VectorXd& x_new, const Eigen::VectorXd& g,
                           const Eigen::VectorXd& g_new) {
  const int slot = (newest_ + 1) % m_;
  S_.col(slot) = x_new - x;
  Y_.col(slot) = g_new - g;
  const double sy = S_.col(slot).dot(Y_.col(slot));
  const double yy = Y_.col(slot).squaredNorm();
  if (sy > 1e-10 * std::sqrt(S_.col(slot).squaredNorm() * yy) && sy > 0) {
    newest_ = slot;
    rho_(slot) = 1.0 / sy;
    gamma_ = sy / yy;
    stored_ = std::min(stored_ + 1, m_);
  } else if (stored_ == m_) {
    --stored_;  // the slot held the oldest pair, now overwritten: drop it
  }
}

}  // namespace shapemap
