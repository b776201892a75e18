// Re-execution under OMP_WAIT_POLICY=passive (openmp_policy.h).
#include "shapemap/openmp_policy.h"
#include <cstdlib>
#include <unistd.h>

namespace shapemap {

void use_passive_openmp_wait(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY")) return;  // the user's choice, or already re-executed
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv("/proc/self/exe", argv);
}

}  // namespace shapemap
