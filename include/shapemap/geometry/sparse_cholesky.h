// A thin owner of a CHOLMOD factorization (supernodal, via Eigen's CholmodSupport).
// Factor once, solve many times.
#pragma once
#include <Eigen/Core>
#include <Eigen/Sparse>
#include <memory>

namespace shapemap {

class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(SparseCholesky&&) noexcept;
  SparseCholesky& operator=(SparseCholesky&&) noexcept;
  // Analyzes the pattern and factors A (symmetric positive definite; lower or full).
  // Throws shapemap::Error if A is not positive definite.
  void compute(const Eigen::SparseMatrix<double>& A);
  // Refactors a matrix with the same pattern as the last compute().
  void factorize(const Eigen::SparseMatrix<double>& A);
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
  Eigen::MatrixXd solve(const Eigen::MatrixXd& B) const;
  int rows() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shapemap
