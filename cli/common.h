// Shared pieces of the command-line tool: global options, progress bar, atomic
// output folders, report.json, and error handling.
#pragma once
#include "shapemap/progress.h"
#include "shapemap/repair.h"
#include "shapemap/volume/tetrahedralize.h"
#include "shapemap/render/image.h"
#include "shapemap/render/report_viewer.h"
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace shapemap::cli {

// Largest --tets any command accepts (the tetrahedralizer's bound).
constexpr double kMaxTets = kMaxTetrahedralizeTets;

// Numeric option checks with short messages (CLI11's own print the whole double range):
// the value must parse completely, be finite and pass `test` (empty string = fine).
inline CLI::Validator number_check(std::function<std::string(double)> test, const std::string& name) {
  return CLI::Validator(
      [test](std::string& v) -> std::string {
        try {
          size_t used = 0;
          const double x = std::stod(v, &used);
          if (used != v.size()) return "not a number: " + v;
          if (!std::isfinite(x)) return "must be finite, got " + v;
          return test(x);
        } catch (const std::exception&) {
          return "not a number: " + v;
        }
      },
      name);
}
inline CLI::Validator non_negative() {
  return number_check([](double x) { return x >= 0 ? std::string() : "must be >= 0, got " + std::to_string(x); },
                      "NONNEGATIVE");
}
inline CLI::Validator positive() {
  return number_check([](double x) { return x > 0 ? std::string() : "must be > 0, got " + std::to_string(x); },
                      "POSITIVE");
}
// lo <= x <= hi: bounds that keep a run from asking for billions of threads, tets or frames.
inline CLI::Validator in_range(double lo, double hi) {
  return number_check(
      [lo, hi](double x) {
        if (x >= lo && x <= hi) return std::string();
        std::ostringstream m;
        m << "must be in [" << lo << ", " << hi << "], got " << x;
        return m.str();
      },
      "RANGE");
}

struct GlobalOptions {
  bool quiet = false;
  int threads = 0;          // 0 = all cores
  std::uint64_t seed = 1;
  bool strict = false;      // refuse defective input surfaces instead of repairing them
};

// Applies --threads to OpenMP.
void apply_threads(const GlobalOptions& g);

// Progress on stderr: a bar when stderr is a terminal (and not --quiet), else nothing.
ProgressCallback make_progress(const GlobalOptions& g);
// A one-line message on stderr unless --quiet.
void info(const GlobalOptions& g, const std::string& msg);

// The safe repairs of a surface the user gave (shapemap/repair.h, docs/methods.md): one note
// line per change on stderr (unless --quiet); --strict refuses instead (InputError: exit 2,
// one line naming `path` and the defects). The notes also go into report.json
// (inputs.repairs).
SurfaceRepair repair_input_surface(const TriMesh& mesh, const std::string& path, const GlobalOptions& g);

// inputs.repairs of report.json: the notes of both inputs' repairs, in order (empty: none).
inline nlohmann::json repairs_json(const SurfaceRepair& a, const SurfaceRepair& b) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto* r : {&a, &b})
    for (const std::string& n : r->notes) j.push_back(n);
  return j;
}

// repair_input_surface(), then require_genus0_surface() on the result: the surface a method
// that needs a closed genus-0 surface runs on. Appends the notes to `notes` if given.
TriMesh repaired_genus0_surface(const TriMesh& mesh, const std::string& path, const GlobalOptions& g,
                                std::vector<std::string>* notes = nullptr);

// tetrahedralize() of the surface read from `path`; prints a note (unless quiet) when CGAL's
// crease protection failed and the surface was meshed without it.
TetMesh tetrahedralize_input(const TriMesh& surface, const TetrahedralizeOptions& opt,
                             const ProgressCallback& progress, const std::string& path, bool quiet);

// A folder written under a temporary name and moved into place by commit(); if the
// object dies without commit() (an exception), the temporary folder is removed, so a
// failed run leaves no partial output.
class OutputDir {
 public:
  explicit OutputDir(const std::string& final_path);
  ~OutputDir();
  std::string path(const std::string& file) const;  // path inside the temporary folder
  const std::string& final_path() const { return final_; }
  void commit();

 private:
  std::string final_, tmp_;
  bool committed_ = false;
  int slot_ = -1;  // the interrupt handler's record of tmp_ (common.cpp)
};

// Wall-clock timer of named stages, for report.json.
class StageTimer {
 public:
  void start(const std::string& name);
  void stop();
  nlohmann::json json() const;
  double total() const;

 private:
  std::vector<std::pair<std::string, double>> stages_;
  std::string current_;
  std::chrono::steady_clock::time_point t0_;
};

// Common report.json fields: tool version, command line, seed, threads.
nlohmann::json report_header(const GlobalOptions& g, const std::string& command);
void write_json(const std::string& path, const nlohmann::json& j);

// A subcommand: registers itself on the app; `run` is called when it is selected.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

// The usual subcommand: `add_command(parent, args)` adds it with its options bound to one Args
// object, kept alive by the closure that calls `run(args, g)` when the subcommand is selected.
template <class Args, class AddCommand, class Run>
Command args_command(CLI::App& parent, GlobalOptions& g, AddCommand add_command, Run run) {
  Command c;
  auto a = std::make_shared<Args>();
  c.app = add_command(parent, *a);
  c.run = [a, &g, run]() -> int { return run(*a, g); };
  return c;
}

// The positional inputs A and B and the output folder of the commands that map A onto B.
inline void add_pair_options(CLI::App* app, std::string& A, std::string& B, std::string& out,
                             const std::string& about_A, const std::string& about_B) {
  app->add_option("A", A, about_A)->required();
  app->add_option("B", B, about_B)->required();
  app->add_option("-o,--output", out, "Output folder")->required();
}

// Each cli/cmd_*.cpp defines one of these.
Command register_surface_map(CLI::App& app, GlobalOptions& g);
Command register_volume_map(CLI::App& app, GlobalOptions& g);
Command register_ball(CLI::App& app, GlobalOptions& g);
Command register_register(CLI::App& app, GlobalOptions& g);
Command register_tetrahedralize(CLI::App& app, GlobalOptions& g);
Command register_generate(CLI::App& app, GlobalOptions& g);
Command register_evaluate(CLI::App& app, GlobalOptions& g);
Command register_render(CLI::App& app, GlobalOptions& g);
Command register_demo(CLI::App& app, GlobalOptions& g);
Command register_check(CLI::App& app, GlobalOptions& g);
Command register_batch(CLI::App& app, GlobalOptions& g);  // cmd_batch.cpp: execs python3 -m shapemap.batch
// `shapemap [global options] batch ARGS...`: sets ARGS aside for the batch (passed on to
// Python verbatim) and returns the arguments up to `batch`; other command lines as they are.
std::vector<std::string> split_batch_arguments(const std::vector<std::string>& args);

// Runs the tool in-process on an argument list (args[0] is the program name) with
// fresh options: parse, dispatch, map exceptions to exit codes. main() and the demo
// (which scripts the subcommands) both go through it.
int run(const std::vector<std::string>& args);

// Writes report.json and, beside it, report.html with the given pictures (embedded).
// Each figure (caption, picture) is also saved as a PNG named by `file` in OUT. With a
// viewer, report.html also has the interactive 3D views: report_data.js, report_viewer.js and
// three.min.js are written beside it (render/report_viewer.h).
struct ReportFigure {
  std::string file, caption;
  Image image;
};
void write_reports(const OutputDir& out, const nlohmann::json& report, const std::string& title,
                   const std::vector<ReportFigure>& figures = {}, const ViewerData* viewer = nullptr,
                   const GlobalOptions* g = nullptr);

}  // namespace shapemap::cli
