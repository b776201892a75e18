// Projected Newton over two blocks of unknowns x = [x1; x2] whose Hessian is
//   [ H1  C  ]
//   [ C^T H2 ]
// with H1, H2 block Hessians of fixed patterns (BlockHessian, one CHOLMOD analysis each)
// and a coupling C whose pattern may change every iteration (sparse, 3k1 × 3k2). The
// Newton system is solved by conjugate gradients preconditioned with the two factors
// (block Jacobi): its first iterate is the direction of the two blocks' separate Newton
// steps, and the iterations add what the coupling changes. Used by the symmetric volume
// map's X-steps (issue 19), where the two maps X12, X21 are coupled through both P's.
#pragma once
#include "shapemap/optim/newton.h"
#include <Eigen/Sparse>
#include <functional>

namespace shapemap {

// The CG solve's limits and the kept factors (refactor_cg) are NewtonOptions' (newton.h):
// here CG always runs, and refactor_cg > 0 keeps the factors of H1 and H2 as its
// preconditioner while it needs at most that many iterations.
struct CoupledNewtonOptions {
  NewtonOptions newton;
};

// Fills H1 and H2 (zeroed) and sets C (3·H1.num_free() × 3·H2.num_free()) at x; together
// positive semi-definite.
using CoupledHessian =
    std::function<void(const Eigen::VectorXd& x, BlockHessian& H1, BlockHessian& H2, Eigen::SparseMatrix<double>& C)>;

class CoupledNewton {
 public:
  // Runs both symbolic analyses here (not thread-safe, as ProjectedNewton's).
  CoupledNewton(BlockHessian pattern1, BlockHessian pattern2);
  int size1() const { return 3 * H1_.num_free(); }
  int size2() const { return 3 * H2_.num_free(); }
  // Minimizes f from x (length size1() + size2()) in place. res.iterations counts Newton
  // steps; cg_iterations() the conjugate-gradient iterations of the last call.
  NewtonResult minimize(const NewtonValue& f, const CoupledHessian& hess, Eigen::VectorXd& x,
                        const CoupledNewtonOptions& opt = {});
  int cg_iterations() const { return cg_total_; }

 private:
  BlockHessian H1_, H2_;
  SparseCholesky chol1_{SparseCholesky::Method::Supernodal, SparseCholesky::Ordering::NestedDissection};
  SparseCholesky chol2_{SparseCholesky::Method::Supernodal, SparseCholesky::Ordering::NestedDissection};
  Eigen::SparseMatrix<double> C_;
  int cg_total_ = 0;
};

}  // namespace shapemap
