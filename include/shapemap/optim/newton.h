// Projected Newton with a backtracking line search (Nocedal & Wright Alg. 3.1 on the Newton
// direction; "projected": the caller assembles a positive semi-definite approximation of the
// Hessian, e.g. per-element Hessians with negative eigenvalues clamped, Teran et al. 2005,
// Smith, de Goes, Kim 2019). The pattern is fixed (BlockHessian), so CHOLMOD's symbolic
// analysis runs once per solver object and each iteration only refactors.
#pragma once
#include "shapemap/geometry/sparse_cholesky.h"
#include "shapemap/optim/block_hessian.h"
#include <Eigen/Core>
#include <functional>
#include <string>

namespace shapemap {

struct NewtonOptions {
  int max_iterations = 20;
  double grad_tol = 1e-10;     // stop when ||g||_2 < grad_tol
  double f_rel_tol = 1e-9;     // stop when f_old - f_new < f_rel_tol * max(1e-300, |f_old|)
  double c1 = 1e-4;            // Armijo sufficient decrease
  int max_line_search = 30;    // halvings of the step before giving up
  double max_step = 0;         // > 0: scale the Newton step so that no unknown moves further
                               // than this (e.g. a fraction of the mesh's edge length)
  // > 0: when the first trial step is accepted, try doubling it up to this many times while
  // each doubling lowers f by Armijo's c1 times its added length (the clamped Hessian sees no
  // curvature where f is concave, e.g. at inverted tets, so the full step can be far shorter
  // than the descent it allows).
  int max_expansions = 0;
  // ProjectedNewton, > 0: a factor of H is kept as the preconditioner of conjugate gradients
  // on H d = -g in the later steps of the same minimize call while CG needs at most this many
  // iterations (cg_iterations at most, to cg_rel_tol); a step whose CG needs more refactors
  // for the next. CG multiplies by the current H, so the kept factor changes how fast it
  // converges, not where to. 0 = factor and solve exactly at every step.
  int refactor_cg = 0;
  int cg_iterations = 30;
  double cg_rel_tol = 1e-3;
};

struct NewtonResult {
  int iterations = 0, evaluations = 0, factorizations = 0;
  double f = 0, grad_norm = 0;  // at the final x; grad_norm Euclidean
  std::string stop;             // "gradient", "decrease", "iterations", "line search"
  double seconds_value = 0, seconds_hessian = 0, seconds_factor = 0, seconds_solve = 0;
};

// f(x, g): value, and the gradient into g when g != nullptr (g sized like x).
using NewtonValue = std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd* g)>;
// Fills H (already zeroed) with a positive semi-definite Hessian approximation at x.
using NewtonHessian = std::function<void(const Eigen::VectorXd& x, BlockHessian& H)>;
// A Newton-type direction d at x with gradient g (timings and factorizations into res).
using NewtonDirection =
    std::function<void(const Eigen::VectorXd& x, const Eigen::VectorXd& g, Eigen::VectorXd& d, NewtonResult& res)>;

// The descent loop shared by the Newton solvers: a direction per iteration, steepest descent
// when it is not one, Armijo backtracking on f, the stopping rules of `opt`.
NewtonResult newton_descent(const NewtonValue& f, const NewtonDirection& direction, Eigen::VectorXd& x,
                            const NewtonOptions& opt);

// Factors H into chol (its pattern analyzed), shifting H's diagonal when CHOLMOD finds it
// indefinite (rounding) until it factors.
void factor_shifted(BlockHessian& H, SparseCholesky& chol, NewtonResult& res);

// Conjugate gradients on A d = -g from d = 0, preconditioned by M (each given as its
// product with a vector): at most max_iterations, until r'Mr has fallen by rel_tol^2. Stops
// early, keeping the iterate, where A shows no positive curvature (rounding on a
// semi-definite A). Returns the iterations.
using LinearProduct = std::function<void(const Eigen::VectorXd& in, Eigen::VectorXd& out)>;
int preconditioned_cg(const LinearProduct& A, const LinearProduct& M, const Eigen::VectorXd& g, Eigen::VectorXd& d,
                      int max_iterations, double rel_tol);

class ProjectedNewton {
 public:
  ProjectedNewton() = default;
  // Runs CHOLMOD's symbolic analysis of the pattern here (not thread-safe: METIS), so that
  // minimize() may run concurrently on separate objects.
  explicit ProjectedNewton(BlockHessian pattern);
  BlockHessian& hessian() { return H_; }
  // Minimizes f from x (length 3·H.num_free()) in place. The Hessian gets a small diagonal
  // shift when CHOLMOD finds it indefinite (rounding), grown until it factors.
  NewtonResult minimize(const NewtonValue& f, const NewtonHessian& hess, Eigen::VectorXd& x,
                        const NewtonOptions& opt = {});

 private:
  BlockHessian H_;
  SparseCholesky chol_{SparseCholesky::Method::Supernodal, SparseCholesky::Ordering::NestedDissection};
};

}  // namespace shapemap
