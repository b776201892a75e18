// CHOLMOD supernodal LL^T (or simplicial LDL^T) behind shapemap::SparseCholesky.
//
// The factor is owned through the raw CHOLMOD API (the matrix views come from Eigen's
// CholmodSupport) so that solves can use their own cholmod_common: CHOLMOD only reads
// the factor during cholmod_solve, and a cholmod_common per call makes concurrent
// solve() calls on one factor thread-safe (HeatGeodesics::distances relies on it).
// compute()/factorize() must not run concurrently with anything else on the object.
// Supernodal factorizations and solves call BLAS, and the serial OpenBLAS that
// scripts/install-deps installs is not safe to call from two threads at once (a BIM test
// with 8 threads gave a different map in 3 runs of 40; never with the reference BLAS):
// those calls are serialized across all objects. Simplicial ones use no BLAS and run
// concurrently.
//
// CHOLMOD's supernodal code also opens OpenMP regions of its own, with a fixed team of 4
// threads (num_threads(CHOLMOD_OMP_NUM_THREADS), which omp_set_num_threads and --threads
// do not reach), to zero each supernode and to clear its maps: thousands of regions per
// factorization, each waking 3 sleeping threads (the CLI's passive wait policy) on a
// 2-core machine for work smaller than the wake-up. Measured on cat -> lion's volume map
// (29.8k + 28.4k tets) with one thread: 3.4 million context switches, 20 s of system time,
// 88.7 s; with those regions held to one thread, 170 and 2.8 s, 62.1 s. So these calls run
// with OpenMP's active levels at 0 (every region one thread), under the BLAS lock (the
// setting is process-wide, and the lock keeps the saves and restores from interleaving).
#include "shapemap/geometry/sparse_cholesky.h"
#include "shapemap/error.h"
#include <Eigen/CholmodSupport>
#include <mutex>
#include <omp.h>
#include <string>

namespace shapemap {
namespace {
std::mutex& blas_mutex() {
  static std::mutex m;
  return m;
}

// Holds the BLAS lock (supernodal calls only) and, with it, OpenMP regions to one thread
// for its lifetime (the note at the top).
class SupernodalCall {
 public:
  explicit SupernodalCall(bool supernodal) : lock_(blas_mutex(), std::defer_lock) {
    if (!supernodal) return;
    lock_.lock();
    if (omp_in_parallel()) return;  // nested regions are inactive already
    levels_ = omp_get_max_active_levels();
    omp_set_max_active_levels(0);
  }
  ~SupernodalCall() {
    if (levels_ >= 0) omp_set_max_active_levels(levels_);
  }
  SupernodalCall(const SupernodalCall&) = delete;
  SupernodalCall& operator=(const SupernodalCall&) = delete;

 private:
  std::unique_lock<std::mutex> lock_;
  int levels_ = -1;
};
}  // namespace

struct SparseCholesky::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  int n = 0;
  bool numeric = false;  // the factor holds a successful numeric factorization
  Impl(SparseCholesky::Method method, SparseCholesky::Ordering ordering) {
    cholmod_start(&common);
    common.supernodal = method == SparseCholesky::Method::Simplicial ? CHOLMOD_SIMPLICIAL : CHOLMOD_SUPERNODAL;
    if (ordering == SparseCholesky::Ordering::NestedDissection) {
      common.nmethods = 1;
      common.method[0].ordering = CHOLMOD_METIS;
    }
    common.final_asis = 1;
    common.print = 0;
    common.error_handler = nullptr;  // errors are reported by status codes; we throw
  }
  ~Impl() {
    if (factor) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
  // Lower-triangle view (stype = -1) of a compressed copy if needed.
  void run_factorize(const Eigen::SparseMatrix<double>& A, bool analyze, bool numeric_too = true) {
    if (A.rows() != A.cols())
      throw Error("SparseCholesky: matrix is not square (" + std::to_string(A.rows()) + "x" +
                  std::to_string(A.cols()) + ")");
    Eigen::SparseMatrix<double> copy;
    const Eigen::SparseMatrix<double>* M = &A;
    if (!A.isCompressed()) {
      copy = A;
      copy.makeCompressed();
      M = &copy;
    }
    cholmod_sparse view = Eigen::viewAsCholmod(M->selfadjointView<Eigen::Lower>());
    if (analyze || !factor || int(A.rows()) != n) {
      if (factor) cholmod_free_factor(&factor, &common);
      n = int(A.rows());
      {
        const SupernodalCall call(common.supernodal != CHOLMOD_SIMPLICIAL);
        factor = cholmod_analyze(&view, &common);
      }
      if (!factor || common.status < CHOLMOD_OK)
        throw Error("SparseCholesky: symbolic analysis failed (CHOLMOD status " +
                    std::to_string(common.status) + ")");
      numeric = false;
    }
    if (!numeric_too) return;
    numeric = false;
    {
      const SupernodalCall call(common.supernodal != CHOLMOD_SIMPLICIAL);
      cholmod_factorize(&view, factor, &common);
    }
    if (common.status == CHOLMOD_NOT_POSDEF || factor->minor < factor->n) {
      // The analysis stays (same pattern, e.g. a shifted matrix, can be factorized next).
      throw Error("SparseCholesky: matrix is not positive definite (failed at column " +
                  std::to_string(factor->minor) + ")");
    }
    if (common.status < CHOLMOD_OK)
      throw Error("SparseCholesky: numeric factorization failed (CHOLMOD status " +
                  std::to_string(common.status) + ")");
    numeric = true;
  }
  // X = A^{-1} B for a column-major n×k block.
  void run_solve(const double* B, int k, double* X) const {
    if (!factor || !numeric) throw Error("SparseCholesky: solve() without a successful factorization");
    cholmod_common c;
    cholmod_start(&c);
    c.print = 0;
    c.error_handler = nullptr;
    cholmod_dense b;
    b.nrow = size_t(n);
    b.ncol = size_t(k);
    b.nzmax = size_t(n) * size_t(k);
    b.d = size_t(n);
    b.x = const_cast<double*>(B);  // read only
    b.z = nullptr;
    b.xtype = CHOLMOD_REAL;
    b.dtype = CHOLMOD_DOUBLE;
    cholmod_dense* x = nullptr;
    {
      const SupernodalCall call(factor->is_super);
      x = cholmod_solve(CHOLMOD_A, factor, &b, &c);
    }
    if (!x) {
      const int status = c.status;
      cholmod_finish(&c);
      throw Error("SparseCholesky: solve failed (CHOLMOD status " + std::to_string(status) + ")");
    }
    std::copy(static_cast<const double*>(x->x), static_cast<const double*>(x->x) + size_t(n) * k, X);
    cholmod_free_dense(&x, &c);
    cholmod_finish(&c);
  }
};

SparseCholesky::SparseCholesky(Method method, Ordering ordering)
    : method_(method), ordering_(ordering), impl_(std::make_unique<Impl>(method, ordering)) {}
SparseCholesky::~SparseCholesky() = default;
SparseCholesky::SparseCholesky(SparseCholesky&&) noexcept = default;
SparseCholesky& SparseCholesky::operator=(SparseCholesky&&) noexcept = default;

void SparseCholesky::compute(const Eigen::SparseMatrix<double>& A) {
  if (!impl_) impl_ = std::make_unique<Impl>(method_, ordering_);
  impl_->run_factorize(A, true);
}

void SparseCholesky::analyze(const Eigen::SparseMatrix<double>& A) {
  if (!impl_) impl_ = std::make_unique<Impl>(method_, ordering_);
  impl_->run_factorize(A, true, false);
}

void SparseCholesky::factorize(const Eigen::SparseMatrix<double>& A) {
  if (!impl_) impl_ = std::make_unique<Impl>(method_, ordering_);
  impl_->run_factorize(A, false);
}

Eigen::VectorXd SparseCholesky::solve(const Eigen::VectorXd& b) const {
  if (!impl_ || !impl_->factor) throw Error("SparseCholesky: solve() before compute()");
  if (b.size() != impl_->n)
    throw Error("SparseCholesky: right-hand side has " + std::to_string(b.size()) +
                " rows, expected " + std::to_string(impl_->n));
  Eigen::VectorXd x(b.size());
  impl_->run_solve(b.data(), 1, x.data());
  return x;
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& B) const {
  if (!impl_ || !impl_->factor) throw Error("SparseCholesky: solve() before compute()");
  if (B.rows() != impl_->n)
    throw Error("SparseCholesky: right-hand side has " + std::to_string(B.rows()) +
                " rows, expected " + std::to_string(impl_->n));
  Eigen::MatrixXd X(B.rows(), B.cols());
  if (B.cols() > 0) impl_->run_solve(B.data(), int(B.cols()), X.data());
  return X;
}

int SparseCholesky::rows() const { return impl_ ? impl_->n : 0; }

}  // namespace shapemap
