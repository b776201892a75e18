// Re-execution under OMP_WAIT_POLICY=passive (openmp_policy.h).
#include "shapemap/openmp_policy.h"
#include <cstdlib>
#include <unistd.h>

namespace shapemap {

void use_passive_openmp_wait(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY")) return;  // the user's choice, or already re-executed
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  // A threaded OpenBLAS starts its own thread pool when it is loaded; SparseCholesky holds it
  // to one thread (our threads run the two factorizations at once), so the pool is not needed.
  if (!std::getenv("OPENBLAS_NUM_THREADS")) setenv("OPENBLAS_NUM_THREADS", "1", 1);
  execv("/proc/self/exe", argv);
}

}  // namespace shapemap
