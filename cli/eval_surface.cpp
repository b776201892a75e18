// shapemap evaluate surface A B MAP [--truth TRUTH | --landmarks LA LB] [-o FILE]
// Metrics of a surface map A -> B (MAP in the map_AB.txt format): the BIM benchmark
// protocol (Kim et al. 2011, Sec. 8.2): geodesic error of each ground-truth
// correspondence normalized by sqrt(area(B)), its cumulative curve at thresholds
// 0, 0.01, ..., 0.25, mean and maximum; against a dense truth map (TRUTH, same format,
// e.g. from `shapemap generate`) or sparse landmarks (line i of LA <-> line i of LB).
// Always: the map's integrated confidence (area preservation, Eq. 2). JSON on stdout,
// or in FILE with -o.
#include "common.h"
#include "shapemap/error.h"
#include "shapemap/eval/surface_metrics.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include <iostream>

namespace shapemap::cli {

namespace {

nlohmann::json curve_json(const SurfaceErrorCurve& c) {
  nlohmann::json j;
  j["count"] = c.count;
  j["mean"] = c.mean;
  j["max"] = c.max;
  j["fraction_within_0.1"] = c.within_0_1;
  j["thresholds"] = c.thresholds;
  j["fraction"] = c.fraction;
  return j;
}

}  // namespace

Command register_evaluate_surface(CLI::App& evaluate, GlobalOptions& g) {
  Command c;
  c.app = evaluate.add_subcommand("surface", "Metrics of a surface map (BIM benchmark protocol)");
  struct Args {
    std::string A, B, map, truth, out;
    std::vector<std::string> landmarks;
    int max_points = 0;
  };
  auto a = std::make_shared<Args>();
  c.app->add_option("A", a->A, "Source surface")->required();
  c.app->add_option("B", a->B, "Target surface")->required();
  c.app->add_option("MAP", a->map, "Map A -> B (map_AB.txt)")->required();
  auto* truth = c.app->add_option("--truth", a->truth, "Dense ground-truth map A -> B (same format)");
  auto* lm = c.app->add_option("--landmarks", a->landmarks, "LA LB: corresponding vertex lists")->expected(2);
  truth->excludes(lm);
  c.app->add_option("--max-points", a->max_points, "Dense truth: evaluate at most this many vertices (0 = all)")
      ->check(CLI::NonNegativeNumber);
  c.app->add_option("-o,--output", a->out, "Write the JSON here instead of stdout");
  c.run = [a, &g] {
    TriMesh A = read_surface(a->A), B = read_surface(a->B);
    BarycentricMap map = read_map(a->map);
    validate_map(map, A.num_vertices(), B.num_faces(), 3, a->map);
    nlohmann::json j;
    j["A"] = a->A;
    j["B"] = a->B;
    j["map"] = a->map;
    j["normalization"] = "geodesic distances divided by sqrt(area(B))";
    SurfaceErrorOptions o;
    o.max_points = a->max_points;
    if (!a->truth.empty()) {
      BarycentricMap t = read_map(a->truth);
      validate_map(t, A.num_vertices(), B.num_faces(), 3, a->truth);
      j["truth"] = a->truth;
      j["geodesic_error"] = curve_json(surface_map_error(map, t, B.V, B.F, o, make_progress(g)));
    } else if (!a->landmarks.empty()) {
      std::vector<int> la = read_landmarks(a->landmarks[0], A.V), lb = read_landmarks(a->landmarks[1], B.V);
      if (la.size() != lb.size())
        throw InputError(a->landmarks[1] + ": " + std::to_string(lb.size()) + " landmarks, but " +
                         a->landmarks[0] + " has " + std::to_string(la.size()));
      j["landmarks"] = a->landmarks;
      SurfaceErrorCurve cv = surface_landmark_error(map, la, lb, B.V, B.F, o);
      j["geodesic_error"] = curve_json(cv);
      j["geodesic_error"]["per_landmark"] = std::vector<double>(cv.errors.data(), cv.errors.data() + cv.errors.size());
    }
    double ic = 0;
    surface_map_confidence(A.V, A.F, map_positions(map, B.V, B.F), surface_area(B.V, B.F), &ic);
    j["integrated_confidence"] = ic;
    if (a->out.empty()) {
      std::cout << j.dump(2) << "\n";
    } else {
      write_json(a->out, j);
    }
    return 0;
  };
  return c;
}

}  // namespace shapemap::cli
