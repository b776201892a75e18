// Preconditioned nonlinear conjugate gradient (Nocedal & Wright Section 5.2; the
// preconditioned forms of Shewchuk, "An Introduction to the Conjugate Gradient Method
// Without the Agonizing Pain", Section 14):
//   z = M^{-1} g,  d = -z + beta d,
//   FR:  beta = g_new.z_new / g.z
//   PR:  beta = g_new.(z_new - z) / g.z
//   PR+: max(0, PR)
// restarting with d = -z whenever d is not a descent direction (and, for FR, with Powell's
// criterion, N&W Eq. 5.52). The step is the optional
// trial step (taken if f decreases) or a strong Wolfe line search.
// All vectors are allocated once before the first iteration.
#include "shapemap/optim/ncg.h"

#include "shapemap/error.h"
#include "shapemap/optim/line_search.h"

#include <algorithm>
#include <cmath>

namespace shapemap {

NcgResult ncg_minimize(const Objective& f, const Preconditioner& precond, Eigen::VectorXd& x,
                       const NcgOptions& opt) {
  const Eigen::Index n = x.size();
  NcgResult res;
  Eigen::VectorXd g(n), g_new(n), z(n), z_new(n), d(n), x_new(n);
  auto apply_precond = [&](const Eigen::VectorXd& r, Eigen::VectorXd& out) {
    if (precond)
      precond(r, out);
    else
      out = r;
    if (out.size() != r.size()) throw Error("ncg_minimize: preconditioner returned a wrong size");
  };

  res.f = f(x, g);
  res.evaluations = 1;
  if (!std::isfinite(res.f)) throw Error("ncg_minimize: objective is not finite at the start");
  res.grad_norm = n ? g.lpNorm<Eigen::Infinity>() : 0.0;
  if (opt.grad_tol > 0 && res.grad_norm < opt.grad_tol) {
    res.converged = true;
    return res;
  }
  apply_precond(g, z);
  d = -z;
  double gz = g.dot(z);
  double f_prev = res.f, alpha_prev = 0;
  bool steepest = true;  // d = -z (a restart): a failed line search cannot be helped

  while (res.iterations < opt.max_iterations) {
    double gd = g.dot(d);
    if (!(gd < 0)) {  // not a descent direction: restart
      d = -z;
      gd = -gz;
      ++res.restarts;
      steepest = true;
      if (!(gd < 0)) break;  // preconditioner not positive definite here, or g = 0
    }
    // Step: the trial step if it decreases f, else strong Wolfe.
    bool stepped = false;
    double f_new = res.f;
    if (opt.trial_step) {
      const double a = opt.trial_step(x, g, d);
      if (a > 0 && std::isfinite(a)) {
        x_new.noalias() = x + a * d;
        const double ft = f(x_new, g_new);
        ++res.evaluations;
        if (std::isfinite(ft) && ft < res.f) {
          stepped = true;
          f_new = ft;
          alpha_prev = a;
        }
      }
    }
    if (!stepped) {
      // Initial step: 1 for the first (preconditioned) step, then the quadratic
      // interpolation of N&W Eq. 3.60, 2 (f_k - f_{k-1}) / phi'(0).
      double alpha0 = 1.0;
      if (res.iterations > 0 && alpha_prev > 0) {
        const double guess = 1.01 * 2 * (res.f - f_prev) / gd;
        if (std::isfinite(guess) && guess > 0) alpha0 = guess;
      }
      LineSearchResult ls = strong_wolfe_search(f, x, res.f, g, d, alpha0, opt.c1, opt.c2,
                                                opt.max_line_search, x_new, g_new);
      ++res.line_searches;
      res.evaluations += ls.evaluations;
      if (!ls.ok) {
        if (ls.alpha > 0 && ls.f < res.f) {  // keep the decrease found, then restart
          stepped = true;
          f_new = ls.f;
          alpha_prev = ls.alpha;
        } else if (!steepest) {  // retry along -z
          d = -z;
          ++res.restarts;
          steepest = true;
          continue;
        } else {
          break;  // no progress possible
        }
      } else {
        stepped = true;
        f_new = ls.f;
        alpha_prev = ls.alpha;
      }
    }
    // Accept the step.
    f_prev = res.f;
    x.swap(x_new);
    res.f = f_new;
    apply_precond(g_new, z_new);
    const double gz_new = g_new.dot(z_new);
    double beta = 0;
    switch (opt.beta) {
      case CGBeta::FletcherReeves:
        beta = gz_new / gz;
        break;
      case CGBeta::PolakRibiere:
        beta = (gz_new - g_new.dot(z)) / gz;
        break;
      case CGBeta::PolakRibierePlus:
        beta = std::max(0.0, (gz_new - g_new.dot(z)) / gz);
        break;
    }
    // Fletcher-Reeves needs restarts to be usable (N&W Eq. 5.52, Powell): when consecutive
    // (preconditioned) gradients are far from orthogonal, |g_new.z| >= 0.1 g_new.z_new.
    if (opt.beta == CGBeta::FletcherReeves && std::abs(g_new.dot(z)) >= 0.1 * gz_new) {
      beta = 0;
      ++res.restarts;
    }
    if (!std::isfinite(beta)) beta = 0;
    g.swap(g_new);
    z.swap(z_new);
    gz = gz_new;
    d = beta * d - z;
    steepest = beta == 0;
    ++res.iterations;
    res.grad_norm = g.lpNorm<Eigen::Infinity>();
    if (opt.on_iteration && !opt.on_iteration(res.iterations, res.f)) break;
    if (opt.grad_tol > 0 && res.grad_norm < opt.grad_tol) {
      res.converged = true;
      break;
    }
    if (f_prev - res.f < opt.f_decrease_tol) {
      res.converged = true;
      break;
    }
  }
  return res;
}

}  // namespace shapemap
