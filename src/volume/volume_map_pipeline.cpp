// The volume-map command as library calls (shapemap/volume/volume_map_pipeline.h).
#include "shapemap/volume/volume_map_pipeline.h"
#include "shapemap/boundary_chords.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/io.h"
#include "shapemap/repair.h"
#include "shapemap/volume/register.h"
#include "shapemap/volume/tetrahedralize.h"
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <tuple>

namespace shapemap {

namespace {

// Safe repairs and the genus-0 guard; the notes go to `notes`.
TriMesh repaired_genus0(const TriMesh& mesh, const std::string& name, bool strict, std::vector<std::string>& notes) {
  SurfaceRepairOptions ro;
  ro.strict = strict;
  SurfaceRepair r = repair_surface(mesh, name, ro);
  require_genus0_surface(r.mesh, name);
  notes.insert(notes.end(), r.notes.begin(), r.notes.end());
  return std::move(r.mesh);
}

void check_volume_input(VolumeInput& in) {
  // Up to 1% bad tets are accepted (and said); more is the one-line error.
  require_valid_volume(in.mesh, in.name, 0.01);
  const MeshReport rep = check_volume(in.mesh);
  if (rep.inverted_elements + rep.degenerate_elements > 0)
    in.notes.push_back(in.name + ": " + std::to_string(rep.inverted_elements) + " inverted and " +
                       std::to_string(rep.degenerate_elements) + " degenerate tets of " +
                       std::to_string(rep.num_elements));
}

// The row of P nearest to x (the first of equals): a landmark's position snapped to a vertex.
int nearest_row(const Eigen::MatrixXd& P, const Eigen::RowVector3d& x) {
  int best = 0;
  (P.rowwise() - x).rowwise().squaredNorm().minCoeff(&best);
  return best;
}

}  // namespace

VolumeInput volume_input_from_tets(TetMesh mesh, const std::string& name) {
  VolumeInput in;
  in.name = name;
  in.mesh = std::move(mesh);
  check_volume_input(in);
  return in;
}

VolumeInput volume_input_from_surface(const TriMesh& given, const std::string& name, int tets,
                                      std::uint64_t seed, bool strict, const ProgressCallback& progress) {
  VolumeInput in;
  in.name = name;
  in.given = given;
  in.surface = repaired_genus0(given, name, strict, in.repairs);
  TetrahedralizeOptions to;
  to.target_tets = tets;
  to.seed = unsigned(seed);
  TetrahedralizeInfo ti;
  try {
    in.mesh = tetrahedralize(in.surface, to, progress, &ti);
  } catch (const InputError& e) {
    // The mesher names the mesh "surface"; the caller knows it by `name`.
    const std::string msg = e.what(), prefix = "surface: ";
    throw InputError(name + ": " + (msg.compare(0, prefix.size(), prefix) == 0 ? msg.substr(prefix.size()) : msg));
  }
  for (std::string& n : tetrahedralize_notes(ti, name)) in.notes.push_back(std::move(n));
  in.from_surface = true;
  check_volume_input(in);
  return in;
}

namespace {
// Whether the automatic start can map this input: the surface surface_init would give BIM
// (the repaired given surface, or the boundary after the safe repairs) is closed genus 0.
bool automatic_start_can_map(const VolumeInput& in, bool strict) {
  try {
    std::vector<std::string> unused;
    repaired_genus0(in.from_surface ? in.surface : boundary_surface(in.mesh).surface, in.name, strict, unused);
    return true;
  } catch (const InputError&) {
    return false;
  }
}
}  // namespace

bool sparse_landmark_start(std::vector<int> LA, std::vector<int> LB, const VolumeInput& A, const VolumeInput& B,
                           bool strict) {
  tidy_landmark_pairs(LA, LB, "landmarks A", "landmarks B");  // its notes come with the run
  if (LA.size() < 4) return true;
  return int(LA.size()) < kLandmarkStartMinPairs && automatic_start_can_map(A, strict) &&
         automatic_start_can_map(B, strict);
}

std::string sparse_landmark_start_note() {
  return "volume-map: note: fewer than " + std::to_string(kLandmarkStartMinPairs) +
         " distinct landmark pairs: the landmark initialization (Sec. 5.1) would put every vertex on its nearest "
         "landmark's partner, too coarse a start with so few; they guide --init auto instead (--init landmarks "
         "forces it; docs/methods.md, \"Few landmarks: the automatic start guided by them\")";
}

std::vector<int> carry_landmarks_to_volume(const VolumeInput& in, const std::vector<int>& landmarks) {
  if (!in.from_surface) return landmarks;
  const TetBoundary bd = boundary_surface(in.mesh);
  const Eigen::MatrixXd boundary_positions = in.mesh.V(bd.to_volume, Eigen::all);
  std::vector<int> out;
  for (int l : landmarks) {
    if (l < 0 || l >= in.given.num_vertices())
      throw InputError(in.name + ": landmark " + std::to_string(l) + " is not a vertex of the surface");
    // two landmarks on one tet vertex: repeats (tidy_landmark_pairs)
    out.push_back(bd.to_volume(nearest_row(boundary_positions, in.given.V.row(l))));
  }
  return out;
}

nlohmann::json volume_metrics_json(const VolumeMapMetrics& m) {
  nlohmann::json j;
  j["num_tets"] = m.num_tets;
  j["n_inv"] = m.n_inv;
  j["inverted_fraction"] = m.inverted_fraction;
  j["d_max_hat"] = m.d_max;
  j["d_avg_hat"] = m.d_avg;
  j["det_J_mean"] = m.det_mean;
  j["det_J_sd"] = m.det_sd;
  j["E_ARAP"] = m.E_arap;
  if (!std::isnan(m.E_R)) {
    j["E_R"] = m.E_R;
    j["E_R_boundary_share"] = m.E_R_boundary_share;
    j["round_trip_max_hat"] = m.round_trip_max;
    j["round_trip_avg_hat"] = m.round_trip_avg;
  }
  if (m.has_truth) {
    j["truth_error_mean"] = m.truth_mean;
    j["truth_error_max"] = m.truth_max;
  }
  return j;
}

Eigen::VectorXd tet_volume_ratios(const TetMesh& src, const Eigen::MatrixXd& X) {
  Eigen::VectorXd d(src.num_tets());
  for (int k = 0; k < src.num_tets(); ++k) {
    Eigen::Matrix3d Dm, Ds;
    for (int j = 0; j < 3; ++j) {
      Dm.col(j) = (src.V.row(src.T(k, j + 1)) - src.V.row(src.T(k, 0))).transpose();
      Ds.col(j) = (X.row(src.T(k, j + 1)) - X.row(src.T(k, 0))).transpose();
    }
    const double q = Ds.determinant() / Dm.determinant();
    d(k) = std::isfinite(q) ? q : 0.0;
  }
  return d;
}

namespace {

void landmark_init(const VolumeInput& A, const VolumeInput& B, const VolumeMapRequest& req, VolumeMapRun& run,
                   BarycentricMap& i12, BarycentricMap& i21) {
  std::vector<int> LA = req.landmarks_A, LB = req.landmarks_B;
  if (LA.empty()) throw InputError("init landmarks: no landmarks given");
  for (const std::string& n : tidy_landmark_pairs(LA, LB, A.name, B.name)) run.notes.push_back(n);
  if (LA.size() != LB.size())
    throw InputError(B.name + ": " + std::to_string(LB.size()) + " landmarks but " + A.name + " has " +
                     std::to_string(LA.size()));
  i12 = landmark_initial_map(A.mesh, B.mesh, LA, LB);
  i21 = landmark_initial_map(B.mesh, A.mesh, LB, LA);
}

// Both directions from one pair of ball maps (Sec. 7 of the isovolumetric paper):
// volume-preserving, landmark-free, no surface map needed.
void ball_init(const VolumeInput& inA, const VolumeInput& inB, const ProgressCallback& progress, VolumeMapRun& run,
               BarycentricMap& i12, BarycentricMap& i21) {
  const TetMesh &A = inA.mesh, &B = inB.mesh;
  // Both inputs are checked before either ball map is computed (every tet must be positive).
  for (const VolumeInput* in : {&inA, &inB}) {
    require_valid_volume(in->mesh, in->name + " (--init ball)", 0.0);
    require_ball_topology(in->mesh, in->name + " (--init ball)");
  }
  // The ball maps run on copies with their boundary chords split (docs/methods.md,
  // "Boundary chords"); splitting only appends vertices, so the user's vertices are the first rows.
  run.ball_mesh_A = A;
  run.ball_mesh_B = B;
  const int chords = split_boundary_chords(run.ball_mesh_A) + split_boundary_chords(run.ball_mesh_B);
  RegisterResult rr = register_through_ball(run.ball_mesh_A, run.ball_mesh_B, {}, progress, inA.name, inB.name);
  const Eigen::MatrixXd phi = rr.A_on_B.topRows(A.num_vertices());
  i12 = locate_in_tets(B, phi);
  i21 = locate_in_tets(A, rr.B_on_A.topRows(B.num_vertices()));
  // d(phi) (Sec. 7) over the user's A (rr.d_phi is over the split copy).
  const Eigen::VectorXd w = vertex_volumes(A.V, A.T);
  const double d_phi = w.dot((A.V - phi).rowwise().norm()) / w.sum();
  char d[96];
  std::snprintf(d, sizeof d, "%.4g of A's bbox diagonal; %d boundary chords split", d_phi / bbox_diagonal(A.V), chords);
  run.init_detail = std::string("ball (registration through the ball, d(phi) ") + d + ")";
  run.used_ball = true;
  run.ball_A = std::move(rr.ball_A);
  run.ball_B = std::move(rr.ball_B);
}

// The surface a given surface map lives on: the boundary surface, the repaired input
// surface or the input surface as given, whichever has its number of vertices.
TriMesh pick_surface(const VolumeInput& in, const TetBoundary& bd, int n, const std::string& file) {
  if (n == bd.surface.num_vertices()) return bd.surface;
  if (in.from_surface && n == in.surface.num_vertices()) return in.surface;
  if (in.from_surface && n == in.given.num_vertices()) return in.given;  // e.g. surface-map's output
  throw InputError(file + ": " + std::to_string(n) + " rows, but the boundary surface has " +
                   std::to_string(bd.surface.num_vertices()) + " vertices");
}

// For each of `rows` of V, the vertex of S nearest to it (landmarks carried from a tet mesh to
// its boundary surface, which the repairs may have renumbered).
std::vector<int> nearest_surface_vertices(const TriMesh& S, const Eigen::MatrixXd& V, const std::vector<int>& rows) {
  std::vector<int> out;
  for (int r : rows) out.push_back(nearest_row(S.V, V.row(r)));
  return out;
}

// Whether the start's two surface maps agree. On the real bench pairs that map well their
// mean round trip is 0.07-0.37% of the diagonal; on SHREC'07's glasses, which BIM cannot map
// (docs/methods.md, "The automatic start's two directions"), 2.2-2.7%: above 1%, a note.
constexpr double kInitRoundTripNote = 0.01;
void note_init_round_trip(const TriMesh& SA, const TriMesh& SB, const BarycentricMap& sAB, const BarycentricMap& sBA,
                          bool auto_init, VolumeMapRun& run) {
  run.init_round_trip_AB = round_trip_bbox(SA, SB, sAB, sBA).mean();
  run.init_round_trip_BA = round_trip_bbox(SB, SA, sBA, sAB).mean();
  if (std::max(run.init_round_trip_AB, run.init_round_trip_BA) <= kInitRoundTripNote) return;
  char line[480];
  std::snprintf(line, sizeof line,
                "volume-map: note: the initial surface maps disagree: a boundary point taken A -> B -> A "
                "lands %.2g%% of the diagonal away on average (B -> A -> B %.2g%%; above 1%%, the surface "
                "map is likely wrong in places and the volume map starts from it); %s",
                100 * run.init_round_trip_AB, 100 * run.init_round_trip_BA,
                auto_init ? "landmarks (--landmarks) or a surface map of the surfaces the meshes were made from "
                            "(--init surface-map) may do better"
                          : "landmarks (surface-map --landmarks, or --init landmarks) may do better");
  run.notes.push_back(line);
}

void surface_init(VolumeInput& inA, VolumeInput& inB, const VolumeMapRequest& req, const ProgressCallback& progress,
                  VolumeMapRun& run, BarycentricMap& i12, BarycentricMap& i21) {
  const TetBoundary bA = boundary_surface(inA.mesh), bB = boundary_surface(inB.mesh);
  TriMesh SA, SB;
  BarycentricMap sAB = req.surface_map_AB, sBA = req.surface_map_BA;
  if (req.init == "surface-map") {
    if (sAB.size() == 0 || sBA.size() == 0) throw InputError("init surface-map: needs both surface maps");
    if (req.surface_map_mesh_A.num_vertices() > 0) {
      SA = req.surface_map_mesh_A;
      SB = req.surface_map_mesh_B;
      // The maps refer to these meshes as given (surface-map writes them in the user's
      // numbering, also for scans it repaired): they are only evaluated and searched by
      // closest point here, so a scan with non-manifold edges is used as it is, once its
      // repaired copy is a closed genus-0 surface (--strict: once it needs no repair).
      std::vector<std::string> unused;
      repaired_genus0(SA, req.surface_map_mesh_names[0], req.strict, unused);
      repaired_genus0(SB, req.surface_map_mesh_names[1], req.strict, unused);
    } else {
      SA = pick_surface(inA, bA, sAB.size(), req.surface_map_names[0]);
      SB = pick_surface(inB, bB, sBA.size(), req.surface_map_names[1]);
    }
    validate_map(sAB, SA.num_vertices(), SB.num_faces(), 3, req.surface_map_names[0]);
    validate_map(sBA, SB.num_vertices(), SA.num_faces(), 3, req.surface_map_names[1]);
  } else {
    SA = inA.from_surface ? inA.surface : bA.surface;
    SB = inB.from_surface ? inB.surface : bB.surface;
    // Boundaries of tet meshes get the surface repairs too (tets touching along an edge make
    // a non-manifold boundary); A's boundary vertices are located on SA by closest point.
    if (!inA.from_surface) SA = repaired_genus0(SA, inA.name + " (boundary)", req.strict, inA.repairs);
    if (!inB.from_surface) SB = repaired_genus0(SB, inB.name + " (boundary)", req.strict, inB.repairs);
    // The user's landmarks (tet mesh vertices, on the boundary) guide the surface map: each
    // becomes the vertex of the (repaired) boundary surface at its position.
    std::vector<int> LA = req.landmarks_A, LB = req.landmarks_B;
    if (!LA.empty() || !LB.empty()) {
      for (const std::string& n : tidy_landmark_pairs(LA, LB, inA.name, inB.name)) run.notes.push_back(n);
      if (LA.size() < 3) throw InputError(inA.name + ": --init auto with landmarks needs at least 3");
      LA = nearest_surface_vertices(SA, inA.mesh.V, LA);
      LB = nearest_surface_vertices(SB, inB.mesh.V, LB);
    }
    std::string used;
    std::tie(sAB, sBA) =
        surface_map_for_volumes(SA, SB, progress, &used, req.auto_surface == "elastic", nullptr, LA, LB,
                                req.auto_reverse_candidates);
    run.init_detail = "auto (" + used + ")";
  }
  note_init_round_trip(SA, SB, sAB, sBA, req.init == "auto", run);
  i12 = surface_initial_map(inA.mesh, inB.mesh, SA, SB, sAB);
  i21 = surface_initial_map(inB.mesh, inA.mesh, SB, SA, sBA);
}

nlohmann::json parameters_json(const SymmetricVolumeMapOptions& o, const std::string& init_detail) {
  return {{"init", init_detail}, {"alpha", o.alpha}, {"alpha_final", o.alpha_final}, {"gamma", o.gamma},
          {"beta_start", o.beta_start}, {"beta_end", o.beta_end},
          {"beta_ramp_iterations", o.beta_ramp_iterations},
          {"gamma_start", o.gamma_start}, {"backward_projection_scale", o.backward_projection_scale},
          {"max_iterations", o.max_iterations}, {"boundary_fixed_iteration_factor", o.boundary_fixed_iteration_factor},
          {"boundary_fixed_expansions", o.boundary_fixed_expansions},
          {"solver", o.solver == XStepSolver::Lbfgs ? "lbfgs" : "newton"},
          {"newton_iterations", o.newton_iterations},
          {"newton_iterations_final", o.newton_iterations_final},
          {"newton_refactor_cg", o.newton_refactor_cg},
          {"newton_cg_rel_tol", o.newton_cg_rel_tol},
          {"boundary_fixed_stage", o.fix_boundary_first}, {"interior_init", o.harmonic_interior ? "harmonic" : "closest"}, {"land_on_target", o.land_on_target},
          {"land_gamma_rounds", o.land_gamma_rounds}, {"land_gamma_factor", o.land_gamma_factor},
          {"land_uncovered_edges", o.land_uncovered_edges},
          {"land_barrier_floor", o.land_barrier_floor}, {"land_passes", o.land_passes},
          {"land_pull_rounds", o.land_pull_rounds}, {"land_untangle_rounds", o.land_untangle_rounds},
          {"land_untangle_rings", o.land_untangle_rings}, {"land_regularized_rings", o.land_regularized_rings},
          {"land_return_rows", o.land_return_rows}, {"land_reconcile_rounds", o.land_reconcile_rounds},
          {"land_reconcile_gap", o.land_reconcile_gap},
          {"land_reconcile_det", o.land_reconcile_det},
          {"land_reconcile_arap", o.land_reconcile_arap}, {"land_interior_final", o.land_interior_final},
          {"eliminate_p", o.eliminate_p}, {"joint_xstep", o.joint_xstep},
          {"post_repair_penalty", o.post_repair_penalty.floor}, {"xstep_iterations", o.xstep_iterations},
          {"grad_tol", o.grad_tol}, {"decrease_tol", o.decrease_tol},
          {"decrease_rel_tol", o.decrease_rel_tol},
          {"repair_rings", o.repair_rings}, {"post_repair_steps", o.post_repair_steps},
          {"boundary_to_boundary", o.boundary_to_boundary}};
}

nlohmann::json stages_json(const SymmetricVolumeMapResult& r) {
  nlohmann::json stages = nlohmann::json::array();
  for (auto& s : r.stages)
    stages.push_back({{"name", s.name}, {"iterations", s.iterations}, {"seconds", s.seconds},
                      {"energy", s.energy}, {"n_inv_AB", s.inverted12}, {"n_inv_BA", s.inverted21},
                      {"seconds_P_step", s.time_pstep}, {"seconds_X_step", s.time_xstep},
                      {"solver_iterations", s.lbfgs_iterations}, {"evaluations", s.evaluations},
                      {"cg_iterations", s.cg_iterations},
                      {"factorizations", s.factorizations},
                      {"anderson_accepted", s.anderson_accepted}, {"anderson_rejected", s.anderson_rejected},
                      {"land_unprojected", s.land_unprojected}, {"land_returned", s.land_returned},
                      {"land_uncovered", s.land_uncovered}, {"land_reconciled", s.land_reconciled},
                      {"relocated_AB", s.relocated12}, {"relocated_BA", s.relocated21},
                      {"newton_seconds", {{"energy", s.newton_seconds[0]}, {"hessian", s.newton_seconds[1]},
                                          {"factor", s.newton_seconds[2]}, {"solve", s.newton_seconds[3]}}},
                      {"stop_reason", s.stop_reason}, {"energy_history", s.energy_history},
                      {"gradient_history", s.gradient_history}});
  return stages;
}

// Metrics of X and of the maps as the map files hold them: images that the free boundary
// left outside the target are snapped into it there, and more tets can invert.
void measure(const TetMesh& A, const TetMesh& B, VolumeMapRun& run) {
  const SymmetricVolumeMapResult& r = run.result;
  run.m12 = volume_map_metrics(A, B, r.X12, &r.map12, &r.X21);
  run.m21 = volume_map_metrics(B, A, r.X21, &r.map21, &r.X12);
  const Eigen::MatrixXd F12 = map_positions(r.map12, B.V, B.T), F21 = map_positions(r.map21, A.V, A.T);
  run.f12 = volume_map_metrics(A, B, F12, &r.map12, &F21);
  run.f21 = volume_map_metrics(B, A, F21, &r.map21, &F12);
  for (int i = 0; i < A.num_vertices(); ++i) run.snap12 = std::max(run.snap12, (F12.row(i) - r.X12.row(i)).norm());
  for (int i = 0; i < B.num_vertices(); ++i) run.snap21 = std::max(run.snap21, (F21.row(i) - r.X21.row(i)).norm());
}

void fill_report(const TetMesh& A, const TetMesh& B, const VolumeMapRequest& req, const SymmetricVolumeMapOptions& o,
                 VolumeMapRun& run) {
  const SymmetricVolumeMapResult& r = run.result;
  nlohmann::json& j = run.report;
  j["parameters"] = parameters_json(o, run.init_detail);
  if (run.init_round_trip_AB >= 0)
    j["init_round_trip"] = {{"definition", "initial surface maps: mean distance of a boundary vertex from its image under map_AB then map_BA (AB; BA the other way), over the bounding-box diagonal"},
                            {"AB", run.init_round_trip_AB}, {"BA", run.init_round_trip_BA}};
  j["algorithm_stages"] = stages_json(r);
  j["energy"] = {{"E", r.E}, {"E_ARAP", r.E_arap}, {"E_R", r.E_R}, {"E_P", r.E_P}, {"E_Q", r.E_Q},
                 {"outer_iterations", r.iterations}};
  j["metrics"] = {{"AB", volume_metrics_json(run.m12)}, {"BA", volume_metrics_json(run.m21)}};
  j["metrics_map_files"] = {{"AB", volume_metrics_json(run.f12)}, {"BA", volume_metrics_json(run.f21)},
                            {"max_snap_AB", run.snap12 / bbox_diagonal(B.V)},
                            {"max_snap_BA", run.snap21 / bbox_diagonal(A.V)}};
  run.summary = "volume-map: n_inv " + std::to_string(run.m12.n_inv) + " / " + std::to_string(run.m21.n_inv) +
                ", d_avg^ " + std::to_string(run.m12.d_avg) + " / " + std::to_string(run.m21.d_avg) +
                ", |det J| " + std::to_string(run.m12.det_mean) + " / " + std::to_string(run.m21.det_mean);
  if (run.f12.n_inv != run.m12.n_inv || run.f21.n_inv != run.m21.n_inv) {
    char line[320];
    std::snprintf(line, sizeof line,
                  "volume-map: note: map_AB.txt / map_BA.txt snap images left outside the target into it "
                  "(by up to %.2g / %.2g of the target's bounding-box diagonal): n_inv %d / %d there "
                  "(report.json: metrics_map_files)",
                  run.snap12 / bbox_diagonal(B.V), run.snap21 / bbox_diagonal(A.V), run.f12.n_inv, run.f21.n_inv);
    run.notes.push_back(line);
  }
}

}  // namespace

VolumeMapRun run_volume_map(VolumeInput& A, VolumeInput& B, const VolumeMapRequest& req,
                            const ProgressCallback& progress) {
  const std::string& init = req.init;
  if (init != "auto" && init != "landmarks" && init != "ball" && init != "surface-map")
    throw InputError("init " + init + ": expected auto, landmarks, ball or surface-map");
  if (req.boundary_stage != "auto" && req.boundary_stage != "on" && req.boundary_stage != "off")
    throw InputError("boundary stage " + req.boundary_stage + ": expected auto, on or off");
  if (req.interior_init != "closest" && req.interior_init != "harmonic")
    throw InputError("interior init " + req.interior_init + ": expected closest or harmonic");
  VolumeMapRun run;
  run.init_detail = init;
  BarycentricMap i12, i21;
  if (init == "landmarks") landmark_init(A, B, req, run, i12, i21);
  else if (init == "ball") ball_init(A, B, progress, run, i12, i21);
  else surface_init(A, B, req, progress, run, i12, i21);
  SymmetricVolumeMapOptions o = req.opt;
  o.fix_boundary_first = req.boundary_stage == "on" || (req.boundary_stage == "auto" && init != "landmarks");
  o.harmonic_interior = req.interior_init == "harmonic";
  run.result = symmetric_volume_map(A.mesh, B.mesh, i12, i21, o, progress);
  measure(A.mesh, B.mesh, run);
  fill_report(A.mesh, B.mesh, req, o, run);
  return run;
}

}  // namespace shapemap
