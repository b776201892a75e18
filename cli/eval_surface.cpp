// shapemap evaluate surface A B MAP [--truth TRUTH | --landmarks LA LB] [--map-ba MAP_BA] [--per-face] [-o FILE]
// Metrics of a surface map A -> B (MAP in the map_AB.txt format): the BIM benchmark
// protocol (Kim et al. 2011, Sec. 8.2): geodesic error of each ground-truth
// correspondence normalized by sqrt(area(B)), its cumulative curve at thresholds
// 0, 0.01, ..., 0.25, mean and maximum; against a dense truth map (TRUTH, same format,
// e.g. from `shapemap generate`) or sparse landmarks (line i of LA <-> line i of LB).
// Always: the map's integrated confidence (area preservation, Eq. 2) and the distortion
// metrics of elastic-correspondence.txt Sec. 6.1 (eval/surface_distortion.h), on unit-area
// copies of A and B: conformal distortion per triangle (Hormann-Greiner MIPS - 2), area
// distortion log(a/a^) per triangle, mean curvature error |P H~ - H| in the lumped L2 norm,
// flipped and collapsed mapped triangles; with --map-ba MAP_BA (B -> A) also the
// reversibility |P Q X - X|_X (also per vertex over A's bounding-box diagonal) and the
// same metrics for MAP_BA. --per-face adds the per-triangle values. JSON on stdout, or in
// FILE with -o.
#include "common.h"
#include "eval_output.h"
#include "shapemap/error.h"
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/eval/surface_metrics.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <algorithm>
#include <iostream>
#include <vector>

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

// Sec. 6.1 distortion metrics of the map S -> T (unit-area copies).
nlohmann::json distortion_json(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                               bool per_face) {
  const SurfaceDistortion d = surface_distortion(S, T, P);
  auto quantile = [](const Eigen::VectorXd& v, double q) {
    if (v.size() == 0) return 0.0;
    std::vector<double> s(v.data(), v.data() + v.size());
    const size_t k = std::min(s.size() - 1, size_t(q * double(s.size() - 1) + 0.5));
    std::nth_element(s.begin(), s.begin() + k, s.end());
    return s[k];
  };
  const Eigen::VectorXd area_abs = d.area.cwiseAbs();
  nlohmann::json j;
  j["conformal_distortion"] = {{"definition", "per triangle sigma1/sigma2 + sigma2/sigma1 - 2 (MIPS - 2), "
                                              "collapsed triangles clamped to 1e4"},
                               {"mean", d.conformal_mean},
                               {"median", d.conformal_median},
                               {"p90", quantile(d.conformal, 0.9)},
                               {"max", d.conformal.size() ? d.conformal.maxCoeff() : 0.0}};
  j["area_distortion"] = {{"definition", "per triangle log(a/a^), a^ source area, a mapped area; "
                                         "statistics of |log(a/a^)|"},
                          {"mean_abs", d.area_mean_abs},
                          {"median_abs", d.area_median_abs},
                          {"p90_abs", quantile(area_abs, 0.9)},
                          {"max_abs", area_abs.size() ? area_abs.maxCoeff() : 0.0}};
  j["mean_curvature_error"] = d.mean_curvature_error;
  j["flipped_triangles"] = d.flipped;
  j["degenerate_triangles"] = d.degenerate;
  j["faces"] = S.num_faces();
  if (per_face) {
    j["conformal_distortion"]["per_face"] =
        std::vector<double>(d.conformal.data(), d.conformal.data() + d.conformal.size());
    j["area_distortion"]["per_face"] = std::vector<double>(d.area.data(), d.area.data() + d.area.size());
  }
  return j;
}

}  // namespace

Command register_evaluate_surface(CLI::App& evaluate, GlobalOptions& g) {
  Command c;
  c.app = evaluate.add_subcommand("surface", "Metrics of a surface map (BIM benchmark protocol)");
  struct Args {
    std::string A, B, map, truth, out, map_ba;
    bool per_face = false;
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
      ->check(non_negative());
  c.app->add_option("--map-ba", a->map_ba,
                    "The reverse map B -> A (map_BA.txt): reversibility |PQX - X| and its metrics");
  c.app->add_flag("--per-face", a->per_face, "Also write per-triangle conformal and area distortion");
  c.app->add_option("-o,--output", a->out, "Write the JSON here instead of stdout");
  c.run = [a, &g] {
    TriMesh A = read_surface(a->A), B = read_surface(a->B);
    for (const auto& [M, path] : {std::pair<const TriMesh*, std::string>{&A, a->A}, {&B, a->B}}) {
      try {
        unit_area_normalization(*M);  // the metrics' unit-area scaling needs a finite, nonzero area
      } catch (const InputError& e) {
        throw InputError(path + ": " + e.what());
      }
    }
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
      for (const std::string& n : tidy_landmark_pairs(la, lb, a->landmarks[0], a->landmarks[1])) info(g, n);
      j["landmarks"] = a->landmarks;
      SurfaceErrorCurve cv = surface_landmark_error(map, la, lb, B.V, B.F, o);
      j["geodesic_error"] = curve_json(cv);
      j["geodesic_error"]["per_landmark"] = std::vector<double>(cv.errors.data(), cv.errors.data() + cv.errors.size());
    }
    double ic = 0;
    surface_map_confidence(A.V, A.F, map_positions(map, B.V, B.F), surface_area(B.V, B.F), &ic);
    j["integrated_confidence"] = ic;
    // Sec. 6.1 of elastic-correspondence.txt.
    j["distortion"] = distortion_json(A, B, map, a->per_face);
    j["distortion"]["normalization"] = "A and B scaled to unit area";
    if (!a->map_ba.empty()) {
      BarycentricMap ba = read_map(a->map_ba);
      validate_map(ba, B.num_vertices(), A.num_faces(), 3, a->map_ba);
      j["map_ba"] = a->map_ba;
      j["reversibility"] = reversibility_error(A, B, map, ba);  // |P Q X - X|_X, unit area
      j["reversibility_definition"] = "|P Q X - X| in the lumped L2 norm of A (unit area)";
      // The same round trip per vertex, as a share of A's bounding-box diagonal: a
      // scale-free figure for maps without ground truth (issue 20's camel target).
      const Eigen::VectorXd d = round_trip_bbox(A, B, map, ba);
      j["reversibility_bbox"] = {{"definition", "per vertex of A: |P Q x - x| / bounding-box diagonal of A"},
                                 {"mean", d.mean()},
                                 {"max", d.maxCoeff()}};
      j["distortion_BA"] = distortion_json(B, A, ba, a->per_face);
    }
    emit_evaluation(a->out, j);
    return 0;
  };
  return c;
}

}  // namespace shapemap::cli
