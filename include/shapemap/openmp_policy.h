// The OpenMP wait policy of the shapemap executables (the CLI and the bench tools).
#pragma once

namespace shapemap {

// OpenMP threads that spin while waiting at barriers (libgomp's default) take the CPU from
// the thread that still has work, both when the machine is shared and, on this project's
// 2-core virtual machines, when it is idle: on the 10k-vertex elastic bench with two
// threads, a spinning partner made the serial parts slower than on one thread (47.3 s
// against 44.1 s), a sleeping one gave 35.3 s (5 Dec 2026). On a ~30k-tet volume map with
// another process busy on one core, one X-step evaluation took 64 ms with 2 spinning
// threads, 19 ms with the passive policy. libgomp reads the policy once, when it is loaded,
// so it cannot be set from inside the process: unless the user chose a policy
// (OMP_WAIT_POLICY set), this re-executes the program once with OMP_WAIT_POLICY=passive.
// Call it first thing in main(); if the re-execution fails, the program carries on.
void use_passive_openmp_wait(char** argv);

}  // namespace shapemap
