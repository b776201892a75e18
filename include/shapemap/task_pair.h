// Two independent tasks on two threads. Used for the volume map's two directions, whose
// supernodal Cholesky factorizations would otherwise run one after the other (the joint
// X-step's factors and solves, the landings), and whose other per-direction work has serial
// parts that then overlap (Hessian assemblies, P-steps, energy evaluations). Each task's own
// OpenMP loops run on one thread (libgomp's default of one active level).
#pragma once
#include "shapemap/geometry/sparse_cholesky.h"
#include <exception>
#include <omp.h>

namespace shapemap {

// OpenMP has two threads to give and we are not inside a parallel region already.
inline bool two_threads_available() { return omp_get_max_threads() > 1 && !omp_in_parallel(); }

// Whether two tasks of supernodal factorizations gain from run_pair(..., true): two threads,
// and a BLAS that takes two supernodal calls at once (else they are serialized inside).
inline bool factorizations_in_parallel() {
  return SparseCholesky::concurrent_factorizations() && two_threads_available();
}

// Runs first() and second(), at once on two threads when `parallel`, else in turn (first
// first). The tasks' own OpenMP loops then run on one thread each (nested regions are
// inactive). The first exception is rethrown after both have ended.
template <class First, class Second>
void run_pair(const First& first, const Second& second, bool parallel) {
  std::exception_ptr error[2];
#pragma omp parallel sections num_threads(2) if (parallel)
  {
#pragma omp section
    {
      try {
        first();
      } catch (...) {
        error[0] = std::current_exception();
      }
    }
#pragma omp section
    {
      try {
        second();
      } catch (...) {
        error[1] = std::current_exception();
      }
    }
  }
  for (const auto& e : error)
    if (e) std::rethrow_exception(e);
}

}  // namespace shapemap
