// Preconditioned nonlinear conjugate gradient.
#pragma once
#include "shapemap/optim/lbfgs.h"
#include <functional>

namespace shapemap {

// z = M^{-1} r, the preconditioner solve.
using Preconditioner = std::function<void(const Eigen::VectorXd& r, Eigen::VectorXd& z)>;

enum class CGBeta { FletcherReeves, PolakRibiere, PolakRibierePlus };

struct NcgOptions {
  int max_iterations = 500;
  double f_decrease_tol = 1e-6;  // stop when f_old - f_new < tol
  double grad_tol = 0;           // stop when ||g||_inf < tol (0 = off)
  CGBeta beta = CGBeta::PolakRibierePlus;
  double c1 = 1e-4, c2 = 0.1;    // strong Wolfe parameters (c2 < 1/2 for FR)
  int max_line_search = 40;
  // Optional: a trial step length for direction d at x (e.g. a quadratic model, Eq. 17
  // of the isovolumetric paper). If it returns alpha > 0 and f decreases, it is taken;
  // otherwise the strong Wolfe line search is used.
  std::function<double(const Eigen::VectorXd& x, const Eigen::VectorXd& g,
                       const Eigen::VectorXd& d)> trial_step;
  // Called after each iteration with (iteration, f); return false to stop.
  std::function<bool(int, double)> on_iteration;
};

struct NcgResult {
  int iterations = 0, evaluations = 0, line_searches = 0, restarts = 0;
  double f = 0, grad_norm = 0;
  bool converged = false;
};

NcgResult ncg_minimize(const Objective& f, const Preconditioner& precond, Eigen::VectorXd& x,
                       const NcgOptions& opt = {});

}  // namespace shapemap
