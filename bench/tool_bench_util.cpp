// tool_bench_util: the parts of bench/run that need to read meshes or JSON (bench/run
// itself is plain bash and must not depend on python or jq).
//
//   tool_bench_util landmarks PAIR_DIR K LA LB
//       K landmarks for a generated pair (`shapemap generate --shape pair`): farthest-point
//       samples of PAIR_DIR/A.obj (first: the vertex farthest from the centroid) written to
//       LA as "x y z" lines, and their ground-truth images on B (PAIR_DIR/truth_AB.txt)
//       written to LB. "x y z" landmarks are snapped by the reader to the nearest
//       (boundary) vertex, so the same files serve A.obj/B.obj and A.vtk/B.vtk.
//
//   tool_bench_util collect STEPS.jsonl -o RESULTS.json [--meta KEY=VALUE]...
//       Turns the per-step records bench/run appends to STEPS.jsonl (one JSON object per
//       line: method, size_label, seed, kind, pair, report, evaluation, exit_code,
//       seconds, peak_rss_mb, x_measure, ...) into RESULTS.json: "runs" (each with the
//       pair's sizes from pair.json, a status and the quality metrics picked from the
//       method's report.json and evaluation JSON) and "summary" (per method, kind and
//       size: run count, successes, mean seconds and mean of every metric over the
//       successful runs). Prints a table of the runs on stdout.
//
//   tool_bench_util get FILE.json POINTER...
//       The values at the JSON pointers (e.g. /metrics/D_V/mean), tab-separated on one
//       line ("-" for a missing one); numbers with 4 significant digits. For bench scripts.
#include "shapemap/openmp_policy.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include <nlohmann/json.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using nlohmann::json;

namespace {

json read_json_file(const std::string& path) {
  if (path.empty()) return json();
  std::ifstream f(path);
  if (!f) return json();
  try {
    return json::parse(f);
  } catch (...) {
    return json();
  }
}

// ---- landmarks ------------------------------------------------------------------------

int cmd_landmarks(const std::vector<std::string>& a) {
  if (a.size() != 4) {
    std::cerr << "usage: tool_bench_util landmarks PAIR_DIR K LA LB\n";
    return 2;
  }
  const std::string dir = a[0];
  const int K = std::stoi(a[1]);
  shapemap::TriMesh A = shapemap::read_surface(dir + "/A.obj");
  shapemap::TriMesh B = shapemap::read_surface(dir + "/B.obj");
  shapemap::BarycentricMap t = shapemap::read_map(dir + "/truth_AB.txt");
  shapemap::validate_map(t, A.num_vertices(), B.num_faces(), 3, dir + "/truth_AB.txt");
  const Eigen::MatrixXd TB = shapemap::map_positions(t, B.V, B.F);
  const int n = A.num_vertices();
  if (K < 1 || K > n) {
    std::cerr << "tool_bench_util: K must be in [1, " << n << "]\n";
    return 2;
  }
  const Eigen::RowVector3d c = A.V.colwise().mean();
  int first = 0;
  (A.V.rowwise() - c).rowwise().squaredNorm().maxCoeff(&first);
  std::vector<int> pick = {first};
  Eigen::VectorXd d = (A.V.rowwise() - A.V.row(first)).rowwise().squaredNorm();
  while (int(pick.size()) < K) {
    int next = 0;
    d.maxCoeff(&next);
    pick.push_back(next);
    d = d.cwiseMin((A.V.rowwise() - A.V.row(next)).rowwise().squaredNorm());
  }
  std::ostringstream la, lb;
  la.precision(17);
  lb.precision(17);
  la << "# farthest-point landmarks on " << dir << "/A.obj (vertices";
  for (int i : pick) la << " " << i;
  la << ")\n";
  lb << "# ground-truth images (truth_AB.txt) of the landmarks of A on " << dir << "/B.obj\n";
  for (int i : pick) {
    la << A.V(i, 0) << " " << A.V(i, 1) << " " << A.V(i, 2) << "\n";
    lb << TB(i, 0) << " " << TB(i, 1) << " " << TB(i, 2) << "\n";
  }
  shapemap::write_text_atomic(a[2], la.str());
  shapemap::write_text_atomic(a[3], lb.str());
  return 0;
}

// ---- collect --------------------------------------------------------------------------

struct Pick {
  const char* source;   // "report" or "evaluation"
  const char* pointer;  // JSON pointer
  const char* name;     // metric name in results.json
};

// The quality metrics of each method (first match of the method name's prefix).
const std::vector<std::pair<std::string, std::vector<Pick>>>& metric_table() {
  static const std::vector<std::pair<std::string, std::vector<Pick>>> t = {
      {"bim",
       {{"evaluation", "/geodesic_error/mean", "geodesic_error_mean"},
        {"evaluation", "/geodesic_error/max", "geodesic_error_max"},
        {"evaluation", "/geodesic_error/fraction_within_0.1", "geodesic_within_0.1"},
        {"evaluation", "/integrated_confidence", "integrated_confidence"},
        {"report", "/bim/AB/num_candidates", "num_candidates"},
        {"report", "/bim/AB/selected_maps", "num_blended_maps"}}},
      {"elastic",
       {{"evaluation", "/geodesic_error/mean", "geodesic_error_mean"},
        {"evaluation", "/geodesic_error/max", "geodesic_error_max"},
        {"evaluation", "/geodesic_error/fraction_within_0.1", "geodesic_within_0.1"},
        {"evaluation", "/integrated_confidence", "integrated_confidence"},
        {"report", "/elastic/outer_iterations", "outer_iterations"},
        {"report", "/elastic/converged", "converged"},
        {"report", "/elastic/time_per_iteration", "seconds_per_iteration"},
        {"report", "/metrics/initial/AB/conformal_distortion_mean", "conformal_distortion_initial"},
        {"report", "/metrics/final/AB/conformal_distortion_mean", "conformal_distortion_mean"},
        {"report", "/metrics/final/AB/area_distortion_mean_abs", "area_distortion_mean_abs"},
        {"report", "/metrics/final/AB/flipped_triangles", "flipped_triangles"},
        {"report", "/metrics/final/AB/reversibility", "reversibility"}}},
      {"volume-map",
       {{"evaluation", "/metrics/truth_error_mean", "truth_error_mean"},
        {"evaluation", "/metrics/truth_error_max", "truth_error_max"},
        {"report", "/metrics/AB/n_inv", "n_inv_AB"},
        {"report", "/metrics/BA/n_inv", "n_inv_BA"},
        {"report", "/metrics/AB/d_avg_hat", "d_avg_hat"},
        {"report", "/metrics/AB/d_max_hat", "d_max_hat"},
        {"report", "/metrics/AB/det_J_mean", "det_J_mean"},
        {"report", "/metrics/AB/det_J_sd", "det_J_sd"},
        {"report", "/metrics/AB/E_R", "E_R"},
        {"report", "/energy/outer_iterations", "outer_iterations"}}},
      {"ball",
       {{"report", "/metrics/D_V/mean", "D_V_mean"},
        {"report", "/metrics/D_V/sd", "D_V_sd"},
        {"report", "/metrics/D_V/max", "D_V_max"},
        {"report", "/metrics/E_I", "E_I"},
        {"report", "/metrics/folded_tets", "folded_tets"},
        {"report", "/metrics/boundary_sphere_error", "boundary_sphere_error"},
        {"report", "/optimization/iterations", "iterations"},
        {"report", "/optimization/converged", "converged"},
        {"evaluation", "/metrics/D_V/mean", "evaluated_D_V_mean"},
        {"evaluation", "/metrics/folded_tets", "evaluated_folded_tets"}}},
      {"register",
       {{"evaluation", "/metrics/truth_error_mean", "truth_error_mean"},
        {"evaluation", "/metrics/truth_error_max", "truth_error_max"},
        {"report", "/d_phi", "d_phi"},
        {"report", "/d_phi_relative_to_bbox_diagonal", "d_phi_relative"},
        {"report", "/metrics/n_inv", "n_inv"},
        {"report", "/metrics/d_avg_hat", "d_avg_hat"},
        {"report", "/located_AB/interior_outside_ball_mesh", "interior_outside_ball_mesh"}}},
  };
  return t;
}

// Metrics shown in the printed table, per method prefix.
std::vector<std::string> key_metrics(const std::string& method) {
  if (method.rfind("bim", 0) == 0 || method.rfind("elastic", 0) == 0)
    return {"geodesic_error_mean", "geodesic_within_0.1"};
  if (method.rfind("volume-map", 0) == 0) return {"truth_error_mean", "n_inv_AB", "d_avg_hat"};
  if (method.rfind("ball", 0) == 0) return {"D_V_mean", "folded_tets"};
  if (method.rfind("register", 0) == 0) return {"truth_error_mean", "n_inv"};
  return {};
}

json metrics_of(const std::string& method, const json& report, const json& evaluation) {
  json m = json::object();
  for (auto& [prefix, picks] : metric_table()) {
    if (method.rfind(prefix, 0) != 0) continue;
    for (auto& p : picks) {
      const json& src = std::string(p.source) == "report" ? report : evaluation;
      if (!src.is_object()) continue;
      try {
        const json& v = src.at(json::json_pointer(p.pointer));
        if (v.is_array())
          m[p.name] = v.size();  // e.g. number of selected maps
        else if (v.is_number() || v.is_boolean())
          m[p.name] = v;
      } catch (...) {
      }
    }
    break;
  }
  return m;
}

std::string fmt(const json& v) {
  if (v.is_null()) return "-";
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number()) {
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", v.get<double>());
    return b;
  }
  return v.is_string() ? v.get<std::string>() : v.dump();
}

int cmd_collect(const std::vector<std::string>& a) {
  std::string steps, out;
  json meta = json::object();
  for (size_t i = 0; i < a.size(); ++i) {
    if ((a[i] == "-o" || a[i] == "--output") && i + 1 < a.size()) {
      out = a[++i];
    } else if (a[i] == "--meta" && i + 1 < a.size()) {
      const std::string kv = a[++i];
      const size_t eq = kv.find('=');
      if (eq == std::string::npos) continue;
      // KEY may be a path a/b (nested objects).
      const std::string v = kv.substr(eq + 1);
      const json::json_pointer k("/" + kv.substr(0, eq));
      // Numbers and booleans as such, everything else as a string.
      try {
        size_t used = 0;
        const double d = std::stod(v, &used);
        if (used == v.size()) {
          if (v.find_first_of(".eE") == std::string::npos)
            meta[k] = std::stoll(v);
          else
            meta[k] = d;
          continue;
        }
      } catch (...) {
      }
      if (v == "true" || v == "false")
        meta[k] = v == "true";
      else
        meta[k] = v;
    } else if (steps.empty()) {
      steps = a[i];
    } else {
      std::cerr << "usage: tool_bench_util collect STEPS.jsonl -o RESULTS.json [--meta KEY=VALUE]...\n";
      return 2;
    }
  }
  if (steps.empty() || out.empty()) {
    std::cerr << "usage: tool_bench_util collect STEPS.jsonl -o RESULTS.json [--meta KEY=VALUE]...\n";
    return 2;
  }
  std::ifstream f(steps);
  if (!f) {
    std::cerr << "tool_bench_util: error: " << steps << ": cannot open\n";
    return 2;
  }
  json results = meta;
  results["schema"] = "shapemap-bench 1";
  json runs = json::array();
  std::string line;
  int lineno = 0;
  std::map<std::string, json> pairs;  // pair.json per pair folder
  while (std::getline(f, line)) {
    ++lineno;
    if (line.empty()) continue;
    json s;
    try {
      s = json::parse(line);
    } catch (const std::exception& e) {
      std::cerr << "tool_bench_util: warning: " << steps << ":" << lineno << ": " << e.what() << "\n";
      continue;
    }
    json r = json::object();
    const std::string method = s.value("method", std::string("?"));
    r["method"] = method;
    for (const char* k : {"size_label", "kind", "seed"})
      if (s.contains(k)) r[k] = s[k];
    const std::string pair = s.value("pair", std::string());
    if (!pairs.count(pair)) pairs[pair] = read_json_file(pair + "/pair.json");
    const json& pj = pairs[pair];
    json size = json::object();
    if (pj.is_object()) {
      auto num = [&](const char* p) -> json {
        try {
          return pj.at(json::json_pointer(p));
        } catch (...) {
          return json();
        }
      };
      size["vertices"] = num("/A/vertices");
      size["faces"] = num("/A/faces");
      size["tets"] = num("/A/tets");
      size["tet_vertices"] = num("/A/tet_vertices");
      size["B_vertices"] = num("/B/vertices");
      size["B_tets"] = num("/B/tets");
      for (auto it = size.begin(); it != size.end();)
        it = it->is_null() ? size.erase(it) : std::next(it);
    }
    if (s.contains("requested")) size["requested"] = s["requested"];
    r["size"] = size;
    const std::string measure = s.value("x_measure", std::string("vertices"));
    r["x_measure"] = measure;
    r["x"] = size.contains(measure) ? size[measure] : json();
    r["plot"] = s.value("plot", true);
    const int code = s.value("exit_code", -1);
    r["exit_code"] = code;
    r["status"] = code == 0 ? "ok" : code == 124 ? "timeout" : "failed";
    r["seconds"] = s.contains("seconds") ? s["seconds"] : json();
    r["peak_rss_mb"] = s.contains("peak_rss_mb") ? s["peak_rss_mb"] : json();
    for (const char* k : {"command", "init", "log", "output"})
      if (s.contains(k)) r[k] = s[k];
    const json rep = read_json_file(s.value("report", std::string()));
    const json ev = read_json_file(s.value("evaluation", std::string()));
    if (s.contains("evaluation_exit_code")) {
      r["evaluation_exit_code"] = s["evaluation_exit_code"];
      r["evaluation_seconds"] = s.contains("evaluation_seconds") ? s["evaluation_seconds"] : json();
    }
    r["metrics"] = code == 0 ? metrics_of(method, rep, ev) : json::object();
    if (code == 0 && rep.is_object() && rep.contains("timings")) r["stage_seconds"] = rep["timings"];
    runs.push_back(r);
  }
  results["runs"] = runs;

  // Summary per (method, kind, size label).
  struct Acc {
    json first;
    int count = 0, ok = 0;
    double seconds = 0, rss = 0;
    int rss_n = 0;
    std::map<std::string, std::pair<double, int>> metrics;
    std::map<std::string, std::vector<double>> per_run;
  };
  std::vector<std::string> order;
  std::map<std::string, Acc> acc;
  for (auto& r : runs) {
    const std::string key = r["method"].get<std::string>() + "|" + r.value("kind", std::string()) + "|" +
                            r.value("size_label", std::string());
    if (!acc.count(key)) order.push_back(key);
    Acc& A = acc[key];
    if (A.count == 0) A.first = r;
    ++A.count;
    if (r["status"] != "ok") continue;
    ++A.ok;
    if (r["seconds"].is_number()) A.seconds += r["seconds"].get<double>();
    if (r["peak_rss_mb"].is_number()) A.rss += r["peak_rss_mb"].get<double>(), ++A.rss_n;
    for (auto& [k, v] : r["metrics"].items())
      if (v.is_number() || v.is_boolean()) {
        const double x = v.is_boolean() ? double(v.get<bool>()) : v.get<double>();
        A.metrics[k].first += x;
        A.metrics[k].second += 1;
        A.per_run[k].push_back(x);
      }
  }
  json summary = json::array();
  for (auto& key : order) {
    Acc& A = acc[key];
    json s;
    s["method"] = A.first["method"];
    for (const char* k : {"kind", "size_label"})
      if (A.first.contains(k)) s[k] = A.first[k];
    s["size"] = A.first["size"];
    s["runs"] = A.count;
    s["succeeded"] = A.ok;
    if (A.ok) s["seconds_mean"] = A.seconds / A.ok;
    if (A.rss_n) s["peak_rss_mb_mean"] = A.rss / A.rss_n;
    json m = json::object();
    for (auto& [k, v] : A.metrics) m[k] = v.first / v.second;
    s["metrics_mean"] = m;
    if (A.count > 1) {
      json pr = json::object();
      for (auto& [k, v] : A.per_run) pr[k] = v;
      s["metrics_per_run"] = pr;
    }
    summary.push_back(s);
  }
  results["summary"] = summary;
  try {
    std::ostringstream ss;
    ss << results.dump(2) << "\n";
    shapemap::write_text_atomic(out, ss.str());
  } catch (const std::exception& e) {
    std::cerr << "tool_bench_util: error: " << out << ": " << e.what() << "\n";
    return 1;
  }

  // Table.
  std::printf("%-20s %-15s %5s %8s %8s %9s %9s  %s\n", "method", "kind", "seed", "vertices", "tets", "seconds",
              "rss_MB", "status / key metrics");
  for (auto& r : runs) {
    std::string km;
    for (auto& k : key_metrics(r["method"]))
      if (r["metrics"].contains(k)) km += "  " + k + " " + fmt(r["metrics"][k]);
    std::string st = r["status"].get<std::string>();
    if (st != "ok") st += " (exit " + r["exit_code"].dump() + ")";
    std::printf("%-20s %-15s %5s %8s %8s %9s %9s  %s%s\n", r["method"].get<std::string>().c_str(),
                r.value("kind", std::string("-")).c_str(), r.contains("seed") ? fmt(r["seed"]).c_str() : "-",
                fmt(r["size"].value("vertices", json())).c_str(), fmt(r["size"].value("tets", json())).c_str(),
                fmt(r["seconds"]).c_str(), fmt(r["peak_rss_mb"]).c_str(), st.c_str(), km.c_str());
  }
  return 0;
}

int cmd_get(const std::vector<std::string>& a) {
  if (a.size() < 2) {
    std::cerr << "usage: tool_bench_util get FILE.json POINTER...\n";
    return 2;
  }
  std::ifstream f(a[0]);
  if (!f) {
    std::cerr << "tool_bench_util: error: cannot open " << a[0] << "\n";
    return 2;
  }
  const json j = json::parse(f);
  for (size_t k = 1; k < a.size(); ++k) {
    const json::json_pointer ptr(a[k]);
    std::string v = "-";
    if (j.contains(ptr)) {
      const json& x = j.at(ptr);
      if (x.is_number_float()) {
        char b[32];
        std::snprintf(b, sizeof b, "%.4g", x.get<double>());
        v = b;
      } else if (x.is_string()) {
        v = x.get<std::string>();
      } else {
        v = x.dump();
      }
    }
    std::cout << (k > 1 ? "\t" : "") << v;
  }
  std::cout << "\n";
  return 0;
}

int usage() {
  std::cerr << "usage: tool_bench_util landmarks PAIR_DIR K LA LB\n"
               "       tool_bench_util collect STEPS.jsonl -o RESULTS.json [--meta KEY=VALUE]...\n"
               "       tool_bench_util get FILE.json POINTER...\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  shapemap::use_passive_openmp_wait(argv);  // as the CLI runs (openmp_policy.h)
  if (argc < 2) return usage();
  const std::string cmd = argv[1];
  std::vector<std::string> args(argv + 2, argv + argc);
  try {
    if (cmd == "landmarks") return cmd_landmarks(args);
    if (cmd == "collect") return cmd_collect(args);
    if (cmd == "get") return cmd_get(args);
    if (cmd == "-h" || cmd == "--help") return usage(), 0;
  } catch (const std::exception& e) {
    std::cerr << "tool_bench_util: error: " << e.what() << "\n";
    return 2;
  }
  return usage();
}
