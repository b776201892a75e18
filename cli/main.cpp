// shapemap: dense correspondences between 3D shapes. Exit codes: 0 success,
// 2 bad input (one line on stderr naming the file and the problem), 1 internal failure.
#include "common.h"
#include "shapemap/openmp_policy.h"

int main(int argc, char** argv) {
  shapemap::use_passive_openmp_wait(argv);  // OpenMP threads sleep at barriers (openmp_policy.h)
  return shapemap::cli::run(std::vector<std::string>(argv, argv + argc));
}
