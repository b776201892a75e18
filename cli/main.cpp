// shapemap: dense correspondences between 3D shapes. Exit codes: 0 success,
// 2 bad input (one line on stderr naming the file and the problem), 1 internal failure.
#include "common.h"
#include <cstdlib>
#include <unistd.h>

namespace {
// OpenMP threads that spin while waiting at barriers (libgomp's default) steal the CPU
// from the threads that still have work whenever the machine is shared. Measured on a
// ~30k-tet volume map with another process busy on one of the two cores: one X-step
// objective evaluation took 64 ms with 2 spinning threads, 19 ms with
// OMP_WAIT_POLICY=passive, 19 ms with 1 thread (the ball's CG: 12.9 s vs 2.9 s). libgomp
// reads the policy once, when it is loaded, so it cannot be set from inside the process:
// unless the user chose a policy, the tool re-executes itself once with
// OMP_WAIT_POLICY=passive before doing anything. If that fails, it carries on.
void ensure_passive_omp_wait_policy(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY")) return;  // the user's choice, or already re-executed
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv("/proc/self/exe", argv);
}
}  // namespace

int main(int argc, char** argv) {
  ensure_passive_omp_wait_policy(argv);
  return shapemap::cli::run(std::vector<std::string>(argv, argv + argc));
}
