// Runs the shapemap binary quietly with an argument string; returns its exit code
// (-1 if it did not exit normally). Shared by the CLI tests.
#pragma once
#include <cstdlib>
#include <string>
#include <sys/wait.h>

namespace shapemap::testing {
inline int run_quiet(const std::string& args) {
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " -q " + args + " > /dev/null 2>&1";
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
// The same, with stderr written to `err_file` (for checking the one-line error contract).
inline int run_stderr(const std::string& args, const std::string& err_file) {
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " --quiet --threads 1 " + args + " > /dev/null 2> " + err_file;
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
}  // namespace shapemap::testing
