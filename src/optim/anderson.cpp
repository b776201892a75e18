// Anderson acceleration (type II): see anderson.h.
#include "shapemap/optim/anderson.h"

#include <Eigen/QR>

namespace shapemap {

void AndersonAcceleration::reset() {
  f_prev_.resize(0);
  g_prev_.resize(0);
  dF_.clear();
  dG_.clear();
}

Eigen::VectorXd AndersonAcceleration::step(const Eigen::VectorXd& x, const Eigen::VectorXd& gx) {
  const Eigen::VectorXd f = gx - x;
  if (f_prev_.size() == f.size() && m_ > 0) {
    dF_.push_back(f - f_prev_);
    dG_.push_back(gx - g_prev_);
    if (int(dF_.size()) > m_) {
      dF_.pop_front();
      dG_.pop_front();
    }
  }
  f_prev_ = f;
  g_prev_ = gx;
  const int k = int(dF_.size());
  if (k == 0) return gx;
  Eigen::MatrixXd F(f.size(), k);
  for (int j = 0; j < k; ++j) F.col(j) = dF_[j];
  // Rank-revealing QR: near-parallel differences (a stalled iteration) get theta = 0 in
  // their direction instead of a huge coefficient.
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(F);
  qr.setThreshold(1e-10);
  const Eigen::VectorXd theta = qr.solve(f);
  Eigen::VectorXd next = gx;
  for (int j = 0; j < k; ++j) next -= theta(j) * dG_[j];
  return next;
}

}  // namespace shapemap
