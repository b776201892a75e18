// shapemap evaluate volume: metrics of a volume map (symmetric-volume-maps Sec. 6.1).
//
//   shapemap evaluate volume A B MAP_AB [--map-ba MAP_BA] [--truth T] [-o report.json]
//
// MAP_AB: the map file (vertex of A -> tet of B + barycentric). --map-ba adds E_R (Eq. 18).
// --truth: ground-truth images of A's vertices in B's coordinates, either a map file of
// the same kind or a text file with one "x y z" line per vertex of A.
#include "shapemap/volume/volume_map_pipeline.h"
#include "common.h"
#include "eval_output.h"
#include "shapemap/error.h"
#include "shapemap/eval/volume_metrics.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

namespace shapemap::cli {


namespace {
Eigen::MatrixXd read_truth(const std::string& path, const TetMesh& B) {
  std::ifstream f(path);
  if (!f) throw InputError(path + ": cannot open");
  std::string first;  // the first line with content (after a byte-order mark, blanks, comments)
  while (std::getline(f, first)) {
    if (first.rfind("\xEF\xBB\xBF", 0) == 0) first.erase(0, 3);
    const size_t b = first.find_first_not_of(" \t\r");
    if (b != std::string::npos && first[b] != '#') {
      first.erase(0, b);
      break;
    }
  }
  if (first.rfind("shapemap-map", 0) == 0) {
    BarycentricMap m = read_map(path);
    validate_map(m, m.size(), B.num_tets(), 4, path);
    return map_positions(m, B.V, B.T);
  }
  return read_points(path);
}

TetMesh read_tets(const std::string& path) {
  if (!is_volume_path(path))
    throw InputError(path + ": not a tet mesh (.mesh .vtk .msh .node .ele)");
  TetMesh m = read_volume(path);
  try {
    unit_volume_normalization(m);  // the metrics' unit-volume scaling needs a finite, nonzero volume
  } catch (const InputError& e) {
    throw InputError(path + ": " + e.what());
  }
  return m;
}

struct VolumeEvalArgs {
  std::string A, B, map, map_ba, truth, out;
};

CLI::App* add_evaluate_volume_command(CLI::App& evaluate, VolumeEvalArgs& a) {
  CLI::App* app = evaluate.add_subcommand("volume", "Metrics of a volume map (Sec. 6.1 of symmetric volume maps)");
  app->add_option("A", a.A, "Source tet mesh")->required();
  app->add_option("B", a.B, "Target tet mesh")->required();
  app->add_option("MAP_AB", a.map, "Map file A -> B")->required();
  app->add_option("--map-ba", a.map_ba, "Map file B -> A (for E_R)");
  app->add_option("--truth", a.truth, "Ground-truth images of A's vertices (map file or x y z lines)");
  app->add_option("-o,--output", a.out, "Write the metrics JSON here (default: stdout)");
  return app;
}

int run_evaluate_volume(const VolumeEvalArgs& a, const GlobalOptions& g) {
  TetMesh A = read_tets(a.A), B = read_tets(a.B);
  BarycentricMap m = read_map(a.map);
  validate_map(m, A.num_vertices(), B.num_tets(), 4, a.map);
  Eigen::MatrixXd X = map_positions(m, B.V, B.T);
  Eigen::MatrixXd Xba, T;
  if (!a.map_ba.empty()) {
    BarycentricMap mb = read_map(a.map_ba);
    validate_map(mb, B.num_vertices(), A.num_tets(), 4, a.map_ba);
    Xba = map_positions(mb, A.V, A.T);
  }
  if (!a.truth.empty()) {
    T = read_truth(a.truth, B);
    if (T.rows() != A.num_vertices())
      throw InputError(a.truth + ": " + std::to_string(T.rows()) + " rows for " +
                       std::to_string(A.num_vertices()) + " vertices of A");
  }
  VolumeMapMetrics r = volume_map_metrics(A, B, X, a.map_ba.empty() ? nullptr : &m,
                                          a.map_ba.empty() ? nullptr : &Xba,
                                          a.truth.empty() ? nullptr : &T);
  nlohmann::json j = report_header(g, "evaluate volume");
  j["inputs"] = {{"A", a.A}, {"B", a.B}, {"map_AB", a.map}};
  if (!a.map_ba.empty()) j["inputs"]["map_BA"] = a.map_ba;
  if (!a.truth.empty()) j["inputs"]["truth"] = a.truth;
  j["metrics"] = volume_metrics_json(r);
  emit_evaluation(a.out, j);
  return 0;
}

}  // namespace

Command register_evaluate_volume(CLI::App& evaluate, GlobalOptions& g) {
  return args_command<VolumeEvalArgs>(evaluate, g, add_evaluate_volume_command, run_evaluate_volume);
}

}  // namespace shapemap::cli
