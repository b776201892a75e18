// Projected Newton with backtracking (newton.h).
#include "shapemap/optim/newton.h"
#include "shapemap/timing.h"
#include "shapemap/error.h"
#include <chrono>
#include <cmath>

namespace shapemap {

namespace {
// Mean of the diagonal of a lower-triangle CSC matrix (its scale, for the shift).
double mean_diagonal(const Eigen::SparseMatrix<double>& H) {
  double s = 0;
  for (int j = 0; j < H.outerSize(); ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(H, j); it; ++it)
      if (it.row() == j) s += it.value();
  return H.rows() > 0 ? s / double(H.rows()) : 0.0;
}
}  // namespace

void factor_shifted(BlockHessian& H, SparseCholesky& chol, NewtonResult& res) {
  const auto t = Clock::now();
  double shift = 0;
  for (int attempt = 0;; ++attempt) {
    try {
      chol.factorize(H.matrix());  // the analysis of the owner's constructor
      ++res.factorizations;
      break;
    } catch (const Error&) {
      if (attempt >= 12) throw Error("ProjectedNewton: the Hessian does not factor even when shifted");
      const double add = shift == 0 ? 1e-10 * std::max(1e-300, std::abs(mean_diagonal(H.matrix()))) : 9 * shift;
      H.add_diagonal(add);
      shift += add;
    }
  }
  res.seconds_factor += seconds_since(t);
}

int preconditioned_cg(const LinearProduct& A, const LinearProduct& M, const Eigen::VectorXd& g, Eigen::VectorXd& d,
                      int max_iterations, double rel_tol) {
  Eigen::VectorXd r = -g, s, p, q;
  d.setZero(g.size());
  M(r, s);
  p = s;
  double rs = r.dot(s);
  const double rs0 = rs;
  int k = 0;
  for (; k < max_iterations && rs > rel_tol * rel_tol * rs0; ++k) {
    A(p, q);
    const double pq = p.dot(q);
    if (!(pq > 0)) {  // rounding on a semi-definite system: keep what we have
      if (k == 0) d = p;
      break;
    }
    const double a = rs / pq;
    d += a * p;
    r -= a * q;
    M(r, s);
    const double rs_new = r.dot(s);
    p = s + (rs_new / rs) * p;
    rs = rs_new;
  }
  return k;
}

NewtonResult newton_descent(const NewtonValue& f, const NewtonDirection& direction, Eigen::VectorXd& x,
                            const NewtonOptions& opt) {
  const Eigen::Index N = x.size();
  NewtonResult res;
  Eigen::VectorXd g(N), g_new(N), x_new, d, x_try, g_try(N);
  auto t = Clock::now();
  double fx = f(x, &g);
  res.seconds_value += seconds_since(t);
  ++res.evaluations;
  res.f = fx;
  res.grad_norm = g.norm();
  if (N == 0) {
    res.stop = "gradient";
    return res;
  }
  for (int it = 0; it < opt.max_iterations; ++it) {
    if (res.grad_norm < opt.grad_tol) {
      res.stop = "gradient";
      return res;
    }
    direction(x, g, d, res);
    double slope = g.dot(d);
    if (!(slope < 0) || !d.allFinite()) {  // not a descent direction (rounding): steepest descent
      d = -g;
      slope = -g.squaredNorm();
    }
    double step = 1.0;
    if (opt.max_step > 0) {
      const double longest = d.lpNorm<Eigen::Infinity>();
      if (longest > opt.max_step) step = opt.max_step / longest;
    }
    const double first_step = step;
    // Backtracking (Armijo) on the full energy.
    bool accepted = false;
    double f_new = fx;
    t = Clock::now();
    for (int ls = 0; ls < opt.max_line_search; ++ls) {
      x_new = x + step * d;
      f_new = f(x_new, &g_new);
      ++res.evaluations;
      if (std::isfinite(f_new) && f_new <= fx + opt.c1 * step * slope) {
        accepted = true;
        break;
      }
      step *= 0.5;
    }
    // Expansion (NewtonOptions::max_expansions): only when the first trial was accepted.
    const bool expand = accepted && step == first_step;
    for (int e = 0; expand && e < opt.max_expansions; ++e) {
      x_try = x + 2 * step * d;
      const double f_try = f(x_try, &g_try);
      ++res.evaluations;
      // The added length `step` must itself give Armijo's decrease: a doubling that gains
      // next to nothing is refused, so that rounding does not decide it (swapping the inputs
      // of a symmetric problem must give the same steps).
      if (!(std::isfinite(f_try) && f_try <= f_new + opt.c1 * step * slope)) break;
      x_new.swap(x_try);
      g_new.swap(g_try);
      f_new = f_try;
      step *= 2;
    }
    res.seconds_value += seconds_since(t);
    ++res.iterations;
    if (!accepted) {
      // No decrease along d: x is where rounding ends the descent. Keep it.
      res.stop = "line search";
      return res;
    }
    const double decrease = fx - f_new;
    x.swap(x_new);
    g.swap(g_new);
    fx = f_new;
    res.f = fx;
    res.grad_norm = g.norm();
    if (decrease < opt.f_rel_tol * std::max(1e-300, std::abs(fx + decrease))) {
      res.stop = "decrease";
      return res;
    }
  }
  res.stop = res.grad_norm < opt.grad_tol ? "gradient" : "iterations";
  return res;
}

ProjectedNewton::ProjectedNewton(BlockHessian pattern) : H_(std::move(pattern)) {
  if (H_.num_free() > 0) chol_.analyze(H_.matrix());
}

NewtonResult ProjectedNewton::minimize(const NewtonValue& f, const NewtonHessian& hess,
                                       Eigen::VectorXd& x, const NewtonOptions& opt) {
  if (x.size() != 3 * H_.num_free()) throw Error("ProjectedNewton: x has the wrong length");
  bool refactor = true;  // a factor is kept within one call (one objective) only
  // Newton direction: H d = -g, H positive semi-definite (shifted when it does not factor).
  NewtonDirection newton = [&](const Eigen::VectorXd& z, const Eigen::VectorXd& g, Eigen::VectorXd& d,
                               NewtonResult& res) {
    auto t = Clock::now();
    H_.set_zero();
    hess(z, H_);
    res.seconds_hessian += seconds_since(t);
    if (refactor || opt.refactor_cg <= 0) {
      factor_shifted(H_, chol_, res);
      refactor = false;
      t = Clock::now();
      d = -chol_.solve(g);
    } else {
      t = Clock::now();
      const int k = preconditioned_cg([&](const Eigen::VectorXd& p, Eigen::VectorXd& q) { q = H_.multiply(p); },
                                      [&](const Eigen::VectorXd& r, Eigen::VectorXd& s) { s = chol_.solve(r); }, g, d,
                                      opt.cg_iterations, opt.cg_rel_tol);
      refactor = k > opt.refactor_cg;
    }
    res.seconds_solve += seconds_since(t);
  };
  return newton_descent(f, newton, x, opt);
}

}  // namespace shapemap
