// shapemap surface-map A B -o OUT [--method bim|elastic] [--init bim|FILE]
//                                 [--landmarks LA LB] [--symmetric]
// Map between two closed genus-0 surfaces. Writes into OUT (DESIGN.md contract):
//   map_AB.txt (map_BA.txt with --symmetric), A_on_B.obj (B_on_A.obj), report.json.
// --method bim: Blended Intrinsic Maps (src/surface/bim.cpp); with --landmarks the
//   candidate Möbius maps are the triplets of the given correspondences.
// --method elastic: elastic correspondence refinement (src/surface/elastic.cpp) of an
//   initial map from BIM (--init bim, default) or from a map file (--init FILE).
#include "common.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/surface/bim.h"
#include "figures.h"
#include "surface_map_elastic.h"
#include <filesystem>

namespace shapemap::cli {

namespace {

struct SurfaceMapArgs {
  std::string A, B, out;
  std::string method = "bim";
  std::string init = "bim";
  std::vector<std::string> landmarks;  // LA LB
  bool symmetric = false;
  bool reverse_candidates = false;
  // BIM options exposed on the command line (defaults from the paper, BIMOptions).
  int max_features = 10;
  int max_candidates = 10000;
  int num_even = 256;
};

struct Inputs {
  TriMesh A, B;
  std::vector<int> la, lb;
  std::vector<std::string> notes;  // repeated landmarks (tidy_landmark_pairs)
};

Inputs read_inputs(const SurfaceMapArgs& a) {
  Inputs in;
  in.A = read_surface(a.A);
  in.B = read_surface(a.B);
  if (!a.landmarks.empty()) {
    if (a.landmarks.size() != 2) throw InputError("--landmarks: needs two files, LA and LB");
    in.la = read_landmarks(a.landmarks[0], in.A.V);
    in.lb = read_landmarks(a.landmarks[1], in.B.V);
    in.notes = tidy_landmark_pairs(in.la, in.lb, a.landmarks[0], a.landmarks[1]);
    if (in.la.size() < 3) throw InputError(a.landmarks[0] + ": at least 3 landmarks are needed");
  }
  return in;
}

BIMOptions bim_options(const SurfaceMapArgs& a, const GlobalOptions& g, const Inputs& in) {
  BIMOptions o;
  o.seed = g.seed;
  o.symmetric = a.symmetric;
  o.reverse_candidates = a.reverse_candidates;
  o.name_A = a.A;
  o.name_B = a.B;
  o.max_features = a.max_features;
  o.max_candidates = a.max_candidates;
  o.num_even = a.num_even;
  o.landmarks_A = in.la;
  o.landmarks_B = in.lb;
  return o;
}

nlohmann::json direction_json(const BIMDirectionResult& r) {
  nlohmann::json j;
  j["integrated_confidence"] = r.integrated_confidence;
  j["num_candidates"] = r.num_candidates;
  j["num_candidates_before_pruning"] = r.num_candidates_total;
  j["num_consistent_pairs"] = r.num_consistent_pairs;
  j["eigenvalues"] = r.eigenvalues;
  j["num_eigenvectors_used"] = r.num_eigenvectors_used;
  j["group_sizes"] = r.group_sizes;
  j["group_integrated_confidence"] = r.group_confidence;
  j["selected_group"] = r.selected_group;
  j["from_reverse"] = r.from_reverse;
  if (r.from_reverse) j["own_integrated_confidence"] = r.own_integrated_confidence;
  j["best_single_map_confidence"] = r.best_candidate_confidence;
  nlohmann::json sel = nlohmann::json::array();
  for (auto& m : r.selected)
    sel.push_back({{"candidate", m.index},
                   {"source_vertices", m.source},
                   {"target_vertices", m.target},
                   {"confidence", m.integrated_confidence}});
  j["selected_maps"] = sel;
  return j;
}

void write_mapped_surface(const std::string& path, const TriMesh& source, const Eigen::MatrixXd& X) {
  TriMesh m;
  m.V = X;
  m.F = source.F;
  write_surface(path, m);
}

int run_bim(const SurfaceMapArgs& a, const ElasticCliOptions& eo, const GlobalOptions& g) {
  if (a.init != "bim") throw InputError("--init " + a.init + ": an initial map is only used by --method elastic");
  StageTimer timer;
  timer.start("read");
  Inputs in = read_inputs(a);
  for (const std::string& n : in.notes) info(g, n);
  OutputDir out(a.out);
  BIMOptions o = bim_options(a, g, in);
  // Safe repairs (or --strict's refusal), then the library's input guard, before the
  // progress line: bad input gives one line. BIM runs on the repaired surfaces; the outputs
  // are carried back to the user's numbering.
  const SurfaceRepair rA = repair_input_surface(in.A, a.A, g), rB = repair_input_surface(in.B, a.B, g);
  check_surface_map_input(rA.mesh, a.A, o.min_vertices, g);
  check_surface_map_input(rB.mesh, a.B, o.min_vertices, g);
  for (int& v : o.landmarks_A) v = repaired_vertex(rA, v);
  for (int& v : o.landmarks_B) v = repaired_vertex(rB, v);
  BarycentricMap truth;
  const bool has_truth = !eo.truth_ab.empty();
  if (has_truth)
    truth = map_to_repaired(read_checked_map(eo.truth_ab, in.A.num_vertices(), in.B.num_faces()), rA, rB, in.B);
  timer.start("bim");
  info(g, "surface-map: Blended Intrinsic Maps " + a.A + " -> " + a.B);
  BIMResult r = blended_intrinsic_maps(rA.mesh, rB.mesh, o, make_progress(g));
  timer.start("write");
  const bool repaired = rA.changed() || rB.changed();
  const BarycentricMap mAB = map_to_inputs(r.AB.map, rA, rB, in.B);
  write_map(out.path("map_AB.txt"), mAB);
  write_mapped_surface(out.path("A_on_B.obj"), in.A, repaired ? map_positions(mAB, in.B.V, in.B.F) : r.AB.positions);
  if (a.symmetric) {
    const BarycentricMap mBA = map_to_inputs(r.BA.map, rB, rA, in.A);
    write_map(out.path("map_BA.txt"), mBA);
    write_mapped_surface(out.path("B_on_A.obj"), in.B, repaired ? map_positions(mBA, in.A.V, in.A.F) : r.BA.positions);
  }
  timer.stop();
  nlohmann::json j = report_header(g, "surface-map");
  j["method"] = "bim";
  j["inputs"] = {{"A", a.A}, {"B", a.B}, {"A_vertices", in.A.num_vertices()}, {"A_faces", in.A.num_faces()},
                 {"B_vertices", in.B.num_vertices()}, {"B_faces", in.B.num_faces()}};
  j["inputs"]["repairs"] = repairs_json(rA, rB);
  if (!a.landmarks.empty()) j["inputs"]["landmarks"] = a.landmarks;
  if (has_truth) j["inputs"]["truth"] = eo.truth_ab;
  j["parameters"] = {{"max_features", o.max_features},     {"num_even", o.num_even},
                     {"max_candidates", o.max_candidates}, {"sigma", o.sigma},
                     {"eigenvalue_fraction", o.eigenvalue_fraction},
                     {"entry_fraction", o.entry_fraction}, {"feature_radius", o.feature_radius},
                     {"symmetric", o.symmetric}, {"reverse_candidates", o.reverse_candidates}};
  // BIM's own output (Sec. 5): candidates, consistency spectrum, selected maps, stages.
  nlohmann::json bim;
  bim["features_A"] = r.features_A;
  bim["features_B"] = r.features_B;
  bim["AB"] = direction_json(r.AB);
  if (a.symmetric) bim["BA"] = direction_json(r.BA);
  nlohmann::json stages = nlohmann::json::object();
  for (auto& [name, s] : r.timings) stages[name] = s;
  bim["stages"] = stages;
  bim["total_seconds"] = r.total_seconds;
  j["bim"] = bim;
  // The same map metrics as the elastic method (and its geodesic error with --truth), of
  // the surfaces BIM ran on.
  timer.start("metrics");
  Eigen::VectorXd error_AB;  // per vertex of A, with --truth (report.html)
  j["metrics"]["AB"] = surface_map_metrics_json(rA.mesh, rB.mesh, r.AB.map, a.symmetric ? &r.BA.map : nullptr,
                                                has_truth ? &truth : nullptr, &error_AB);
  if (a.symmetric) j["metrics"]["BA"] = surface_map_metrics_json(rB.mesh, rA.mesh, r.BA.map, &r.AB.map, nullptr);
  timer.start("pictures");
  const auto figures = surface_map_figures(rA.mesh, rB.mesh, r.AB.map, a.symmetric ? &r.BA.map : nullptr);
  const ViewerData viewer = surface_map_viewer_data(rA.mesh, rB.mesh, r.AB.map, a.symmetric ? &r.BA.map : nullptr,
                                                    o.landmarks_A, o.landmarks_B, &error_AB);
  timer.stop();
  j["timings"] = timer.json();
  write_reports(out, j, "shapemap surface-map --method bim", figures, &viewer, &g);
  out.commit();
  info(g, "surface-map: integrated confidence " + std::to_string(r.AB.integrated_confidence) + ", " +
              std::to_string(r.AB.selected.size()) + " blended maps of " + std::to_string(r.AB.num_candidates) +
              " candidates; wrote " + a.out);
  return 0;
}

// ---- --method elastic ------------------------------------------------------------------
// Initial maps: BIM in both directions (--init bim, with --landmarks restricted to them)
// or a map file (--init FILE). The elastic refinement itself is added here by the
// elastic-correspondence implementation (src/surface/elastic.*).
int run_elastic(const SurfaceMapArgs& a, const ElasticCliOptions& eo, const GlobalOptions& g) {
  // The whole elastic pipeline (init, refinement, metrics, outputs) lives in
  // cli/surface_map_elastic.cpp; --init FILE is validated there (exit 2 on mismatch).
  if (a.symmetric && eo.injective)
    throw InputError("--symmetric: the injective model (--elastic-injective, Eq. 4) maps A -> B only");
  ElasticMapArgs e;
  e.A = a.A;
  e.B = a.B;
  e.out = a.out;
  e.init = a.init;
  e.landmarks = a.landmarks;
  e.bim = bim_options(a, g, Inputs{});
  return run_elastic_surface_map(e, eo, g);
}

}  // namespace

Command register_surface_map(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("surface-map", "Map between two closed genus-0 surfaces (BIM, elastic refinement)");
  auto a = std::make_shared<SurfaceMapArgs>();
  c.app->add_option("A", a->A, "Source surface (.obj .off .ply .stl)")->required();
  c.app->add_option("B", a->B, "Target surface")->required();
  c.app->add_option("-o,--output", a->out, "Output folder")->required();
  c.app->add_option("--method", a->method, "bim (Blended Intrinsic Maps) or elastic (refinement)")
      ->check(CLI::IsMember({"bim", "elastic"}));
  c.app->add_option("--init", a->init, "elastic: initial map, 'bim', a map file (map_AB.txt format) or a folder with "
                    "map_AB.txt [map_BA.txt]");
  c.app->add_option("--landmarks", a->landmarks,
                    "LA LB: corresponding landmark lists (one 0-based vertex index or one x y z point per line)")
      ->expected(2);
  c.app->add_flag("--symmetric", a->symmetric,
                  "BIM: also compute the map B -> A (the elastic bijective model always does; "
                  "not with --elastic-injective)");
  c.app->add_flag("--reverse-candidates", a->reverse_candidates,
                  "BIM with --symmetric (and elastic's BIM init): the direction with the less confident "
                  "blend takes the inverse of the other direction's blend");
  c.app->add_option("--features", a->max_features, "BIM: at most this many AGD feature points per surface")
      ->check(CLI::Range(3, 30));
  c.app->add_option("--candidates", a->max_candidates, "BIM: at most this many candidate Möbius maps")
      ->check(CLI::PositiveNumber);
  c.app->add_option("--samples", a->num_even, "BIM: |P_even| evenly spread samples")->check(CLI::Range(16, 4096));
  auto eo = std::make_shared<ElasticCliOptions>();
  add_elastic_options(c.app, *eo);
  c.run = [a, eo, &g] {
    if (a->method == "elastic") return run_elastic(*a, *eo, g);
    return run_bim(*a, *eo, g);
  };
  return c;
}

}  // namespace shapemap::cli
