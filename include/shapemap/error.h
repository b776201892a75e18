// Errors thrown by the library. Library code never prints and never exits; the CLI
// maps InputError to exit code 2 and Error to exit code 1.
#pragma once
#include <stdexcept>
#include <string>

namespace shapemap {

// Something is wrong with what the user gave us (a file, a mesh, an option).
// The message is one line that names the file (when there is one) and the problem.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// An internal failure (a solver that did not factor, an invariant that broke).
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace shapemap
