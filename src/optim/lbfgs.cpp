// L-BFGS (Nocedal & Wright Algorithm 7.4/7.5): two-loop recursion over the last `memory`
// pairs (s, y), initial Hessian scaling gamma = s'y / y'y (Eq. 7.20), pairs with too little
// curvature skipped; step from a strong Wolfe line search or Armijo backtracking.
// All vectors are allocated once before the first iteration.
#include "shapemap/optim/lbfgs.h"

#include "shapemap/error.h"
#include "shapemap/optim/lbfgs_memory.h"
#include "shapemap/optim/line_search.h"

#include <algorithm>
#include <cmath>

namespace shapemap {

LbfgsResult lbfgs_minimize(const Objective& f, Eigen::VectorXd& x, const LbfgsOptions& opt) {
  if (opt.memory < 1) throw InputError("lbfgs_minimize: memory must be >= 1");
  const Eigen::Index n = x.size();
  LbfgsResult res;
  LbfgsMemory H;
  H.init(n, opt.memory);
  Eigen::VectorXd g(n), g_new(n), d(n), x_new(n);

  res.f = f(x, g);
  res.evaluations = 1;
  res.grad_norm = g.size() ? g.lpNorm<Eigen::Infinity>() : 0.0;
  if (!std::isfinite(res.f)) throw Error("lbfgs_minimize: objective is not finite at the start");
  if (res.grad_norm < opt.grad_tol) {
    res.converged = true;
    return res;
  }

  bool restarted = false;  // the last direction was steepest descent after a reset
  while (res.iterations < opt.max_iterations) {
    H.direction(g, d);
    double gd = g.dot(d);
    if (!(gd < 0)) {  // not a descent direction (rounding): reset to steepest descent
      H.reset();
      d = -g;
      gd = g.dot(d);
    }
    // First step (no curvature information): unit length in x.
    const double alpha0 = H.stored() == 0 ? std::min(1.0, 1.0 / std::sqrt(-gd)) : 1.0;
    LineSearchResult ls =
        opt.wolfe ? strong_wolfe_search(f, x, res.f, g, d, alpha0, opt.c1, opt.c2,
                                        opt.max_line_search, x_new, g_new)
                  : armijo_search(f, x, res.f, g, d, alpha0, opt.c1, opt.max_line_search,
                                  x_new, g_new);
    res.evaluations += ls.evaluations;
    if (!ls.ok) {
      if (H.stored() > 0 && !restarted) {  // retry once from steepest descent
        H.reset();
        restarted = true;
        continue;
      }
      // Keep any decrease the failed search found, then stop.
      if (ls.alpha > 0 && ls.f < res.f) {
        x.swap(x_new);
        g.swap(g_new);
        res.f = ls.f;
        res.grad_norm = g.lpNorm<Eigen::Infinity>();
      }
      break;
    }
    restarted = false;
    H.add_pair(x, x_new, g, g_new);
    const double f_old = res.f;
    x.swap(x_new);
    g.swap(g_new);
    res.f = ls.f;
    res.grad_norm = g.lpNorm<Eigen::Infinity>();
    ++res.iterations;
    if (res.grad_norm < opt.grad_tol) {
      res.converged = true;
      break;
    }
    if (opt.f_decrease_tol > 0 &&
        f_old - res.f < opt.f_decrease_tol * std::max(1.0, std::abs(res.f))) {
      res.converged = true;
      break;
    }
  }
  return res;
}

LbfgsResult minimize_rows(const std::function<double(const Eigen::MatrixXd&, Eigen::MatrixXd*)>& f,
                          Eigen::MatrixXd& X, const std::vector<int>& free_rows, int iterations,
                          int memory) {
  const int k = int(free_rows.size());
  Eigen::VectorXd x(3 * k);
  for (int q = 0; q < k; ++q) x.segment<3>(3 * q) = X.row(free_rows[q]).transpose();
  Eigen::MatrixXd Xf = X, G;
  Eigen::VectorXd last_z, last_g;
  double last_f = 0;
  Objective obj = [&](const Eigen::VectorXd& z, Eigen::VectorXd& g) {
    for (int q = 0; q < k; ++q) Xf.row(free_rows[q]) = z.segment<3>(3 * q).transpose();
    double e = f(Xf, &G);
    for (int q = 0; q < k; ++q) g.segment<3>(3 * q) = G.row(free_rows[q]).transpose();
    last_z = z;
    last_g = g;
    last_f = e;
    return e;
  };
  LbfgsOptions lo;
  lo.max_iterations = iterations;
  lo.memory = memory;
  lo.grad_tol = 1e-10;
  lo.f_decrease_tol = 1e-12;
  LbfgsResult res;
  if (k > 0 && iterations > 0) {
    res = lbfgs_minimize(obj, x, lo);
  } else {
    Eigen::VectorXd g(3 * k);
    res.f = obj(x, g);
    res.grad_norm = k > 0 ? g.lpNorm<Eigen::Infinity>() : 0.0;
  }
  for (int q = 0; q < k; ++q) X.row(free_rows[q]) = x.segment<3>(3 * q).transpose();
  // Report the Euclidean norm of the gradient at the final point (Sec. 5.4 (i)).
  if (k > 0 && (last_z.size() != x.size() || last_z != x)) {
    Eigen::VectorXd g(3 * k);
    obj(x, g);
  }
  res.f = k > 0 ? last_f : res.f;
  res.grad_norm = k > 0 ? last_g.norm() : 0.0;
  return res;
}

}  // namespace shapemap
