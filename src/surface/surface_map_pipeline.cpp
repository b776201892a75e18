// The surface-map command as one library call (shapemap/surface/surface_map_pipeline.h).
#include "shapemap/surface/surface_map_pipeline.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/eval/surface_metrics.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/surface/elastic.h"
#include "shapemap/surface/refine_surface_maps.h"
#include "shapemap/surface/untangle.h"
#include <algorithm>
#include <chrono>

namespace shapemap {

BarycentricMap invert_surface_map(const BarycentricMap& P, const TriMesh& A, const TriMesh& B) {
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

namespace {

// The input guard of both methods: closed, manifold, connected, genus 0 (on a copy: the
// maps refer to the faces as given); zero-area faces and coincident vertices pass with a note.
void check_input(const TriMesh& mesh, const std::string& name, int min_vertices, std::vector<std::string>& notes) {
  TriMesh copy = mesh;
  require_genus0_surface(copy, name, min_vertices);
  const MeshReport r = check_surface(mesh);
  if (r.degenerate_elements > 0 || r.duplicate_vertices > 0)
    notes.push_back(name + ": note: " + std::to_string(r.degenerate_elements) + " zero-area faces and " +
                    std::to_string(r.duplicate_vertices) +
                    " vertices at the position of another; the map is unreliable near them (shapemap check " +
                    name + " lists the problems)");
}

// Repairs, checks, landmarks and the truth carried to the repaired surfaces.
void prepare(const TriMesh& A, const TriMesh& B, const SurfaceMapRequest& req, SurfaceMapRun& run,
             BarycentricMap& truth) {
  SurfaceRepairOptions ro;
  ro.strict = req.strict;
  run.repair_A = req.prepared_A ? req.prepared_A->repair : repair_surface(A, req.bim.name_A, ro);
  run.repair_B = req.prepared_B ? req.prepared_B->repair : repair_surface(B, req.bim.name_B, ro);
  for (const auto* r : {&run.repair_A, &run.repair_B})
    run.notes.insert(run.notes.end(), r->notes.begin(), r->notes.end());
  check_input(run.repair_A.mesh, req.bim.name_A, req.bim.min_vertices, run.notes);
  check_input(run.repair_B.mesh, req.bim.name_B, req.bim.min_vertices, run.notes);
  if (req.bim.landmarks_A.size() != req.bim.landmarks_B.size())
    throw InputError(req.bim.name_B + ": " + std::to_string(req.bim.landmarks_B.size()) + " landmarks but " +
                     req.bim.name_A + " has " + std::to_string(req.bim.landmarks_A.size()));
  for (int v : req.bim.landmarks_A)
    if (v < 0 || v >= A.num_vertices())
      throw InputError(req.bim.name_A + ": landmark " + std::to_string(v) + " is not a vertex");
  for (int v : req.bim.landmarks_B)
    if (v < 0 || v >= B.num_vertices())
      throw InputError(req.bim.name_B + ": landmark " + std::to_string(v) + " is not a vertex");
  for (int v : req.bim.landmarks_A) run.landmarks_A.push_back(repaired_vertex(run.repair_A, v));
  for (int v : req.bim.landmarks_B) run.landmarks_B.push_back(repaired_vertex(run.repair_B, v));
  if (req.truth_AB.size() > 0) {
    validate_map(req.truth_AB, A.num_vertices(), B.num_faces(), 3, "truth");
    truth = map_to_repaired(req.truth_AB, run.repair_A, run.repair_B, B);
  }
  run.report["inputs"] = {{"A_vertices", A.num_vertices()}, {"A_faces", A.num_faces()},
                          {"B_vertices", B.num_vertices()}, {"B_faces", B.num_faces()}};
  nlohmann::json rep = nlohmann::json::array();
  for (const auto* r : {&run.repair_A, &run.repair_B})
    for (const std::string& n : r->notes) rep.push_back(n);
  run.report["inputs"]["repairs"] = rep;
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
  const auto& ms = r.matching_search;
  if (ms.ran)
    j["matching_search"] = {{"start_confidence", ms.start_confidence}, {"final_confidence", ms.final_confidence},
                            {"changes", ms.changes}, {"evaluations", ms.evaluations}, {"kept", ms.kept},
                            {"work", ms.work}, {"over_budget", ms.over_budget}};
  nlohmann::json sel = nlohmann::json::array();
  for (auto& m : r.selected)
    sel.push_back({{"candidate", m.index},
                   {"source_vertices", m.source},
                   {"target_vertices", m.target},
                   {"confidence", m.integrated_confidence}});
  j["selected_maps"] = sel;
  return j;
}

bool prepared_fits(const PreparedSurface* p, const BIMOptions& o) {
  return p && p->bim && p->options.seed == o.seed && p->options.max_features == o.max_features &&
         p->options.num_even == o.num_even && p->options.min_vertices == o.min_vertices;
}

// BIM on the request's prepared surfaces when they fit the options, else (or when the prepared
// surfaces give no candidate map) prepared here, with blended_intrinsic_maps' seed retries.
BIMResult bim_with_retries(const TriMesh& RA, const TriMesh& RB, const SurfaceMapRequest& req, const BIMOptions& o,
                           bool use_prepared, const ProgressCallback& progress, std::vector<std::string>& notes) {
  if (use_prepared && prepared_fits(req.prepared_A.get(), o) && prepared_fits(req.prepared_B.get(), o)) {
    try {
      BIMResult r = bim_prepared(*req.prepared_A->bim, *req.prepared_B->bim, o, progress);
      r.seed = o.seed;
      return r;
    } catch (const NoCandidateMaps&) {
    }
  }
  BIMResult r = blended_intrinsic_maps(RA, RB, o, progress);
  if (r.seed_retries > 0)
    notes.push_back("BIM: no candidate map with seed " + std::to_string(o.seed) + " (feature points coincide on the "
                    "flattened sphere); seed " + std::to_string(r.seed) + " used");
  return r;
}

BIMResult bim_for_request(const TriMesh& RA, const TriMesh& RB, const SurfaceMapRequest& req, const BIMOptions& o,
                          bool use_prepared, const ProgressCallback& progress, std::vector<std::string>& notes) {
  BIMResult r = bim_with_retries(RA, RB, req, o, use_prepared, progress, notes);
  // Sec. 6.2 blends maps that share two correspondences without a conflict; with 3 features on
  // a surface no two maps do (each uses all three), so the map is one Moebius map. The paper's
  // glasses fail this way (Fig. 14, "long, thin parts"); so do SHREC'07's glasses 41 -> 44 here.
  auto found = [&](std::size_t a, std::size_t b) {
    return "surface-map: note: BIM found " + std::to_string(a) + " feature points on " + o.name_A + ", " +
           std::to_string(b) + " on " + o.name_B + ": ";
  };
  const std::string runs = std::to_string(r.blend_retry_runs) + (r.blend_retry_runs == 1 ? " run" : " runs");
  if (r.blend_retry_stretch_guide)
    notes.push_back(found(r.blend_retry_features_A, r.blend_retry_features_B) +
                    "no two candidate maps could be blended (Sec. 6.2), and no run again with evenly spread "
                    "samples guided by a single map's triple was more confident than the single map; so a last "
                    "run was guided by the least stretched candidate map on the spread samples (membrane energy "
                    "W_mem " + std::to_string(r.blend_retry_stretch) + " against the single map's " +
                    std::to_string(r.single_map_stretch) + "): a blend of " + std::to_string(r.AB.selected.size()) +
                    " maps (--blend-guide-maps 0 keeps the single Moebius map; docs/methods.md, \"Too few features "
                    "to blend: the stretch guide\")");
  else if (r.blend_retry_features_A > 0)
    notes.push_back(found(r.blend_retry_features_A, r.blend_retry_features_B) +
                    "no two candidate maps could be blended (Sec. 6.2), so it ran again with evenly spread "
                    "samples added up to " + std::to_string(o.blend_min_features) + " a side, guided by " +
                    (r.blend_retry_runs == 1 ? std::string("the single map's triple")
                                             : "the triples of its " + std::to_string(r.blend_retry_runs) +
                                                   " most confident single maps, one run each (that of single map " +
                                                   std::to_string(r.blend_retry_rank + 1) + " kept)") +
                    ": a blend of " + std::to_string(r.AB.selected.size()) +
                    " maps, more confident (--blend-features 0 keeps the single Moebius map)");
  else if (o.landmarks_A.empty() && r.AB.num_consistent_pairs == 0)
    notes.push_back(found(r.features_A.size(), r.features_B.size()) +
                    "no two candidate maps share two correspondences without a conflict, so the map is a "
                    "single Moebius map, not a blend (Sec. 6.2); shapes with long thin parts map poorly so, "
                    "and shapes whose few features do not correspond can come out flipped or upside down "
                    "(docs/methods.md, \"The busts: upside down\"; --landmarks may help)" +
                    (r.blend_retry_runs == 0 ? std::string()
                     : r.blend_retry_confidence > 0
                         ? "; a second run with spread samples, guided by " +
                               (r.blend_retry_runs == 1 ? std::string("its triple")
                                                        : "the triples of the " + std::to_string(r.blend_retry_runs) +
                                                              " most confident single maps") +
                               ", was less confident (" + std::to_string(r.blend_retry_confidence) + ")"
                         : "; a second run with spread samples (" + runs + ") gave no blend") +
                    (r.single_map_stretch > 0 ? "; no candidate on the spread samples less stretched than the "
                                                "single map (W_mem " + std::to_string(r.single_map_stretch) +
                                                ") gave a blend"
                                              : std::string()));
  return r;
}

void run_bim(const TriMesh& A, const TriMesh& B, const SurfaceMapRequest& req, const BarycentricMap* truth,
             const ProgressCallback& progress, SurfaceMapRun& run) {
  BIMOptions o = req.bim;
  o.symmetric = req.symmetric;
  o.landmarks_A = run.landmarks_A;
  o.landmarks_B = run.landmarks_B;
  if (!o.landmarks_A.empty() && o.landmarks_A.size() < 3)
    throw InputError(o.name_A + ": at least 3 landmarks are needed");
  const TriMesh &RA = run.repair_A.mesh, &RB = run.repair_B.mesh;
  const BIMResult r = bim_for_request(RA, RB, req, o, o.landmarks_A.empty(), progress, run.notes);
  run.AB_repaired = r.AB.map;
  if (req.symmetric) run.BA_repaired = r.BA.map;
  nlohmann::json& j = run.report;
  j["method"] = "bim";
  j["parameters"] = {{"max_features", o.max_features},     {"num_even", o.num_even},
                     {"max_candidates", o.max_candidates}, {"candidate_pool", o.candidate_pool},
                     {"implied_radius", o.implied_radius},  {"sigma", o.sigma},
                     {"matching_search", o.matching_search_sweeps},
                     {"eigenvalue_fraction", o.eigenvalue_fraction},
                     {"entry_fraction", o.entry_fraction}, {"feature_radius", o.feature_radius},
                     {"min_features", o.min_features},     {"blend_min_features", o.blend_min_features},
                     {"blend_agreement", o.blend_agreement}, {"blend_triples", o.blend_retry_triples},
                     {"blend_guide_maps", o.blend_guide_maps},
                     {"symmetric", o.symmetric}, {"reverse_candidates", o.reverse_candidates}};
  // BIM's own output (Sec. 5): candidates, consistency spectrum, selected maps, stages.
  nlohmann::json bim;
  bim["features_A"] = r.features_A;
  bim["features_B"] = r.features_B;
  bim["seed"] = r.seed;
  bim["seed_retries"] = r.seed_retries;  // > 0: no candidate map with the given seed
  if (r.blend_retry_runs > 0)  // none of the first features' maps could be blended: the second runs
    bim["blend_retry"] = {{"kept", r.blend_retry_features_A > 0}, {"confidence", r.blend_retry_confidence},
                          {"features_A", r.blend_retry_features_A}, {"features_B", r.blend_retry_features_B},
                          {"runs", r.blend_retry_runs}, {"guided_by_rank", r.blend_retry_rank},
                          {"stretch_guide", r.blend_retry_stretch_guide}};
  if (r.single_map_stretch > 0)  // BIMOptions::blend_guide_maps: W_mem chose between the maps
    bim["blend_retry"].update({{"single_map_stretch", r.single_map_stretch}, {"stretch", r.blend_retry_stretch}});
  bim["AB"] = direction_json(r.AB);
  if (req.symmetric) bim["BA"] = direction_json(r.BA);
  nlohmann::json stages = nlohmann::json::object();
  for (auto& [name, s] : r.timings) stages[name] = s;
  bim["stages"] = stages;
  bim["total_seconds"] = r.total_seconds;
  j["bim"] = bim;
  const BarycentricMap* BA = req.symmetric ? &run.BA_repaired : nullptr;
  j["metrics"]["AB"] = surface_map_metrics_json(RA, RB, run.AB_repaired, BA, truth, &run.error_AB);
  if (BA) j["metrics"]["BA"] = surface_map_metrics_json(RB, RA, *BA, &run.AB_repaired, nullptr);
  run.summary = "surface-map: integrated confidence " + std::to_string(r.AB.integrated_confidence) + ", " +
                std::to_string(r.AB.selected.size()) + " blended maps of " + std::to_string(r.AB.num_candidates) +
                " candidates";
}

// Before stage 0 of refine_surface_maps.h: the initial maps' collapsed parts re-extended.
nlohmann::json collapsed_parts_json(const SurfaceRefinement& ref, const SurfaceRefinementOptions& ro, bool bij) {
  auto one = [](const CollapsedPartResult& c) {
    return nlohmann::json{{"regions", c.regions}, {"vertices", c.vertices},
                          {"degenerate_faces", c.degenerate_faces}, {"seconds", c.seconds}};
  };
  nlohmann::json j = {{"enabled", ro.reextend_collapsed},
                      {"stretch_limit", ro.collapsed_parts.stretch_limit},
                      {"min_area", ro.collapsed_parts.min_area}};
  if (ro.reextend_collapsed) {
    j["AB"] = one(ref.collapsed_AB);
    if (bij) j["BA"] = one(ref.collapsed_BA);
  }
  return j;
}

// The initial maps of the elastic method, on the repaired surfaces. q_given: false when
// B -> A was made here from A -> B (not an initial map of the user's).
std::string elastic_initial_maps(const TriMesh& A, const TriMesh& B, const SurfaceMapRequest& req,
                                 const ProgressCallback& progress, SurfaceMapRun& run, BarycentricMap& initAB,
                                 BarycentricMap& initBA, bool& q_given) {
  const TriMesh &RA = run.repair_A.mesh, &RB = run.repair_B.mesh;
  q_given = true;
  if (!run.landmarks_A.empty()) {
    if (req.init_AB.size() > 0) throw InputError("elastic: give landmarks or an initial map, not both");
    BIMOptions bo = req.bim;
    landmark_initial_maps(RA, RB, run.landmarks_A, run.landmarks_B, initAB, initBA, &bo);
    return bim_landmark_guided(bo, int(run.landmarks_A.size())) ? "landmarks (BIM guided by landmarks)"
                                                                 : "landmarks (BIM over landmark triplets)";
  }
  if (req.init_AB.size() == 0) {
    BIMOptions bo = req.bim;
    bo.landmarks_A.clear();
    bo.landmarks_B.clear();
    bo.symmetric = true;
    run.notes.push_back("elastic: initial maps by BIM (both directions)");
    const BIMResult r = bim_for_request(RA, RB, req, bo, true, progress, run.notes);
    initAB = r.AB.map;
    initBA = r.BA.map;
    return "bim";
  }
  validate_map(req.init_AB, A.num_vertices(), B.num_faces(), 3,
               req.init_description.empty() ? "init AB" : req.init_description);
  initAB = map_to_repaired(req.init_AB, run.repair_A, run.repair_B, B);
  if (req.init_BA.size() > 0) {
    validate_map(req.init_BA, B.num_vertices(), A.num_faces(), 3, "init BA");
    initBA = map_to_repaired(req.init_BA, run.repair_B, run.repair_A, A);
    return req.init_description.empty() ? "given maps" : req.init_description;
  }
  initBA = invert_surface_map(initAB, RA, RB);
  q_given = false;
  return (req.init_description.empty() ? std::string("given map") : req.init_description) +
         " (B->A by closest point on the mapped surface)";
}

nlohmann::json elastic_parameters_json(const ElasticOptions& eo, const std::string& eta_choice) {
  const bool bij = eo.model == ElasticModel::Bijective;
  return {{"model", bij ? "bijective (Eq. 6)" : "injective (Eq. 4)"},
          {"alpha", eo.alpha}, {"eta", eo.eta}, {"eta_choice", eta_choice},
          {"lambda", eo.lambda}, {"mu", eo.mu}, {"log_eps", eo.log_eps},
          {"beta_start", eo.beta_start}, {"beta_end", eo.beta_end},
          {"beta_ramp_iterations", eo.beta_ramp_iterations},
          {"gamma", bij ? eo.gamma : 0.0},
          {"max_outer_iterations", eo.max_outer_iterations},
          {"energy_tol", eo.energy_tol},
          {"inner_max_iterations", eo.inner_max_iterations},
          {"inner_tol", eo.inner_tol}, {"inner_f_tol", eo.inner_f_tol},
          {"inner_f_tol_ramp", eo.inner_f_tol_ramp},
          {"precondition_stiffness", eo.precondition_stiffness},
          {"inner_f_tol_start", eo.inner_f_tol_start},
          {"inner_f_tol_start_iterations", eo.inner_f_tol_start_iterations},
          {"inner_f_tol_start_min_folds", eo.inner_f_tol_start_min_folds},
          {"mask_tol", eo.mask_tol},
          {"interpolate_initial_step", eo.interpolate_initial_step},
          {"unit_area", eo.normalize_area},
          {"keep_orientation", eo.keep_orientation}, {"gamma_ramp", eo.gamma_ramp},
          {"safe_projection", eo.safe_projection}, {"safe_projection_in_ramp", eo.safe_projection_in_ramp}};
}

// Energies per outer iteration, summarized: first, last, and at most 50 samples.
nlohmann::json elastic_energies_json(const ElasticResult& r) {
  nlohmann::json en;
  std::vector<double> E;
  for (const auto& it : r.history) E.push_back(it.energy);
  if (r.history.empty()) return en;
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
  return en;
}

nlohmann::json guard_json(const ElasticGuard& gd) {
  const char* what = gd.returned == ElasticReturned::Last             ? "last iterate"
                     : gd.returned == ElasticReturned::EarlierIterate ? "earlier iterate"
                                                                      : "initial map";
  return nlohmann::json{{"returned", what}, {"iteration", gd.iteration},
                        {"initial_bad_triangles", gd.initial_bad},
                        {"last_bad_triangles", gd.last_bad},
                        {"returned_bad_triangles", gd.returned_bad}};
}

nlohmann::json event_json(const ElasticCollapseEvent& ev) {
  if (ev.iteration == 0) return nlohmann::json(nullptr);
  return nlohmann::json{{"iteration", ev.iteration}, {"faces", ev.faces},
                        {"centroid", {ev.centroid(0), ev.centroid(1), ev.centroid(2)}},
                        {"mismatch_at_faces", ev.mismatch_at_faces},
                        {"mismatch_mean", ev.mismatch_mean}};
}

nlohmann::json first_collapse_json(const ElasticCollapseEvent& m, const ElasticCollapseEvent& y) {
  const int im = m.iteration, iy = y.iteration;
  const char* who = im == 0 && iy == 0 ? "none"
                    : iy == 0 || (im > 0 && im < iy) ? "map"
                    : im == 0 || iy < im ? "shell" : "both";
  return nlohmann::json{{"first", who}, {"map", event_json(m)}, {"shell", event_json(y)}};
}

template <class Get>
nlohmann::json folds_json(const ElasticResult& r, Get get) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& it : r.history) {
    const FoldCounts& c = get(it);
    a.push_back({c.flipped, c.degenerate});
  }
  return a;
}

// report.json "elastic": iterations, timings, and (issue 20) the collapse guard per direction.
nlohmann::json elastic_section_json(const ElasticResult& r, const ElasticOptions& eo, bool bij) {
  const int K = std::max(1, r.outer_iterations);
  double inner_it = 0, inner_ev = 0;
  for (const auto& it : r.history) {
    inner_it += it.inner_iterations;
    inner_ev += it.inner_evaluations;
  }
  nlohmann::json e = {{"outer_iterations", r.outer_iterations}, {"converged", r.converged},
                      {"inner_iterations_per_outer", inner_it / K}, {"evaluations_per_outer", inner_ev / K},
                      {"time_setup", r.time_setup}, {"time_total", r.time_total},
                      {"time_projection", r.time_projection}, {"time_deformation", r.time_deformation},
                      {"time_per_iteration", (r.time_projection + r.time_deformation) / K},
                      {"time_per_iteration_projection", r.time_projection / K},
                      {"time_per_iteration_deformation", r.time_deformation / K},
                      {"degenerate_faces_initial", r.degenerate_faces_initial},
                      {"degenerate_faces_final", r.degenerate_faces_final},
                      {"initial_fold_fraction", r.initial_fold_fraction}, {"tight_start", r.tight_start},
                      {"sliver_mask_steps", r.sliver_mask_steps}};
  using It = ElasticIterate;
  e["guard"]["enabled"] = eo.keep_no_worse;
  e["projection_rows_kept"] = r.projection_rows_kept;
  e["guard"]["AB"] = guard_json(r.guard_AB);
  e["first_collapse"]["AB"] = first_collapse_json(r.first_P_collapse, r.first_Y_collapse);
  e["folds_per_iteration"]["P"] = folds_json(r, [](const It& i) -> const FoldCounts& { return i.P_folds; });
  e["folds_per_iteration"]["Y"] = folds_json(r, [](const It& i) -> const FoldCounts& { return i.Y_folds; });
  if (bij) {
    e["guard"]["BA"] = guard_json(r.guard_BA);
    e["first_collapse"]["BA"] = first_collapse_json(r.first_Q_collapse, r.first_Yt_collapse);
    e["folds_per_iteration"]["Q"] = folds_json(r, [](const It& i) -> const FoldCounts& { return i.Q_folds; });
    e["folds_per_iteration"]["Yt"] = folds_json(r, [](const It& i) -> const FoldCounts& { return i.Yt_folds; });
  }
  e["folds_per_iteration"]["format"] = "[flipped, collapsed] after each outer iteration";
  return e;
}

// Metrics of the initial, final and last maps (Sec. 6.1), and per direction whether the
// elastic stage improved the map: no more flipped or collapsed triangles and a lower mean
// conformal distortion (and, with a truth, no larger geodesic error).
void elastic_metrics(const TriMesh& A, const TriMesh& B, const BarycentricMap& initAB,
                     const BarycentricMap& initBA, const ElasticResult& r, bool bij, const BarycentricMap* truth,
                     SurfaceMapRun& run) {
  nlohmann::json metrics;
  metrics["initial"]["AB"] = surface_map_metrics_json(A, B, initAB, bij ? &initBA : nullptr, truth);
  metrics["final"]["AB"] = surface_map_metrics_json(A, B, r.map_AB, bij ? &r.map_BA : nullptr, truth, &run.error_AB);
  if (bij) {
    metrics["initial"]["BA"] = surface_map_metrics_json(B, A, initBA, &initAB, nullptr);
    metrics["final"]["BA"] = surface_map_metrics_json(B, A, r.map_BA, &r.map_AB, nullptr);
  }
  if (r.last_AB.size() > 0) metrics["last_iterate"]["AB"] = surface_map_metrics_json(A, B, r.last_AB, nullptr, truth);
  if (bij && r.last_BA.size() > 0)
    metrics["last_iterate"]["BA"] = surface_map_metrics_json(B, A, r.last_BA, nullptr, nullptr);
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
    run.report["stages"]["elastic"][dir] = {
        {"improved", improved},
        {"bad_triangles", {{"initial", bad("initial", dir)}, {"final", bad("final", dir)}}},
        {"conformal_distortion_mean",
         {{"initial", mi["conformal_distortion_mean"]}, {"final", mf["conformal_distortion_mean"]}}},
        {"returned", guard_json(gd)["returned"]}};
  }
  run.report["metrics"] = metrics;
}

// The collapse guard's choice per direction, when the last iterate was worse than the start
// (ref.guard_revised: judged again after the untangling, SurfaceRefinementOptions::guard_untangled).
void guard_warnings(const SurfaceRefinement& ref, bool bij, SurfaceMapRun& run) {
  const ElasticResult& r = ref.elastic;
  for (const char* dir : {"AB", "BA"}) {
    if (std::string(dir) == "BA" && !bij) continue;
    const ElasticGuard& gd = std::string(dir) == "AB" ? r.guard_AB : r.guard_BA;
    if (gd.last_bad <= gd.initial_bad) continue;
    const std::string head = std::string("the last ") + dir + " iterate has " + std::to_string(gd.last_bad) +
                             " flipped or collapsed triangles against " + std::to_string(gd.initial_bad) +
                             " in the initial map; ";
    if (ref.guard_revised) {
      const FoldCounts& f = std::string(dir) == "AB" ? ref.untangling.final_AB : ref.untangling.final_BA;
      run.warnings.push_back("elastic: " + head + "untangled it has " + std::to_string(f.bad()) +
                             ": returned (report.json: elastic.guard)");
    } else if (gd.returned == ElasticReturned::EarlierIterate)
      run.warnings.push_back("elastic: " + head + "returning outer iteration " + std::to_string(gd.iteration) +
                             " instead (" + std::to_string(gd.returned_bad) + "; report.json: elastic.guard)");
    else if (gd.returned == ElasticReturned::Initial)
      run.warnings.push_back("elastic: " + head + "returning the initial map instead (report.json: elastic.guard)");
    else
      run.warnings.push_back("elastic: warning: " + head +
                             "returned anyway (--elastic-keep-worse); a different bending weight "
                             "(--elastic-eta, --elastic-preset) or a better initial map may help");
  }
}

// report.json "elastic.untangle.AB" (and BA, wide.AB, wide.BA): one untangling pass of one map.
nlohmann::json untangle_json_of(const UntangleResult& u) {
  return nlohmann::json{{"bad_triangles_before", u.before.bad()}, {"flipped_before", u.before.flipped},
                        {"collapsed_before", u.before.degenerate}, {"bad_triangles_after", u.after.bad()},
                        {"flipped_after", u.after.flipped}, {"collapsed_after", u.after.degenerate},
                        {"slivers_before", u.slivers_before}, {"slivers_after", u.slivers_after},
                        {"regions", u.regions}, {"regions_kept", u.regions_kept},
                        {"vertices_moved", u.vertices_moved}, {"seconds", u.seconds}};
}

void run_elastic(const TriMesh& A, const TriMesh& B, const SurfaceMapRequest& req, const BarycentricMap* truth,
                 const ProgressCallback& progress, SurfaceMapRun& run) {
  const bool bij = !req.elastic.injective;
  if (req.symmetric && !bij)
    throw InputError("--symmetric: the injective model (--elastic-injective, Eq. 4) maps A -> B only");
  const TriMesh &RA = run.repair_A.mesh, &RB = run.repair_B.mesh;
  BarycentricMap initAB, initBA;
  bool q_given = true;
  const std::string init_kind = elastic_initial_maps(A, B, req, progress, run, initAB, initBA, q_given);
  std::string eta_choice;
  ElasticOptions eo = elastic_options_from_settings(req.elastic, RA, RB, initAB, initBA, q_given, eta_choice);
  eo.progress = progress;
  SurfaceRefinementOptions ro;
  ro.elastic = eo;
  set_refinement_stages(req.elastic, ro);
  if (!run.landmarks_A.empty() && req.elastic.feature_anchors && bij) {  // the user's landmarks anchor
    ro.elastic.anchors.A = run.landmarks_A;
    ro.elastic.anchors.B = run.landmarks_B;
  }
  const SurfaceRefinement ref = refine_surface_maps(RA, RB, initAB, initBA, ro);
  const ElasticResult& r = ref.elastic;
  nlohmann::json anchors_json = {{"enabled", ro.feature_anchors && bij},
                                 {"source", run.landmarks_A.empty() ? "features" : "landmarks"},
                                 {"weight", ro.elastic.anchors.weight},
                                 {"activation", ro.elastic.anchors.activation}, {"count", ref.anchors.A.size()},
                                 {"holding", {{"AB", ref.elastic.anchors_holding_AB},
                                              {"BA", ref.elastic.anchors_holding_BA}}},
                                 {"released_after_ramp", ref.elastic.anchors_released},
                                 {"A", ref.anchors.A}, {"B", ref.anchors.B}, {"distance", ref.anchors.distance},
                                 {"features_A", ref.anchors.features_A}, {"features_B", ref.anchors.features_B},
                                 {"seconds", ref.anchor_seconds}};
  nlohmann::json untangle_json = nlohmann::json{{"enabled", ref.untangled}};
  if (ref.untangled) {
    const SurfaceUntangling& u = ref.untangling;
    untangle_json["passes"] = u.passes;  // stages 2-4 repeated while the folds fell
    untangle_json["AB"] = untangle_json_of(u.AB);
    if (bij) untangle_json["BA"] = untangle_json_of(u.BA);
    // stage 3 (refine_surface_maps.h): the same over wide regions, for what stage 2 left
    untangle_json["wide"]["enabled"] = u.wide;
    if (u.wide) {
      untangle_json["wide"]["AB"] = untangle_json_of(u.wide_AB);
      if (bij) untangle_json["wide"]["BA"] = untangle_json_of(u.wide_BA);
    }
    // stage 4: regions around slivers (mapped triangles squashed nearly flat)
    untangle_json["slivers"]["enabled"] = u.slivers;
    if (u.slivers) {
      untangle_json["slivers"]["AB"] = untangle_json_of(u.sliver_AB);
      if (bij) untangle_json["slivers"]["BA"] = untangle_json_of(u.sliver_BA);
    }
    // stage 5: stage 2's regions with the corners mapped across a thin part re-seated first
    untangle_json["bridges"]["enabled"] = u.bridges;
    if (u.bridges) {
      untangle_json["bridges"]["AB"] = untangle_json_of(u.bridge_AB);
      if (bij) untangle_json["bridges"]["BA"] = untangle_json_of(u.bridge_BA);
    }
    // stage 6: the corners of the folds left re-seated by a search (runs only when folds are left)
    untangle_json["search"]["enabled"] = ro.search_untangle;
    untangle_json["search"]["ran"] = u.search;
    if (u.search) {
      untangle_json["search"]["AB"] = untangle_json_of(u.search_AB);
      if (bij) untangle_json["search"]["BA"] = untangle_json_of(u.search_BA);
    }
  }
  run.AB_repaired = r.map_AB;
  if (bij) run.BA_repaired = r.map_BA;
  run.report["method"] = "elastic";
  run.report["init"] = init_kind;
  run.report["parameters"] = elastic_parameters_json(eo, eta_choice);
  run.report["energies"] = elastic_energies_json(r);
  run.report["elastic"] = elastic_section_json(r, eo, bij);
  run.report["elastic"]["untangle"] = untangle_json;
  run.report["elastic"]["anchors"] = anchors_json;  // stage 0, in the repaired meshes' numbering
  run.report["elastic"]["collapsed_parts"] = collapsed_parts_json(ref, ro, bij);  // before stage 0
  elastic_metrics(RA, RB, initAB, initBA, r, bij, truth, run);
  run.report["elastic"]["guard"]["judged_untangled"] = ro.guard_untangled;
  run.report["elastic"]["guard"]["revised"] = ref.guard_revised;
  guard_warnings(ref, bij, run);
  run.summary = "elastic: " + std::to_string(r.outer_iterations) + " outer iterations";
}

}  // namespace

void set_refinement_stages(const ElasticSettings& o, SurfaceRefinementOptions& ro) {
  ro.untangle = o.untangle;
  ro.wide_untangle = o.wide_untangle;
  ro.sliver_untangle = o.sliver_untangle;
  ro.bridge_untangle = o.bridge_untangle;
  ro.search_untangle = o.search_untangle;
  ro.untangle_passes = o.untangle_passes;
  ro.guard_untangled = !o.guard_before_untangling;
  ro.feature_anchors = o.feature_anchors;
  ro.reextend_collapsed = o.collapsed_parts;
  if (o.anchor_tolerance >= 0) ro.anchoring.tolerance = o.anchor_tolerance;
}

ElasticOptions elastic_options_from_settings(const ElasticSettings& o, const TriMesh& A, const TriMesh& B,
                                             const BarycentricMap& initAB, const BarycentricMap& initBA,
                                             bool q_given, std::string& eta_choice) {
  ElasticOptions eo;
  if (o.preset == "near-isometric") eo = ElasticOptions::near_isometric();
  else if (o.preset == "degenerate") eo = ElasticOptions::degenerate_init();
  else if (o.preset != "auto" && o.preset != "non-isometric")
    throw InputError("elastic preset " + o.preset + ": expected auto, non-isometric, near-isometric or degenerate");
  const bool bij = !o.injective;
  eta_choice = o.preset;
  if (o.eta >= 0) {
    eo.eta = o.eta;
    eta_choice = "--elastic-eta";
  } else if (o.preset == "auto") {
    // A Q made here by closest point is not an initial map of the user's: only P and a
    // given or BIM-computed Q count.
    const BendingWeightChoice c =
        bending_weight_for_initial_maps(A, B, initAB, bij && q_given ? initBA : BarycentricMap{}, eo.eta);
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
  if (o.anchor_weight >= 0) eo.anchors.weight = o.anchor_weight;
  if (o.anchor_activation >= 0) eo.anchors.activation = o.anchor_activation;
  eo.anchors.release_after_ramp = !o.anchor_hold_to_end;
  if (o.beta_start >= 0) eo.beta_start = std::min(o.beta_start, eo.beta_end);
  if (o.log_eps >= 0) eo.log_eps = o.log_eps;
  eo.keep_orientation = o.keep_orientation;
  eo.gamma_ramp = o.gamma_ramp;
  eo.safe_projection = !o.plain_projection;
  eo.safe_projection_in_ramp = !o.plain_projection_in_ramp;
  if (o.inner_iterations >= 0) eo.inner_max_iterations = o.inner_iterations;
  if (o.inner_f_tol >= 0) eo.inner_f_tol = o.inner_f_tol;
  if (o.ramp_inner_f_tol >= 0) eo.inner_f_tol_ramp = o.ramp_inner_f_tol;
  if (o.no_precondition) eo.precondition_stiffness = 0;
  if (o.start_inner_f_tol >= 0) eo.inner_f_tol_start = o.start_inner_f_tol;
  if (o.start_min_folds >= 0) eo.inner_f_tol_start_min_folds = o.start_min_folds;
  if (o.mask_tol >= 0) eo.mask_tol = o.mask_tol;
  if (o.unit_first_step) eo.interpolate_initial_step = false;
  return eo;
}

std::shared_ptr<PreparedSurface> prepare_surface(const TriMesh& mesh, const std::string& name,
                                                 const BIMOptions& opt, bool strict,
                                                 const ProgressCallback& progress) {
  auto p = std::make_shared<PreparedSurface>();
  SurfaceRepairOptions ro;
  ro.strict = strict;
  p->repair = repair_surface(mesh, name, ro);
  std::vector<std::string> notes;
  check_input(p->repair.mesh, name, opt.min_vertices, notes);
  p->options = opt;
  p->options.landmarks_A.clear();
  p->options.landmarks_B.clear();
  p->bim = std::make_shared<const BIMSurface>(bim_prepare(p->repair.mesh, name, p->options, {}, progress));
  return p;
}

SurfaceMapRun run_surface_map(const TriMesh& A, const TriMesh& B, const SurfaceMapRequest& req,
                              const ProgressCallback& progress) {
  if (req.method != "bim" && req.method != "elastic")
    throw InputError("method " + req.method + ": expected bim or elastic");
  if (req.method == "bim" && req.init_AB.size() > 0)
    throw InputError("an initial map is only used by the elastic method");
  SurfaceMapRun run;
  BarycentricMap truth;
  prepare(A, B, req, run, truth);
  const BarycentricMap* t = req.truth_AB.size() > 0 ? &truth : nullptr;
  if (req.method == "bim") run_bim(A, B, req, t, progress, run);
  else run_elastic(A, B, req, t, progress, run);
  // In the user's numbering (the identity when nothing was repaired).
  run.AB = map_to_inputs(run.AB_repaired, run.repair_A, run.repair_B, B);
  if (run.BA_repaired.size() > 0) run.BA = map_to_inputs(run.BA_repaired, run.repair_B, run.repair_A, A);
  return run;
}

}  // namespace shapemap
