// Line searches along a descent direction d from x: phi(a) = f(x + a d).
#pragma once
#include "shapemap/optim/lbfgs.h"

namespace shapemap {

struct LineSearchResult {
  double alpha = 0, f = 0;
  int evaluations = 0;
  bool ok = false;
};

// Strong Wolfe conditions (Nocedal & Wright Alg. 3.5/3.6, bracketing and zoom by cubic
// interpolation). On return with ok, x_new = x + alpha d and g_new its gradient.
LineSearchResult strong_wolfe_search(const Objective& f, const Eigen::VectorXd& x, double fx,
                                     const Eigen::VectorXd& gx, const Eigen::VectorXd& d,
                                     double alpha0, double c1, double c2, int max_evals,
                                     Eigen::VectorXd& x_new, Eigen::VectorXd& g_new);

// Armijo backtracking (halving) from alpha0.
LineSearchResult armijo_search(const Objective& f, const Eigen::VectorXd& x, double fx,
                               const Eigen::VectorXd& gx, const Eigen::VectorXd& d,
                               double alpha0, double c1, int max_evals,
                               Eigen::VectorXd& x_new, Eigen::VectorXd& g_new);

}  // namespace shapemap
