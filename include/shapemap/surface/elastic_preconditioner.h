// Initial inverse Hessian for the Y / Y~ steps of elastic correspondence (issue 20 speed,
// our addition; elastic-correspondence.txt Sec. 5.1 uses BFGS started from the identity).
//
//   K = kappa L_X + diag(d),   applied to the x, y and z columns alike,
//
// L_X: the cotangent Laplacian of the reference X (geometry/laplacian.h, x^T L x = sum of
// a_t tr(g^_t^-1 g_t) over faces, so the tr G part of Eq. 7 weighted by alpha has Hessian
// alpha mu L_X); d: per vertex, the diagonal of the mismatch and reversibility terms,
// 2 beta M (Eq. 3/4, exact) + 2 gamma Q^T M~ 1 (Eq. 6: the row sums of 2 gamma Q^T M~ Q).
// The pattern is analyzed once (fixed connectivity); set_diagonal() refactors.
// L-BFGS then runs with H0 = K^-1 (optim/lbfgs_memory.h): K captures the membrane's
// stiffness at all frequencies, which the scalar H0 = gamma I cannot.
#pragma once
#include "shapemap/geometry/sparse_cholesky.h"
#include <Eigen/Core>
#include <Eigen/Sparse>
#include <vector>

namespace shapemap {

class ElasticPreconditioner {
 public:
  ElasticPreconditioner() = default;
  // X n×3 reference positions, F m×3; kappa > 0 the weight of L_X.
  ElasticPreconditioner(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, double kappa);
  bool ready() const { return factored_; }
  int num_vertices() const { return int(L_.rows()); }
  // Factors K = kappa L_X + diag(d), d: n values > 0.
  void set_diagonal(const Eigen::VectorXd& d);
  // The same, but keeps the current factorization when every d_i is within a factor
  // (1 + tol) of the diagonal it was factored with: then K_old and K_new bound each other
  // within that factor (x'Kx = kappa x'L_X x + sum d_i x_i^2), so H0 = K_old^-1 is as good a
  // preconditioner up to that factor, which the scaling theta absorbs. Returns true when it
  // refactored. tol = 0: always.
  bool update_diagonal(const Eigen::VectorXd& d, double tol);
  // out = K^-1 in; in, out: 3n values, row-major positions (v[3i+k]); may alias.
  void apply(const double* in, double* out) const;
  // v^T K v for v of 3n values (row-major positions).
  double quadratic_form(const double* v) const;

 private:
  Eigen::SparseMatrix<double> L_;  // kappa L_X
  Eigen::SparseMatrix<double> K_;  // kappa L_X + diag(d)
  std::vector<Eigen::Index> diag_;  // position of K(i,i) in K's values
  void rebuild_diagonal_index();
  SparseCholesky chol_{SparseCholesky::Method::Simplicial};
  bool analyzed_ = false, factored_ = false;
  Eigen::VectorXd d_factored_;     // the diagonal d of the current factorization
  mutable Eigen::MatrixXd rhs_;    // n×3 scratch
};

}  // namespace shapemap
