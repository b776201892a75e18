// Anderson acceleration of a fixed-point iteration x <- G(x) (Walker & Ni 2011, "Anderson
// acceleration for fixed-point iterations"; used on alternating geometry solvers by Peng,
// Deng, Zhang, Liu 2018, "Anderson acceleration for geometry optimization and physics
// simulation"). From the last m+1 pairs (x_k, G(x_k)) it proposes
//   x_{k+1} = G(x_k) - dG theta,   theta = argmin || f_k - dF theta ||_2,
// f = G(x) - x, dF / dG the differences of consecutive f / G. The caller guards the
// proposal with its own energy (accept it when it lowers the energy, else take G(x_k)),
// as Peng et al. do.
#pragma once
#include <Eigen/Core>
#include <deque>

namespace shapemap {

class AndersonAcceleration {
 public:
  explicit AndersonAcceleration(int memory) : m_(memory) {}
  // Forget the history (the fixed-point map changed, e.g. its weights).
  void reset();
  // Records the pair (x, G(x)) and returns the accelerated next point (G(x) itself until a
  // second pair is known, or with memory 0).
  Eigen::VectorXd step(const Eigen::VectorXd& x, const Eigen::VectorXd& gx);
  int history() const { return int(dF_.size()); }

 private:
  int m_;
  Eigen::VectorXd f_prev_, g_prev_;
  std::deque<Eigen::VectorXd> dF_, dG_;
};

}  // namespace shapemap
