// Runs the shapemap binary quietly with an argument string; returns its exit code
// (-1 if it did not exit normally). Shared by the CLI tests.
#pragma once
#include <sys/wait.h>
#include <unistd.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

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

// A fresh folder under the system temp dir, removed with everything in it at scope exit.
struct TempDir {
  std::filesystem::path dir;
  explicit TempDir(const std::string& tag) {
    dir = std::filesystem::temp_directory_path() / ("shapemap_" + tag + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  ~TempDir() { std::filesystem::remove_all(dir); }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string p(const std::string& f) const { return (dir / f).string(); }
};

// The whole file as bytes ("" if it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}
}  // namespace shapemap::testing
