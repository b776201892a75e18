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
  // Fill-reducing ordering: CHOLMOD's default (AMD, with METIS only when AMD fills badly)
  // or METIS nested dissection, which fills less on tet-mesh Laplacians (measured on the
  // 4.6k interior block of spot.obj's ball map: 4.8e5 -> 4.2e5 factor entries, 1.0e8 ->
  // 7.2e7 flops) but costs more than it saves on small surface Laplacians.
  enum class Ordering { Default, NestedDissection };
  explicit SparseCholesky(Method method = Method::Supernodal, Ordering ordering = Ordering::Default);
  ~SparseCholesky();
  SparseCholesky(SparseCholesky&&) noexcept;
  SparseCholesky& operator=(SparseCholesky&&) noexcept;
  // Analyzes the pattern and factors A (symmetric positive definite; lower or full).
  // Throws shapemap::Error if A is not positive definite (the analysis is kept: a shifted
  // matrix with the same pattern can then be factorize()d).
  void compute(const Eigen::SparseMatrix<double>& A);
  // Refactors a matrix with the same pattern as the last compute() or analyze().
  void factorize(const Eigen::SparseMatrix<double>& A);
  // Symbolic analysis of A's pattern only (the values are not read). The fill-reducing
  // ordering (METIS) is not safe to run on two threads at once: analyze before going
  // parallel, then factorize() concurrently on separate objects.
  void analyze(const Eigen::SparseMatrix<double>& A);
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
  Eigen::MatrixXd solve(const Eigen::MatrixXd& B) const;
  int rows() const;
  // Whether supernodal factorizations and solves of separate objects may run at once
  // (the BLAS is safe from two threads: not a serial OpenBLAS). When false they are
  // serialized inside, so running them on two threads is still correct, only not faster.
  static bool concurrent_factorizations();

 private:
  struct Impl;
  Method method_ = Method::Supernodal;
  Ordering ordering_ = Ordering::Default;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shapemap
