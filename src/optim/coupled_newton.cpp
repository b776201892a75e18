// Two-block projected Newton with a block-Jacobi preconditioned CG solve (coupled_newton.h).
#include "shapemap/optim/coupled_newton.h"
#include "shapemap/error.h"
#include "shapemap/timing.h"
#include "shapemap/task_pair.h"
#include <cmath>

namespace shapemap {


CoupledNewton::CoupledNewton(BlockHessian pattern1, BlockHessian pattern2)
    : H1_(std::move(pattern1)), H2_(std::move(pattern2)) {
  if (H1_.num_free() > 0) chol1_.analyze(H1_.matrix());
  if (H2_.num_free() > 0) chol2_.analyze(H2_.matrix());
}

NewtonResult CoupledNewton::minimize(const NewtonValue& f, const CoupledHessian& hess, Eigen::VectorXd& x,
                                     const CoupledNewtonOptions& opt) {
  const int n1 = size1(), n2 = size2();
  if (x.size() != n1 + n2) throw Error("CoupledNewton: x has the wrong length");
  cg_total_ = 0;
  bool refactor = true;  // factors are kept within one call (one objective) only
  const bool parallel = factorizations_in_parallel();  // H1's and H2's factors and solves at once
  NewtonDirection newton = [&](const Eigen::VectorXd& z, const Eigen::VectorXd& g, Eigen::VectorXd& d,
                               NewtonResult& res) {
    auto t = Clock::now();
    H1_.set_zero();
    H2_.set_zero();
    hess(z, H1_, H2_, C_);
    res.seconds_hessian += seconds_since(t);
    if (refactor || opt.newton.refactor_cg <= 0) {
      NewtonResult r1, r2;
      t = Clock::now();
      run_pair([&] { if (n1 > 0) factor_shifted(H1_, chol1_, r1); },
               [&] { if (n2 > 0) factor_shifted(H2_, chol2_, r2); }, parallel);
      res.factorizations += r1.factorizations + r2.factorizations;
      res.seconds_factor += seconds_since(t);  // wall time of the two together
    }
    t = Clock::now();
    if (C_.rows() != n1 || C_.cols() != n2) throw Error("CoupledNewton: the coupling block has the wrong size");
    // The two halves of the product are independent: at once (each reads all of p).
    auto apply = [&](const Eigen::VectorXd& p, Eigen::VectorXd& q) {
      q.resize(n1 + n2);
      run_pair([&] { q.head(n1) = H1_.multiply(p.head(n1)) + C_ * p.tail(n2); },
               [&] { q.tail(n2) = H2_.multiply(p.tail(n2)) + C_.transpose() * p.head(n1); },
               two_threads_available());
    };
    auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd& s) {
      s.resize(n1 + n2);
      run_pair([&] { if (n1 > 0) s.head(n1) = chol1_.solve(Eigen::VectorXd(r.head(n1))); },
               [&] { if (n2 > 0) s.tail(n2) = chol2_.solve(Eigen::VectorXd(r.tail(n2))); }, parallel);
    };
    // PCG on [H1 C; C^T H2] d = -g from d = 0.
    const int k = preconditioned_cg(apply, precondition, g, d, opt.newton.cg_iterations, opt.newton.cg_rel_tol);
    cg_total_ += k;
    refactor = k > opt.newton.refactor_cg;
    res.seconds_solve += seconds_since(t);
  };
  return newton_descent(f, newton, x, opt.newton);
}

}  // namespace shapemap
