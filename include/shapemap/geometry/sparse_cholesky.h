// A thin owner of a CHOLMOD factorization (via Eigen's CholmodSupport). Factor once,
// solve many times. Supernodal by default; Simplicial is faster for solve-dominated use
// of a mid-size factor with the reference BLAS Debian installs (measured on the ball
// preconditioner, 4.7k + 2.5k unknowns, 500 CG iterations: solves 1.58 s -> 0.63 s).
#pragma once
#include <Eigen/Core>
#include <Eigen/Sparse>
#include <memory>

namespace shapemap {

class SparseCholesky {
 public:
  enum class Method { Supernodal, Simplicial };
  explicit SparseCholesky(Method method = Method::Supernodal);
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
  Method method_ = Method::Supernodal;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shapemap
