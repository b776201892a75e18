// shapemap demo: the main job on built-in generated shapes. It scripts the tool's own
// subcommands in-process (exactly what a user would type), so the demo exercises the
// real command-line contract: generate a creature pair with ground truth -> BIM ->
// elastic refinement -> tetrahedralize -> symmetric volume map from the elastic maps -> ball
// parameterization -> registration through the ball -> symmetric volume map initialized by
// that registration; evaluates each map against the ground truth, prints a summary table
// and writes DIR/index.html: the summary, then each stage's interactive report (its 3D views
// and metrics) in one page. --index-only rewrites index.html from the folders already there.
#include "common.h"
#include "shapemap/render/report_html.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/timing.h"
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace fs = std::filesystem;

namespace shapemap::cli {

namespace {

struct Step {
  std::string name, folder, what;
  std::vector<std::string> args;
  double seconds = 0;
  int code = -1;
};

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  if (!in) return nlohmann::json();
  try {
    return nlohmann::json::parse(in);
  } catch (...) {
    return nlohmann::json();
  }
}

// First number found at any of the given JSON pointers.
std::string pick(const nlohmann::json& j, const std::vector<std::string>& pointers, const char* fmt = "%.4g") {
  for (auto& p : pointers) {
    try {
      const auto& v = j.at(nlohmann::json::json_pointer(p));
      if (v.is_number()) {
        char buf[64];
        std::snprintf(buf, sizeof buf, fmt, v.get<double>());
        return buf;
      }
    } catch (...) {
    }
  }
  return "-";
}

struct DemoArgs {
  std::string out = "demo-output";
  int vertices = 2500;
  int tets = 12000;  // per volume
  bool index_only = false;
};

// The demo's stages in order: each step is one command line of the tool.
std::vector<Step> demo_steps(const DemoArgs& a, const std::string& D) {
  const std::string P = D + "/pair";
  return {
      {"generate", "pair", "creature pair with ground truth (surfaces + volumes)",
       {"generate", "-o", P, "--shape", "pair", "--kind", "non-isometric", "--vertices", std::to_string(a.vertices),
        "--tets", "--tet-count", std::to_string(a.tets)}},
      {"BIM", "bim", "Blended Intrinsic Maps A<->B",
       {"surface-map", P + "/A.obj", P + "/B.obj", "-o", D + "/bim", "--method", "bim", "--symmetric"}},
      {"BIM eval", "bim", "geodesic error vs ground truth",
       {"evaluate", "surface", P + "/A.obj", P + "/B.obj", D + "/bim/map_AB.txt", "--truth", P + "/truth_AB.txt", "-o",
        D + "/bim/evaluation.json"}},
      {"elastic", "elastic", "elastic bijective refinement of BIM",
       {"surface-map", P + "/A.obj", P + "/B.obj", "-o", D + "/elastic", "--method", "elastic", "--symmetric"}},
      {"elastic eval", "elastic", "geodesic error vs ground truth",
       {"evaluate", "surface", P + "/A.obj", P + "/B.obj", D + "/elastic/map_AB.txt", "--truth",
        P + "/truth_AB.txt", "-o", D + "/elastic/evaluation.json"}},
      // The elastic step's maps (on the generated surfaces) start the volume map: the same
      // BIM + elastic chain as --init auto, which would compute it again on the boundaries.
      {"volume map", "volume", "symmetric volume map initialized by the elastic surface maps",
       {"volume-map", P + "/A.vtk", P + "/B.vtk", "-o", D + "/volume", "--init", "surface-map", "--surface-map",
        D + "/elastic/map_AB.txt", D + "/elastic/map_BA.txt", "--surface-map-meshes", P + "/A.obj", P + "/B.obj"}},
      {"volume eval", "volume", "volume map A->B vs the ground-truth deformation",
       {"evaluate", "volume", P + "/A.vtk", P + "/B.vtk", D + "/volume/map_AB.txt", "--map-ba",
        D + "/volume/map_BA.txt", "--truth", P + "/truth_vol_AB.txt", "-o", D + "/volume/evaluation.json"}},
      {"ball", "ball", "isovolumetric ball parameterization of A",
       {"ball", P + "/A.vtk", "-o", D + "/ball", "--split-chords"}},
      {"register", "register", "registration A->B through the ball",
       {"register", P + "/A.vtk", P + "/B.vtk", "-o", D + "/register", "--via", "ball"}},
      {"register eval", "register", "registration A->B vs the ground-truth deformation",
       {"evaluate", "volume", P + "/A.vtk", P + "/B.vtk", D + "/register/map_AB.txt", "--truth",
        P + "/truth_vol_AB.txt", "-o", D + "/register/evaluation.json"}},
      {"ball+volume", "volume_ball", "symmetric volume map initialized by the ball registration (both ways)",
       {"volume-map", P + "/A.vtk", P + "/B.vtk", "-o", D + "/volume_ball", "--init", "ball"}},
      {"ball+volume eval", "volume_ball", "ball-initialized volume map A->B vs the ground-truth deformation",
       {"evaluate", "volume", P + "/A.vtk", P + "/B.vtk", D + "/volume_ball/map_AB.txt", "--map-ba",
        D + "/volume_ball/map_BA.txt", "--truth", P + "/truth_vol_AB.txt", "-o",
        D + "/volume_ball/evaluation.json"}},
  };
}

struct Row {
  std::string method, time, metrics;
};

// One demo run: its steps, then the summary rows read back from the steps' reports.
class Demo {
 public:
  Demo(const DemoArgs& a, const GlobalOptions& g) : a_(a), g_(g), D_(a.out), steps_(demo_steps(a, a.out)) {}

  // Runs every step in order (with --index-only, only checks which outputs exist); returns
  // the number of failed steps.
  int run_steps() {
    std::vector<std::string> common = {"shapemap", "--seed", std::to_string(g_.seed)};
    if (g_.threads > 0) common.insert(common.end(), {"--threads", std::to_string(g_.threads)});
    if (g_.quiet) common.push_back("--quiet");
    int failures = 0;
    for (auto& s : steps_) {
      if (a_.index_only) {
        // Not run now: the step counts as done when its output is there.
        const bool eval = s.name.find("eval") != std::string::npos;
        s.code = fs::exists(D_ + "/" + s.folder + (eval ? "/evaluation.json" : "/report.json")) ? 0 : -1;
        continue;
      }
      std::vector<std::string> args = common;
      args.insert(args.end(), s.args.begin(), s.args.end());
      if (!g_.quiet) std::cerr << "== " << s.name << ": " << s.what << "\n";
      const auto t0 = Clock::now();
      s.code = run(args);
      s.seconds = seconds_since(t0);
      if (s.code != 0) {
        ++failures;
        std::cerr << "demo: step '" << s.name << "' failed with exit code " << s.code << "\n";
      }
    }
    return failures;
  }

  // The summary table's rows: time and key metrics per method.
  void summarize() {
    rows_.push_back({"generate", time_of("generate"), ""});
    for (std::string m : {"bim", "elastic"}) {
      nlohmann::json e = ev(m);
      rows_.push_back({m == "bim" ? "BIM" : "elastic", time_of(m == "bim" ? "BIM" : "elastic"),
                       "geodesic error mean " + pick(e, {"/geodesic_error/mean", "/mean"}) + ", within 0.1: " +
                           pick(e, {"/geodesic_error/fraction_within_0.1", "/fraction_within_0.1"})});
    }
    volume_row("volume map", "volume");
    nlohmann::json r = rep("ball");
    rows_.push_back({"ball", time_of("ball"),
                     "mean D_V " + pick(r, {"/metrics/D_V/mean"}) + ", folded " + pick(r, {"/metrics/folded_tets"}) +
                         ", E_I " + pick(r, {"/optimization/E_I_after_vsem"}) + " -> " +
                         pick(r, {"/optimization/E_I_final"})});
    volume_row("register", "register");
    volume_row("ball+volume", "volume_ball");
  }

  // The table on stdout and in summary.txt; index.html: the summary, then every stage's
  // report.html (3D views and metrics) inline. Each report keeps its own folder and
  // scripts; an iframe shows it as it is, from file://.
  void write_outputs() {
    std::ostringstream table;
    table << "\n" << std::left;
    char line[512];
    std::snprintf(line, sizeof line, "%-12s %-14s %s\n", "method", "time", "key metrics");
    table << line;
    for (auto& r : rows_) {
      std::snprintf(line, sizeof line, "%-12s %-14s %s\n", r.method.c_str(), r.time.c_str(), r.metrics.c_str());
      table << line;
    }
    std::cout << table.str();
    std::ostringstream html;
    html << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>shapemap demo</title><style>"
         << "body{font-family:sans-serif;margin:1em 2em}table{border-collapse:collapse}"
         << "th,td{border:1px solid #ccc;padding:2px 8px;text-align:left;font-size:14px}th{background:#f3f3f3}"
         << "iframe{width:100%;height:820px;border:1px solid #bbb}section{margin:1.5em 0}</style></head><body>"
         << "<h1>shapemap demo</h1><table id=\"summary\"><tr><th>method</th><th>time</th><th>key metrics</th></tr>";
    for (auto& r : rows_)
      html << "<tr><td>" << html_escape(r.method) << "</td><td>" << html_escape(r.time) << "</td><td>"
           << html_escape(r.metrics) << "</td></tr>";
    html << "</table>";
    for (auto& s : steps_) {
      if (s.name.find("eval") != std::string::npos || !fs::exists(D_ + "/" + s.folder + "/report.html")) continue;
      const std::string page = s.folder + "/report.html";
      html << "<section><h2>" << html_escape(s.name) << "</h2><p>" << html_escape(s.what) << " ("
           << html_escape(time_of(s.name)) << "; <a href=\"" << page << "\">open alone</a>)</p><iframe src=\""
           << page << "\" title=\"" << html_escape(s.name) << "\"></iframe></section>";
    }
    html << "</body></html>\n";
    write_text_atomic(D_ + "/index.html", html.str());
    write_text_atomic(D_ + "/summary.txt", table.str());
  }

 private:
  nlohmann::json rep(const std::string& f) const { return read_json(D_ + "/" + f + "/report.json"); }
  nlohmann::json ev(const std::string& f) const { return read_json(D_ + "/" + f + "/evaluation.json"); }

  std::string time_of(const std::string& name) const {
    for (auto& s : steps_)
      if (s.name == name) {
        if (a_.index_only) {
          // The command's own total (report.json) when the step was not run now.
          const std::string t = pick(rep(s.folder), {"/timings/total"}, "%.1f");
          return s.code == 0 ? t + (t == "-" ? "" : " s") : std::string("not run");
        }
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.1f s%s", s.seconds, s.code == 0 ? "" : " FAILED");
        return std::string(buf);
      }
    return std::string("-");
  }

  // Volume maps: inverted tets, distortion and distance to the ground truth (Table 3 metrics).
  void volume_row(const std::string& name, const std::string& folder) {
    nlohmann::json e = ev(folder);
    rows_.push_back({name, time_of(name),
                     "n_inv " + pick(e, {"/metrics/n_inv"}) + ", mean|detJ| " + pick(e, {"/metrics/det_J_mean"}) +
                         ", error vs truth " + pick(e, {"/metrics/truth_error_mean"}) + " of diag"});
  }

  const DemoArgs& a_;
  const GlobalOptions& g_;
  const std::string D_;
  std::vector<Step> steps_;
  std::vector<Row> rows_;
};

int run_demo(const DemoArgs& a, const GlobalOptions& g) {
  fs::create_directories(a.out);
  Demo demo(a, g);
  const int failures = demo.run_steps();
  demo.summarize();
  demo.write_outputs();
  if (!g.quiet) std::cerr << "demo: outputs in " << a.out << "/ (open " << a.out << "/index.html)\n";
  return failures == 0 ? 0 : 1;
}

CLI::App* add_demo_command(CLI::App& parent, DemoArgs& a) {
  CLI::App* app =
      parent.add_subcommand("demo", "The main job on built-in generated shapes (writes maps, pictures, reports)");
  app->add_option("-o,--output", a.out, "Output folder")->capture_default_str();
  app->add_option("--vertices", a.vertices, "Vertices per generated surface")->check(CLI::Range(500, 50000));
  app->add_option("--tets", a.tets, "Tets per generated volume")->check(CLI::Range(1000, 500000));
  app->add_flag("--index-only", a.index_only,
                "Run nothing: rewrite OUT/index.html (and summary.txt) from the stage folders already in OUT");
  return app;
}

}  // namespace

Command register_demo(CLI::App& app, GlobalOptions& g) {
  return args_command<DemoArgs>(app, g, add_demo_command, run_demo);
}

}  // namespace shapemap::cli
