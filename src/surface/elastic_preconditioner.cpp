// K = kappa L_X + diag(d) for the elastic Y steps. See elastic_preconditioner.h.
#include "shapemap/surface/elastic_preconditioner.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"

#include <algorithm>

namespace shapemap {

ElasticPreconditioner::ElasticPreconditioner(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, double kappa) {
  if (!(kappa > 0)) throw InputError("elastic preconditioner: kappa must be > 0");
  L_ = kappa * cotan_laplacian(X, F);
  L_.makeCompressed();
  K_ = L_;
  diag_.assign(size_t(K_.rows()), -1);
  rebuild_diagonal_index();
}

// Where each diagonal entry sits in K's values; a vertex in no face gets an explicit entry.
void ElasticPreconditioner::rebuild_diagonal_index() {
  for (int pass = 0; pass < 2; ++pass) {
    for (Eigen::Index j = 0; j < K_.outerSize(); ++j)
      for (Eigen::Index p = K_.outerIndexPtr()[j]; p < K_.outerIndexPtr()[j + 1]; ++p)
        if (K_.innerIndexPtr()[p] == j) diag_[size_t(j)] = p;
    bool missing = false;
    for (Eigen::Index i = 0; i < K_.rows(); ++i)
      if (diag_[size_t(i)] < 0) K_.coeffRef(i, i) = 0, missing = true;
    if (!missing) return;
    K_.makeCompressed();
    L_ = K_;
  }
}

void ElasticPreconditioner::set_diagonal(const Eigen::VectorXd& d) {
  if (d.size() != L_.rows()) throw Error("elastic preconditioner: diagonal of the wrong size");
  // values of kappa L_X, plus d on the diagonal (same pattern: no allocation)
  std::copy(L_.valuePtr(), L_.valuePtr() + L_.nonZeros(), K_.valuePtr());
  for (Eigen::Index i = 0; i < d.size(); ++i) K_.valuePtr()[diag_[size_t(i)]] += d(i);
  if (!analyzed_) {
    chol_.analyze(K_);  // the pattern of L_X: once per run (fixed connectivity)
    analyzed_ = true;
  }
  chol_.factorize(K_);
  factored_ = true;
  d_factored_ = d;
}

bool ElasticPreconditioner::update_diagonal(const Eigen::VectorXd& d, double tol) {
  if (factored_ && tol > 0 && d.size() == d_factored_.size()) {
    bool close = true;
    for (Eigen::Index i = 0; i < d.size() && close; ++i)
      close = d(i) <= (1 + tol) * d_factored_(i) && d_factored_(i) <= (1 + tol) * d(i);
    if (close) return false;
  }
  set_diagonal(d);
  return true;
}

void ElasticPreconditioner::apply(const double* in, double* out) const {
  const Eigen::Index n = L_.rows();
  rhs_.resize(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) rhs_(i, k) = in[3 * i + k];
  const Eigen::MatrixXd x = chol_.solve(rhs_);
  for (Eigen::Index i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) out[3 * i + k] = x(i, k);
}

double ElasticPreconditioner::quadratic_form(const double* v) const {
  // one pass over the lower and upper entries of K (stored in full), x, y, z together
  double q = 0;
  for (Eigen::Index j = 0; j < K_.outerSize(); ++j) {
    const double* vj = v + 3 * j;
    for (Eigen::SparseMatrix<double>::InnerIterator it(K_, j); it; ++it) {
      const double* vi = v + 3 * it.index();
      q += it.value() * (vi[0] * vj[0] + vi[1] * vj[1] + vi[2] * vj[2]);
    }
  }
  return q;
}

}  // namespace shapemap
