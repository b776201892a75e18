// CHOLMOD supernodal LL^T (or simplicial LDL^T) behind shapemap::SparseCholesky.
//
// The factor is owned through the raw CHOLMOD API (the matrix views come from Eigen's
// CholmodSupport) so that solves can use their own cholmod_common: CHOLMOD only reads
// the factor during cholmod_solve, and a cholmod_common per call makes concurrent
// solve() calls on one factor thread-safe (HeatGeodesics::distances relies on it).
// compute()/factorize() must not run concurrently with anything else on the object.
//
// Supernodal factorizations and solves call BLAS. A serial OpenBLAS (Debian's
// libopenblas0-serial, "SINGLE_THREADED") is not safe to call from two threads at once (a
// BIM test with 8 threads gave a different map in 3 runs of 40; never with the reference
// BLAS): with it, those calls are serialized across all objects. A threaded OpenBLAS (the
// libopenblas0-pthread that scripts/install-deps installs) locks its buffers and is safe;
// its own threads are then held to one, so the parallelism is ours (two factorizations at
// once, `concurrent_factorizations()`) and results do not depend on its thread count.
// Other BLAS libraries (the reference BLAS) are safe. Simplicial calls use no BLAS.
// Symbolic analyses (METIS) are always serialized.
//
// CHOLMOD's supernodal code also opens OpenMP regions of its own, with a fixed team of 4
// threads (num_threads(CHOLMOD_OMP_NUM_THREADS), which omp_set_num_threads and --threads
// do not reach), to zero each supernode and to clear its maps: thousands of regions per
// factorization, each waking 3 sleeping threads (the CLI's passive wait policy) on a
// 2-core machine for work smaller than the wake-up. Measured on cat -> lion's volume map
// (29.8k + 28.4k tets) with one thread: 3.4 million context switches, 20 s of system time,
// 88.7 s; with those regions held to one thread, 170 and 2.8 s, 62.1 s. So while any
// supernodal call runs outside a parallel region, OpenMP's active levels are 0 (every region
// one thread; the setting is process-wide, so it is counted: the first call saves and sets
// it, the last restores it). Inside a parallel region nested regions are inactive already.
#include "shapemap/geometry/sparse_cholesky.h"
#include "shapemap/error.h"
#include <Eigen/CholmodSupport>
#include <dlfcn.h>
#include <mutex>
#include <optional>
#include <omp.h>
#include <string>

namespace shapemap {
namespace {
std::mutex& blas_mutex() {
  static std::mutex m;
  return m;
}

// The BLAS that CHOLMOD was loaded with, as OpenBLAS reports it (nullptr: not OpenBLAS, or
// not found).
void* openblas_symbol(const char* name) {
  for (const char* lib : {"libblas.so.3", "libopenblas.so.0"})  // CHOLMOD calls the first
    if (void* h = dlopen(lib, RTLD_NOW | RTLD_NOLOAD)) {
      void* f = dlsym(h, name);
      dlclose(h);  // only drops the reference RTLD_NOLOAD took
      if (f) return f;
    }
  return dlsym(RTLD_DEFAULT, name);
}

bool blas_is_thread_safe() {
  static const bool safe = [] {
    const auto get_parallel = reinterpret_cast<int (*)()>(openblas_symbol("openblas_get_parallel"));
    if (!get_parallel) return true;            // the reference BLAS, or another library
    if (get_parallel() == 0) return false;     // a serial OpenBLAS: unlocked buffers
    if (const auto set = reinterpret_cast<void (*)(int)>(openblas_symbol("openblas_set_num_threads"))) set(1);
    return true;
  }();
  return safe;
}

// OpenMP regions held to one thread while any supernodal call runs (the note at the top).
class SerialRegions {
 public:
  SerialRegions() {
    const std::lock_guard<std::mutex> g(mutex());
    if (count()++ == 0) {
      saved() = omp_get_max_active_levels();
      omp_set_max_active_levels(0);
    }
  }
  ~SerialRegions() {
    const std::lock_guard<std::mutex> g(mutex());
    if (--count() == 0) omp_set_max_active_levels(saved());
  }
  SerialRegions(const SerialRegions&) = delete;
  SerialRegions& operator=(const SerialRegions&) = delete;

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static int& count() {
    static int c = 0;
    return c;
  }
  static int& saved() {
    static int s = 0;
    return s;
  }
};

// A supernodal CHOLMOD call: the BLAS lock when the BLAS needs it (always for an analysis:
// METIS), and OpenMP regions held to one thread (the note at the top).
class SupernodalCall {
 public:
  SupernodalCall(bool supernodal, bool analysis) : lock_(blas_mutex(), std::defer_lock) {
    if (!supernodal) return;
    const bool safe = blas_is_thread_safe();  // first: holds a threaded OpenBLAS to one thread
    if (analysis || !safe) lock_.lock();
    if (!omp_in_parallel()) serial_.emplace();
  }

 private:
  std::unique_lock<std::mutex> lock_;
  std::optional<SerialRegions> serial_;
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
        const SupernodalCall call(common.supernodal != CHOLMOD_SIMPLICIAL, true);
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
      const SupernodalCall call(common.supernodal != CHOLMOD_SIMPLICIAL, false);
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
      const SupernodalCall call(factor->is_super, false);
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

bool SparseCholesky::concurrent_factorizations() { return blas_is_thread_safe(); }

int SparseCholesky::rows() const { return impl_ ? impl_->n : 0; }

}  // namespace shapemap
