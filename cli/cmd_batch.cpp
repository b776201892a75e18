// shapemap batch SHAPE... -o DIR --method bim|elastic|volume|register [--pairs all|FILE.csv]
//                [--landmarks-dir D] [--workers N] [--threads-per-worker T] [--scheduler ADDR]
// Maps over whole shape collections on Dask. The batch itself is Python (the package
// `shapemap`, module shapemap.batch, python/shapemap/batch.py): this subcommand replaces the
// process with Debian's python3 running it, every argument after `batch` passed on as is,
// and PYTHONPATH pointing at the package built beside this binary (build/python), if there.
// The global --seed, --threads and --quiet, given before `batch`, are passed on too.
#include "common.h"
#include "shapemap/error.h"
#include <unistd.h>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>

namespace shapemap::cli {

namespace {

constexpr const char* kPython = "/usr/bin/python3";

// The arguments after `batch`, set aside by split_batch_arguments (CLI11 never sees them).
std::vector<std::string>& batch_arguments() {
  static std::vector<std::string> rest;
  return rest;
}

// build/python when this binary runs from the build tree (the installed package is on
// python3's own path).
std::string package_dir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const std::filesystem::path dir = exe.parent_path() / "python";
  return std::filesystem::exists(dir / "shapemap" / "__init__.py") ? dir.string() : std::string();
}

int exec_batch(const std::vector<std::string>& rest, const GlobalOptions& g) {
  std::vector<std::string> args = {kPython, "-m", "shapemap.batch"};
  if (g.quiet) args.push_back("--quiet");
  args.push_back("--seed");
  args.push_back(std::to_string(g.seed));
  if (g.threads > 0) {
    args.push_back("--threads-per-worker");
    args.push_back(std::to_string(g.threads));
  }
  args.insert(args.end(), rest.begin(), rest.end());
  if (const std::string dir = package_dir(); !dir.empty()) {
    const char* old = std::getenv("PYTHONPATH");
    const std::string path = old && *old ? dir + ":" + old : dir;
    setenv("PYTHONPATH", path.c_str(), 1);
  }
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(nullptr);
  execv(kPython, argv.data());
  throw Error(std::string("batch: cannot run ") + kPython + ": " + std::strerror(errno) +
              " (the batch needs Debian's python3 with python3-distributed: scripts/install-deps)");
}

}  // namespace

std::vector<std::string> split_batch_arguments(const std::vector<std::string>& args) {
  size_t i = 1;
  while (i < args.size()) {  // global options before the subcommand
    const std::string& a = args[i];
    if (a == "-q" || a == "--quiet" || a == "--strict") i += 1;
    else if (a == "--threads" || a == "--seed") i += 2;
    else if (a.rfind("--threads=", 0) == 0 || a.rfind("--seed=", 0) == 0) i += 1;
    else break;
  }
  if (i >= args.size() || args[i] != "batch") return args;
  batch_arguments().assign(args.begin() + i + 1, args.end());
  return std::vector<std::string>(args.begin(), args.begin() + i + 1);
}

Command register_batch(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("batch", "Maps over shape collections on Dask (Python; --help lists its options)");
  c.app->set_help_flag();  // --help goes to the Python program (split_batch_arguments)
  c.run = [&g]() -> int { return exec_batch(batch_arguments(), g); };
  return c;
}

}  // namespace shapemap::cli
