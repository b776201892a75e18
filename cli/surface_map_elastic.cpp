// shapemap surface-map --method elastic: elastic, crease-aware correspondence
// (elastic-correspondence.txt) initialized by BIM, landmarks or a given map.
#include "surface_map_elastic.h"
#include "figures.h"

#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/eval/surface_metrics.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/surface/bim.h"
#include "shapemap/surface/elastic.h"

#include <algorithm>
#include <filesystem>

namespace shapemap::cli {

namespace fs = std::filesystem;

void add_elastic_options(CLI::App* app, ElasticCliOptions& o) {
  app->add_option("--elastic-preset", o.preset,
                  "elastic: bending weight preset (Sec. 5.2/6.1): auto (default: degenerate if the "
                  "initial maps have flipped or collapsed triangles, as Sec. 5.2 advises, else "
                  "non-isometric), non-isometric (eta 0.1), near-isometric (0.01), degenerate "
                  "(0.002, for degenerate initial maps)")
      ->check(CLI::IsMember({"auto", "non-isometric", "near-isometric", "degenerate"}));
  app->add_option("--elastic-eta", o.eta, "elastic: bending weight eta (Eq. 2), overrides the preset")
      ->check(non_negative());
  app->add_option("--elastic-alpha", o.alpha, "elastic: membrane weight alpha (Eq. 2)")
      ->check(non_negative());
  app->add_option("--elastic-iterations", o.iterations, "elastic: outer iterations K (Algorithm 1)")
      ->check(non_negative());
  app->add_flag("--elastic-injective", o.injective,
                "elastic: locally injective model E_inj (Eq. 4) instead of E_bij (Eq. 6)");
  app->add_flag("--elastic-partial", o.partial,
                "elastic: partial matching (Sec. 6.2): no unit-area scaling");
  app->add_option("--elastic-beta-start", o.beta_start,
                  "elastic: start of the beta ramp (Sec. 5.2: 1e3, linearly to 2e5)")
      ->check(non_negative());
  app->add_option("--elastic-log-eps", o.log_eps,
                  "elastic: -log det G is extended linearly below this (Sec. 4.1; default 1e-4; "
                  "0 = an unbounded barrier)")
      ->check(non_negative());
  app->add_flag("--elastic-keep-orientation", o.keep_orientation,
                "elastic: the Y-step line search never passes a triangle through zero area");
  app->add_flag("--elastic-gamma-ramp", o.gamma_ramp,
                "elastic: ramp the reversibility weight gamma (Eq. 6) from 0 with beta's schedule");
  app->add_flag("--elastic-plain-projection", o.plain_projection,
                "elastic: the P/Q steps of Sec. 5.1 as the plain closest point (default: rows that "
                "would flip or collapse a mapped triangle keep their previous value)");
  app->add_flag("--elastic-keep-worse", o.keep_worse,
                "elastic: return the last iterate even when it has more flipped or collapsed "
                "triangles than the initial map (default: the collapse guard keeps the latest "
                "iterate that has no more, or the initial map; report.json: elastic.guard)");
  app->add_option("--elastic-inner-iterations", o.inner_iterations,
                  "elastic: at most this many L-BFGS iterations per Y step (Sec. 5.1: 50)")
      ->check(non_negative());
  app->add_option("--elastic-inner-f-tol", o.inner_f_tol,
                  "elastic: a Y step stops when an iteration lowers E by less than this times "
                  "max(1, |E|) (default 1e-9)")
      ->check(non_negative());
  app->add_option("--elastic-ramp-inner-f-tol", o.ramp_inner_f_tol,
                  "elastic: the same during the beta ramp (default 0: as --elastic-inner-f-tol; "
                  "1e-6 about halves the time at a slightly larger error, docs/methods.md)")
      ->check(non_negative());
  app->add_option("--truth", o.truth_ab,
                  "ground-truth map A->B (map file) for the geodesic error in report.json");
}

namespace {

// Q from P: every vertex of B onto the mapped surface P X~ (A's triangulation) by
// closest point, giving a face of A and barycentric coordinates.
BarycentricMap invert_map(const BarycentricMap& P, const TriMesh& A, const TriMesh& B) {
  const Eigen::MatrixXd Y = map_positions(P, B.V, B.F);
  ClosestPoint3 bvh(Y, A.F);
  const auto res = bvh.query(B.V);
  BarycentricMap Q;
  Q.elem.resize(B.num_vertices());
  Q.bary.resize(B.num_vertices(), 3);
  for (int i = 0; i < B.num_vertices(); ++i) {
    Q.elem(i) = res[i].elem;
    Eigen::RowVector3d b = res[i].bary.head<3>().transpose().cwiseMax(0.0);
    const double s = b.sum();
    Q.bary.row(i) = s > 0 ? Eigen::RowVector3d(b / s) : Eigen::RowVector3d(1, 0, 0);
  }
  return Q;
}

}  // namespace

BarycentricMap read_checked_map(const std::string& path, int n_source, int m_target) {
  BarycentricMap m = read_map(path);
  validate_map(m, n_source, m_target, 3, path);
  return m;
}

nlohmann::json surface_map_metrics_json(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                                        const BarycentricMap* Q, const BarycentricMap* truth,
                                        Eigen::VectorXd* vertex_error) {
  const SurfaceDistortion d = surface_distortion(S, T, P);
  nlohmann::json j;
  j["conformal_distortion_mean"] = d.conformal_mean;      // Sec. 6.1, MIPS - 2
  j["conformal_distortion_median"] = d.conformal_median;
  j["area_distortion_mean_abs"] = d.area_mean_abs;        // Sec. 6.1, |log(a/a^)|
  j["area_distortion_median_abs"] = d.area_median_abs;
  j["mean_curvature_error"] = d.mean_curvature_error;     // Sec. 6.1, |P H~ - H|_X
  j["flipped_triangles"] = d.flipped;
  j["degenerate_triangles"] = d.degenerate;
  if (Q && Q->size() > 0) j["reversibility"] = reversibility_error(S, T, P, *Q);  // |PQX - X|_X
  if (truth) {
    const SurfaceErrorCurve c = surface_map_error(P, *truth, T.V, T.F);
    j["geodesic_error_mean"] = c.mean;
    j["geodesic_error_max"] = c.max;
    j["geodesic_within_0_1"] = c.within_0_1;
    if (vertex_error) {
      *vertex_error = Eigen::VectorXd::Constant(S.num_vertices(), -1.0);
      for (int k = 0; k < c.evaluated.size(); ++k) (*vertex_error)(c.evaluated(k)) = c.errors(k);
    }
  }
  return j;
}

int run_elastic_surface_map(const ElasticMapArgs& args, const ElasticCliOptions& o,
                            const GlobalOptions& g) {
  StageTimer timer;
  timer.start("read");
  // The user's surfaces (inA, inB: maps read and written are in their numbering) and the
  // repaired ones the method runs on (A, B), with the same input guard as BIM.
  const TriMesh inA = read_surface(args.A), inB = read_surface(args.B);
  const SurfaceRepair rA = repair_input_surface(inA, args.A, g), rB = repair_input_surface(inB, args.B, g);
  const TriMesh& A = rA.mesh;
  const TriMesh& B = rB.mesh;
  check_surface_map_input(A, args.A, args.bim.min_vertices, g);
  check_surface_map_input(B, args.B, args.bim.min_vertices, g);
  BarycentricMap truth;
  const bool has_truth = !o.truth_ab.empty();
  if (has_truth) truth = map_to_repaired(read_checked_map(o.truth_ab, inA.num_vertices(), inB.num_faces()), rA, rB, inB);
  OutputDir out(args.out);

  // Initial maps.
  timer.start("init");
  BarycentricMap initAB, initBA;
  std::string init_kind;
  const bool bij = !o.injective;
  bool q_given = true;  // false: initBA made below from initAB by closest point
  std::vector<int> landmarks_A, landmarks_B;  // on the repaired surfaces, for report.html
  if (!args.landmarks.empty()) {
    if (args.landmarks.size() != 2) throw InputError("--landmarks: expected two files LA LB");
    std::vector<int> la = read_landmarks(args.landmarks[0], inA.V);
    std::vector<int> lb = read_landmarks(args.landmarks[1], inB.V);
    for (const std::string& n : tidy_landmark_pairs(la, lb, args.landmarks[0], args.landmarks[1])) info(g, n);
    for (int& v : la) v = repaired_vertex(rA, v);
    for (int& v : lb) v = repaired_vertex(rB, v);
    BIMOptions bo = args.bim;
    bo.name_A = args.A;
    bo.name_B = args.B;
    landmark_initial_maps(A, B, la, lb, initAB, initBA, &bo);
    landmarks_A = la;
    landmarks_B = lb;
    init_kind = "landmarks (BIM over landmark triplets)";
  } else if (args.init.empty() || args.init == "bim") {
    BIMOptions bo = args.bim;
    bo.landmarks_A.clear();
    bo.landmarks_B.clear();
    bo.symmetric = true;
    bo.name_A = args.A;
    bo.name_B = args.B;
    info(g, "elastic: initial maps by BIM (both directions)");
    BIMResult r = blended_intrinsic_maps(A, B, bo, make_progress(g));
    initAB = r.AB.map;
    initBA = r.BA.map;
    init_kind = "bim";
  } else if (fs::is_directory(args.init)) {
    const std::string ab = (fs::path(args.init) / "map_AB.txt").string();
    const std::string ba = (fs::path(args.init) / "map_BA.txt").string();
    if (!fs::exists(ab)) throw InputError(args.init + ": no map_AB.txt in this folder");
    initAB = map_to_repaired(read_checked_map(ab, inA.num_vertices(), inB.num_faces()), rA, rB, inB);
    if (fs::exists(ba)) {
      initBA = map_to_repaired(read_checked_map(ba, inB.num_vertices(), inA.num_faces()), rB, rA, inA);
      init_kind = "files " + ab + ", " + ba;
    } else {
      initBA = invert_map(initAB, A, B);
      q_given = false;
      init_kind = "file " + ab + " (B->A by closest point on the mapped surface)";
    }
  } else {
    if (!fs::exists(args.init)) throw InputError(args.init + ": no such file (--init bim|FILE)");
    initAB = map_to_repaired(read_checked_map(args.init, inA.num_vertices(), inB.num_faces()), rA, rB, inB);
    initBA = invert_map(initAB, A, B);
    q_given = false;
    init_kind = "file " + args.init + " (B->A by closest point on the mapped surface)";
  }

  // Elastic refinement.
  timer.start("elastic");
  ElasticOptions eo;
  if (o.preset == "near-isometric") eo = ElasticOptions::near_isometric();
  else if (o.preset == "degenerate") eo = ElasticOptions::degenerate_init();
  std::string eta_choice = o.preset;
  if (o.eta >= 0) {
    eo.eta = o.eta;
    eta_choice = "--elastic-eta";
  } else if (o.preset == "auto") {
    // A Q made here by closest point (no map_BA.txt given) is not an initial map of the
    // user's: only P and a given or BIM-computed Q count.
    const BendingWeightChoice c = bending_weight_for_initial_maps(
        A, B, initAB, bij && q_given ? initBA : BarycentricMap{}, eo.eta);
    eo.eta = c.eta;
    eta_choice = "auto: " + std::to_string(c.flipped) + " flipped and " + std::to_string(c.degenerate) +
                 " collapsed triangles in the initial maps -> " +
                 (c.flipped + c.degenerate > 0 ? "degenerate (Sec. 5.2)" : "non-isometric");
  }
  eo.alpha = o.alpha;
  eo.max_outer_iterations = o.iterations;
  eo.model = bij ? ElasticModel::Bijective : ElasticModel::Injective;
  eo.normalize_area = !o.partial;
  eo.keep_no_worse = !o.keep_worse;
  if (o.beta_start >= 0) eo.beta_start = std::min(o.beta_start, eo.beta_end);
  if (o.log_eps >= 0) eo.log_eps = o.log_eps;
  eo.keep_orientation = o.keep_orientation;
  eo.gamma_ramp = o.gamma_ramp;
  eo.safe_projection = !o.plain_projection;
  if (o.inner_iterations >= 0) eo.inner_max_iterations = o.inner_iterations;
  if (o.inner_f_tol >= 0) eo.inner_f_tol = o.inner_f_tol;
  if (o.ramp_inner_f_tol >= 0) eo.inner_f_tol_ramp = o.ramp_inner_f_tol;
  eo.progress = make_progress(g);
  const ElasticResult r = elastic_correspondence(A, B, initAB, initBA, eo);
  if (!r.map_AB.bary.allFinite() || !r.Y.allFinite())
    throw Error("elastic: non-finite result");  // guarded inside; never expected

  // Metrics of the initial and the final maps (Sec. 6.1).
  timer.start("metrics");
  nlohmann::json report = report_header(g, "surface-map");
  report["method"] = "elastic";
  report["inputs"] = {{"A", args.A}, {"B", args.B}, {"A_vertices", inA.num_vertices()},
                      {"A_faces", inA.num_faces()}, {"B_vertices", inB.num_vertices()},
                      {"B_faces", inB.num_faces()}};
  report["inputs"]["repairs"] = repairs_json(rA, rB);
  if (has_truth) report["inputs"]["truth"] = o.truth_ab;
  if (!args.landmarks.empty()) report["inputs"]["landmarks"] = args.landmarks;
  report["init"] = init_kind;
  report["parameters"] = {{"model", bij ? "bijective (Eq. 6)" : "injective (Eq. 4)"},
                          {"alpha", eo.alpha}, {"eta", eo.eta}, {"eta_choice", eta_choice},
                          {"lambda", eo.lambda},
                          {"mu", eo.mu}, {"log_eps", eo.log_eps},
                          {"beta_start", eo.beta_start}, {"beta_end", eo.beta_end},
                          {"beta_ramp_iterations", eo.beta_ramp_iterations},
                          {"gamma", bij ? eo.gamma : 0.0},
                          {"max_outer_iterations", eo.max_outer_iterations},
                          {"energy_tol", eo.energy_tol},
                          {"inner_max_iterations", eo.inner_max_iterations},
                          {"inner_tol", eo.inner_tol}, {"inner_f_tol", eo.inner_f_tol},
                          {"inner_f_tol_ramp", eo.inner_f_tol_ramp},
                          {"unit_area", eo.normalize_area},
                          {"keep_orientation", eo.keep_orientation}, {"gamma_ramp", eo.gamma_ramp},
                          {"safe_projection", eo.safe_projection}};
  // Energies per outer iteration, summarized: first, last, and at most 50 samples.
  nlohmann::json en;
  std::vector<double> E, ep, ed;
  for (const auto& it : r.history) {
    E.push_back(it.energy);
    ep.push_back(it.time_projection);
    ed.push_back(it.time_deformation);
  }
  if (!r.history.empty()) {
    const auto& f = r.history.front();
    const auto& l = r.history.back();
    en["first"] = {{"energy", f.energy}, {"deformation", f.deformation}, {"mismatch", f.mismatch},
                   {"reversibility", f.reversibility}, {"beta", f.beta}};
    en["last"] = {{"energy", l.energy}, {"deformation", l.deformation}, {"mismatch", l.mismatch},
                  {"reversibility", l.reversibility}, {"beta", l.beta}};
    const int stride = std::max<int>(1, int(E.size() + 49) / 50);
    nlohmann::json samples = nlohmann::json::array();
    for (size_t k = 0; k < E.size(); k += stride) samples.push_back({{"iteration", k}, {"energy", E[k]}});
    en["samples"] = samples;
  }
  report["energies"] = en;
  const int K = std::max(1, r.outer_iterations);
  double inner_it = 0, inner_ev = 0;
  for (const auto& it : r.history) {
    inner_it += it.inner_iterations;
    inner_ev += it.inner_evaluations;
  }
  report["elastic"] = {{"outer_iterations", r.outer_iterations}, {"converged", r.converged},
                       {"inner_iterations_per_outer", inner_it / K},
                       {"evaluations_per_outer", inner_ev / K},
                       {"time_setup", r.time_setup},
                       {"time_total", r.time_total},
                       {"time_projection", r.time_projection},
                       {"time_deformation", r.time_deformation},
                       {"time_per_iteration", (r.time_projection + r.time_deformation) / K},
                       {"time_per_iteration_projection", r.time_projection / K},
                       {"time_per_iteration_deformation", r.time_deformation / K},
                       {"degenerate_faces_initial", r.degenerate_faces_initial},
                       {"degenerate_faces_final", r.degenerate_faces_final}};
  // Issue 20: which iterate each direction returns (collapse guard), where triangles first
  // collapsed (the map P / Q or the shell Y / Y~), and the counts per outer iteration.
  auto guard_json = [&](const ElasticGuard& gd) {
    const char* what = gd.returned == ElasticReturned::Last             ? "last iterate"
                       : gd.returned == ElasticReturned::EarlierIterate ? "earlier iterate"
                                                                        : "initial map";
    return nlohmann::json{{"returned", what}, {"iteration", gd.iteration},
                          {"initial_bad_triangles", gd.initial_bad},
                          {"last_bad_triangles", gd.last_bad},
                          {"returned_bad_triangles", gd.returned_bad}};
  };
  auto event_json = [&](const ElasticCollapseEvent& ev) {
    if (ev.iteration == 0) return nlohmann::json(nullptr);
    return nlohmann::json{{"iteration", ev.iteration}, {"faces", ev.faces},
                          {"centroid", {ev.centroid(0), ev.centroid(1), ev.centroid(2)}},
                          {"mismatch_at_faces", ev.mismatch_at_faces},
                          {"mismatch_mean", ev.mismatch_mean}};
  };
  auto first_json = [&](const ElasticCollapseEvent& m, const ElasticCollapseEvent& y) {
    const int im = m.iteration, iy = y.iteration;
    const char* who = im == 0 && iy == 0 ? "none"
                      : iy == 0 || (im > 0 && im < iy) ? "map"
                      : im == 0 || iy < im ? "shell" : "both";
    return nlohmann::json{{"first", who}, {"map", event_json(m)}, {"shell", event_json(y)}};
  };
  auto folds_json = [&](auto get) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& it : r.history) {
      const FoldCounts& c = get(it);
      a.push_back({c.flipped, c.degenerate});
    }
    return a;
  };
  report["elastic"]["guard"]["enabled"] = eo.keep_no_worse;
  report["elastic"]["projection_rows_kept"] = r.projection_rows_kept;
  report["elastic"]["guard"]["AB"] = guard_json(r.guard_AB);
  report["elastic"]["first_collapse"]["AB"] = first_json(r.first_P_collapse, r.first_Y_collapse);
  report["elastic"]["folds_per_iteration"]["P"] = folds_json([](const ElasticIterate& i) -> const FoldCounts& { return i.P_folds; });
  report["elastic"]["folds_per_iteration"]["Y"] = folds_json([](const ElasticIterate& i) -> const FoldCounts& { return i.Y_folds; });
  if (bij) {
    report["elastic"]["guard"]["BA"] = guard_json(r.guard_BA);
    report["elastic"]["first_collapse"]["BA"] = first_json(r.first_Q_collapse, r.first_Yt_collapse);
    report["elastic"]["folds_per_iteration"]["Q"] = folds_json([](const ElasticIterate& i) -> const FoldCounts& { return i.Q_folds; });
    report["elastic"]["folds_per_iteration"]["Yt"] = folds_json([](const ElasticIterate& i) -> const FoldCounts& { return i.Yt_folds; });
  }
  report["elastic"]["folds_per_iteration"]["format"] = "[flipped, collapsed] after each outer iteration";
  nlohmann::json metrics;
  metrics["initial"]["AB"] = surface_map_metrics_json(A, B, initAB, bij ? &initBA : nullptr,
                                             has_truth ? &truth : nullptr);
  Eigen::VectorXd error_AB;  // per vertex of A, with --truth (report.html)
  metrics["final"]["AB"] = surface_map_metrics_json(A, B, r.map_AB, bij ? &r.map_BA : nullptr,
                                           has_truth ? &truth : nullptr, &error_AB);
  if (bij) {
    metrics["initial"]["BA"] = surface_map_metrics_json(B, A, initBA, &initAB, nullptr);
    metrics["final"]["BA"] = surface_map_metrics_json(B, A, r.map_BA, &r.map_AB, nullptr);
  }
  // The last iterate too when the guard returned another map (what the guard avoided).
  if (r.last_AB.size() > 0)
    metrics["last_iterate"]["AB"] = surface_map_metrics_json(A, B, r.last_AB, nullptr, has_truth ? &truth : nullptr);
  if (bij && r.last_BA.size() > 0)
    metrics["last_iterate"]["BA"] = surface_map_metrics_json(B, A, r.last_BA, nullptr, nullptr);
  report["metrics"] = metrics;
  // Per stage (initial map -> elastic), per direction: did the map improve? Improved = no more
  // flipped or collapsed triangles and a lower mean conformal distortion (and, with --truth,
  // no larger geodesic error).
  auto bad = [&](const char* when, const char* dir) {
    const nlohmann::json& m = metrics[when][dir];
    return m["flipped_triangles"].get<int>() + m["degenerate_triangles"].get<int>();
  };
  for (const char* dir : {"AB", "BA"}) {
    if (!metrics["final"].contains(dir)) continue;
    const nlohmann::json &mi = metrics["initial"][dir], &mf = metrics["final"][dir];
    bool improved = bad("final", dir) <= bad("initial", dir) &&
                    mf["conformal_distortion_mean"].get<double>() < mi["conformal_distortion_mean"].get<double>();
    if (mf.contains("geodesic_error_mean"))
      improved = improved && mf["geodesic_error_mean"].get<double>() <= mi["geodesic_error_mean"].get<double>();
    const ElasticGuard& gd = std::string(dir) == "AB" ? r.guard_AB : r.guard_BA;
    report["stages"]["elastic"][dir] = {
        {"improved", improved},
        {"bad_triangles", {{"initial", bad("initial", dir)}, {"final", bad("final", dir)}}},
        {"conformal_distortion_mean", {{"initial", mi["conformal_distortion_mean"]}, {"final", mf["conformal_distortion_mean"]}}},
        {"returned", guard_json(gd)["returned"]}};
  }

  // Outputs.
  timer.start("write");
  // In the user's numbering (map_to_inputs is the identity when nothing was repaired).
  const BarycentricMap mAB = map_to_inputs(r.map_AB, rA, rB, inB);
  write_map(out.path("map_AB.txt"), mAB);
  write_surface(out.path("A_on_B.obj"), TriMesh{map_positions(mAB, inB.V, inB.F), inA.F});
  if (bij) {
    const BarycentricMap mBA = map_to_inputs(r.map_BA, rB, rA, inA);
    write_map(out.path("map_BA.txt"), mBA);
    write_surface(out.path("B_on_A.obj"), TriMesh{map_positions(mBA, inA.V, inA.F), inB.F});
  }
  timer.start("pictures");
  const auto figures = surface_map_figures(A, B, r.map_AB, bij ? &r.map_BA : nullptr);
  const ViewerData viewer =
      surface_map_viewer_data(A, B, r.map_AB, bij ? &r.map_BA : nullptr, landmarks_A, landmarks_B, &error_AB);
  timer.stop();
  report["timings"] = timer.json();
  write_reports(out, report, "shapemap surface-map --method elastic", figures, &viewer, &g);
  out.commit();
  info(g, "elastic: " + std::to_string(r.outer_iterations) + " outer iterations, " +
              std::to_string(timer.total()) + " s; wrote " + out.final_path());
  // The energy can go down while the maps get worse where the deformation Y does not reach
  // the target (thin parts, far-from-isometric pairs): the projections P, Q then fold or
  // collapse triangles. The collapse guard (ElasticOptions::keep_no_worse) then returns an
  // earlier iterate or the initial map; say which.
  for (const char* dir : {"AB", "BA"}) {
    if (!metrics["final"].contains(dir)) continue;
    const ElasticGuard& gd = std::string(dir) == "AB" ? r.guard_AB : r.guard_BA;
    if (gd.last_bad <= gd.initial_bad) continue;
    const std::string head = std::string("elastic: the last ") + dir + " iterate has " +
                             std::to_string(gd.last_bad) + " flipped or collapsed triangles against " +
                             std::to_string(gd.initial_bad) + " in the initial map; ";
    if (gd.returned == ElasticReturned::EarlierIterate)
      info(g, head + "returning outer iteration " + std::to_string(gd.iteration) + " instead (" +
                  std::to_string(gd.returned_bad) + "; report.json: elastic.guard)");
    else if (gd.returned == ElasticReturned::Initial)
      info(g, head + "returning the initial map instead (report.json: elastic.guard)");
    else
      info(g, "elastic: warning: " + head.substr(std::string("elastic: ").size()) + "returned anyway (--elastic-keep-worse); a different bending weight "
                  "(--elastic-eta, --elastic-preset) or a better initial map may help");
  }
  return 0;
}

}  // namespace shapemap::cli
