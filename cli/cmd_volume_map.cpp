// shapemap volume-map: symmetric volume maps between two tetrahedral meshes
// (symmetric-volume-maps.txt). Inputs: tet meshes (.mesh .vtk .msh .node/.ele) or closed
// genus-0 surfaces (.obj .off .ply .stl, tetrahedralized first).
//
//   shapemap volume-map A B -o OUT [--init auto|ball|landmarks|surface-map]
//                       [--landmarks LA LB] [--surface-map MAP_AB MAP_BA]
//
// Writes OUT/map_AB.txt, map_BA.txt (vertex -> target tet + barycentric), A_on_B.vtk,
// B_on_A.vtk (source connectivity, mapped positions in the target's coordinates),
// report.json (inputs, parameters, per-stage timings, Table 3 metrics per direction) and,
// for surface inputs, the tet meshes made from them (A.vtk, B.vtk), which the maps index.
#include "ball_common.h"
#include "common.h"
#include "figures.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/eval/volume_metrics.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/volume/register.h"
#include "shapemap/volume/symmetric_map.h"
#include "shapemap/volume/tetrahedralize.h"
#include "shapemap/volume/volume_map_pipeline.h"
#include <Eigen/Dense>
#include <unistd.h>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <memory>
#include <tuple>

namespace shapemap::cli {

namespace {

struct VolumeMapArgs {
  std::string A, B, out, init;
  std::vector<std::string> landmarks, surface_map, surface_map_meshes;
  int tets = 0;
  std::string auto_surface = "elastic";
  bool auto_reverse_candidates = true;
  std::string solver = "newton";
  std::string boundary_stage = "auto";
  std::string interior_init = "closest";
  SymmetricVolumeMapOptions opt;
};

// A volume input from its file: a tet mesh, or a closed surface tetrahedralized.
VolumeInput load_volume_input(const std::string& path, int tets, const ProgressCallback& progress,
                              const GlobalOptions& g) {
  VolumeInput in;
  if (is_volume_path(path)) {
    in = volume_input_from_tets(read_volume(path), path);
  } else if (is_surface_path(path)) {
    in = volume_input_from_surface(read_surface(path), path, tets, g.seed, g.strict, progress);
  } else {
    throw InputError(path + ": unknown extension (tet mesh: .mesh .vtk .msh .node .ele; "
                            "surface: .obj .off .ply .stl)");
  }
  for (const std::string& n : in.repairs) info(g, n);
  for (const std::string& n : in.notes) info(g, n);
  return in;
}

// Landmarks of a volume input, in the numbering of the file the user gave: for a tet mesh its
// vertices (x y z lines snap to the nearest boundary vertex); for a surface input its surface
// vertices, carried to the tet mesh made from it (the library's carry_landmarks_to_volume).
std::vector<int> volume_landmarks(const std::string& file, const VolumeInput& in) {
  if (in.from_surface) return carry_landmarks_to_volume(in, read_landmarks(file, in.given.V));
  const TetBoundary bd = boundary_surface(in.mesh);
  const std::vector<int> cand(bd.to_volume.data(), bd.to_volume.data() + bd.to_volume.size());
  return read_landmarks(file, in.mesh.V, cand);
}

// The initialization (--init, or its default) and the checks of the options that go with it.
std::string choose_init(const VolumeMapArgs& a) {
  std::string init = a.init;
  if (init.empty()) init = !a.landmarks.empty() ? "landmarks" : !a.surface_map.empty() ? "surface-map" : "auto";
  const std::string init_name = "--init " + init + (a.init.empty() ? " (the default)" : "");
  if (init == "landmarks" && a.landmarks.size() != 2) throw InputError("--init landmarks: needs --landmarks LA LB");
  if (init == "surface-map" && a.surface_map.size() != 2)
    throw InputError("--init surface-map: needs --surface-map MAP_AB MAP_BA");
  // Inputs of another initialization are an error, not silently ignored.
  if (!a.landmarks.empty() && init != "landmarks" && init != "auto")
    throw InputError(init_name + ": --landmarks is only used by --init landmarks and auto");
  if ((!a.surface_map.empty() || !a.surface_map_meshes.empty()) && init != "surface-map")
    throw InputError(init_name + ": --surface-map/--surface-map-meshes are only used by --init surface-map");
  return init;
}

CLI::App* add_volume_map_command(CLI::App& parent, VolumeMapArgs& a);

void write_volume_map_outputs(const OutputDir& out, const VolumeInput& inA, const VolumeInput& inB,
                              const VolumeMapRun& run) {
  const TetMesh &A = inA.mesh, &B = inB.mesh;
  const SymmetricVolumeMapResult& r = run.result;
  write_map(out.path("map_AB.txt"), r.map12);
  write_map(out.path("map_BA.txt"), r.map21);
  // Per vertex, how far it lands from itself through the other shape and back (Eq. 18's
  // integrand, in its own units): where the two maps disagree.
  write_vtk(out.path("A_on_B.vtk"), TetMesh{r.X12, A.T}, {{"round_trip", round_trip_distances(A, B, r.map12, r.X21)}},
            {{"volume_ratio", tet_volume_ratios(A, r.X12)}});
  write_vtk(out.path("B_on_A.vtk"), TetMesh{r.X21, B.T}, {{"round_trip", round_trip_distances(B, A, r.map21, r.X12)}},
            {{"volume_ratio", tet_volume_ratios(B, r.X21)}});
  // The maps index the tets we made from surface inputs: without them map_AB.txt and the
  // rest positions of A_on_B.vtk's vertices could not be read.
  if (inA.from_surface) write_volume(out.path("A.vtk"), A);
  if (inB.from_surface) write_volume(out.path("B.vtk"), B);
}

int run_volume_map_command(VolumeMapArgs& a, const GlobalOptions& g) {
  StageTimer timer;
  ProgressCallback progress = make_progress(g);
  OutputDir out(a.out);
  VolumeMapRequest req;
  req.init = choose_init(a);
  req.auto_surface = a.auto_surface;
  req.auto_reverse_candidates = a.auto_reverse_candidates;
  req.boundary_stage = a.boundary_stage;
  req.interior_init = a.interior_init;
  req.strict = g.strict;
  req.opt = a.opt;
  req.opt.solver = a.solver == "lbfgs" ? XStepSolver::Lbfgs : XStepSolver::Newton;
  // Map files are read (syntax) before the inputs, which may need tetrahedralizing first.
  if (req.init == "surface-map") {
    req.surface_map_AB = read_map(a.surface_map[0]);
    req.surface_map_BA = read_map(a.surface_map[1]);
    req.surface_map_names[0] = a.surface_map[0];
    req.surface_map_names[1] = a.surface_map[1];
  }
  timer.start("load");
  VolumeInput inA = load_volume_input(a.A, a.tets, progress, g);
  VolumeInput inB = load_volume_input(a.B, a.tets, progress, g);
  if (req.init == "landmarks" || (req.init == "auto" && !a.landmarks.empty())) {
    req.landmarks_A = volume_landmarks(a.landmarks[0], inA);
    req.landmarks_B = volume_landmarks(a.landmarks[1], inB);
    if (a.init.empty() && sparse_landmark_start(req.landmarks_A, req.landmarks_B, inA, inB, req.strict)) {
      req.init = "auto";
      info(g, sparse_landmark_start_note());
    }
  }
  if (req.init == "surface-map" && a.surface_map_meshes.size() == 2) {
    req.surface_map_mesh_A = read_surface(a.surface_map_meshes[0]);
    req.surface_map_mesh_B = read_surface(a.surface_map_meshes[1]);
    req.surface_map_mesh_names[0] = a.surface_map_meshes[0];
    req.surface_map_mesh_names[1] = a.surface_map_meshes[1];
  }
  timer.start("map");
  const size_t before[2] = {inA.repairs.size(), inB.repairs.size()};
  const VolumeMapRun run = run_volume_map(inA, inB, req, progress);
  for (int k = 0; k < 2; ++k) {  // repairs of tet-mesh boundaries (init auto)
    const VolumeInput& in = k ? inB : inA;
    for (size_t i = before[k]; i < in.repairs.size(); ++i) info(g, in.repairs[i]);
  }
  if (run.used_ball) {
    const std::pair<const TetMesh*, const BallParamResult*> balls[2] = {{&run.ball_mesh_A, &run.ball_A},
                                                                        {&run.ball_mesh_B, &run.ball_B}};
    for (int k = 0; k < 2; ++k)
      if (const std::string msg = ball_quality_warning(std::string("volume-map --init ball: ") + (k ? "B" : "A"),
                                                       ball_metrics(*balls[k].first, balls[k].second->f),
                                                       *balls[k].second);
          !msg.empty())
        info(g, msg);
  }
  timer.start("write");
  write_volume_map_outputs(out, inA, inB, run);
  timer.stop();

  nlohmann::json j = report_header(g, "volume-map");
  const TetMesh &A = inA.mesh, &B = inB.mesh;
  j["inputs"] = {{"A", a.A}, {"B", a.B}, {"A_vertices", A.num_vertices()}, {"A_tets", A.num_tets()},
                 {"B_vertices", B.num_vertices()}, {"B_tets", B.num_tets()},
                 {"A_tetrahedralized", inA.from_surface}, {"B_tetrahedralized", inB.from_surface}};
  j["inputs"]["repairs"] = inA.repairs;
  for (const std::string& n : inB.repairs) j["inputs"]["repairs"].push_back(n);
  if (!a.landmarks.empty()) j["inputs"]["landmarks"] = a.landmarks;
  j.update(run.report);
  timer.start("pictures");
  const auto figures = volume_map_figures(A, run.result.X12, &B, &run.result.X21);
  const ViewerData viewer = volume_map_viewer(A, run.result.X12, &B, &run.result.X21);
  timer.stop();
  j["timings"] = timer.json();
  write_reports(out, j, "shapemap volume-map", figures, &viewer, &g);
  out.commit();
  info(g, run.summary + ", " + std::to_string(timer.total()) + " s -> " + a.out);
  for (const std::string& n : run.notes) info(g, n);
  return 0;
}

}  // namespace

Command register_volume_map(CLI::App& app, GlobalOptions& g) {
  return args_command<VolumeMapArgs>(app, g, add_volume_map_command, run_volume_map_command);
}

namespace {

// The initialization (Algorithm 1, line 1): its kind and the files it reads.
void add_initialization_options(CLI::App* app, VolumeMapArgs& a) {
  app->add_option("--init", a.init, "Initialization: auto (surface map by BIM + elastic), "
                                       "ball (registration through ball maps, both ways), "
                                       "landmarks, surface-map (default: landmarks if given, auto guided by "
                                       "them when fewer than " + std::to_string(kLandmarkStartMinPairs) +
                                       " distinct pairs, else surface-map if given, else auto)")
      ->check(CLI::IsMember({"auto", "ball", "landmarks", "surface-map"}));
  app->add_option("--landmarks", a.landmarks, "Landmark files LA LB (vertex index or x y z per line): --init landmarks starts from them; with --init auto they "
                  "guide the surface map (BIM's candidates, anchors of the elastic refinement)")
      ->expected(2);
  app->add_option("--surface-map", a.surface_map,
                    "Surface map files MAP_AB MAP_BA between the boundary surfaces (or the input surfaces)")
      ->expected(2);
  app->add_option("--surface-map-meshes", a.surface_map_meshes,
                    "SA SB: the closed surfaces the --surface-map files were computed on (default: the "
                    "boundary surfaces of A and B as extracted here, or the input surfaces); boundary "
                    "vertices are located on them by closest point")
      ->expected(2);
  app->add_option("--auto-surface-map", a.auto_surface,
                    "--init auto: surface map between the boundaries by BIM only (bim) or BIM "
                    "refined by elastic correspondence (elastic)")
      ->check(CLI::IsMember({"bim", "elastic"}))
      ->capture_default_str();
  app->add_flag("--reverse-candidates,!--no-reverse-candidates", a.auto_reverse_candidates,
                "--init auto without landmarks: the less confident direction of BIM takes the inverse of the "
                "other's blend, as surface-map does (default; --no-reverse-candidates keeps each direction's "
                "own blend, as --init auto --landmarks always does)");
  app->add_option("--tets", a.tets, "Target tet count when tetrahedralizing surfaces (0: default)")
      ->check(in_range(0, kMaxTets));
}

// The weights of Eq. 25 and their ramp (Sec. 4.4, Eq. 23).
void add_energy_weight_options(CLI::App* app, VolumeMapArgs& a) {
  app->add_option("--alpha", a.opt.alpha, "Eq. 25 rigidity weight alpha")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--alpha-final", a.opt.alpha_final,
                  "Eq. 25 alpha of a second stage 4 run after the first converges at --alpha (< 0: off)")
      ->capture_default_str();
  app->add_option("--gamma", a.opt.gamma, "Eq. 25 projection weight gamma")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--beta-start", a.opt.beta_start, "Eq. 25 beta at the first iteration")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--beta-end", a.opt.beta_end, "Eq. 25 beta after the ramp")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--beta-ramp-iterations", a.opt.beta_ramp_iterations,
                    "Sec. 4.4: outer iterations over which beta (and gamma, with --gamma-start) ramp")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--gamma-start", a.opt.gamma_start,
                    "gamma at the first iteration, ramped to --gamma with beta (the authors' code; "
                    "default -1: gamma constant, Sec. 5.5)")
      ->capture_default_str();
  app->add_option("--backward-projection-scale", a.opt.backward_projection_scale,
                    "Eq. 23: E_P = E_P,f + scale E_P,b (ours 2, tuned on real pairs; paper: 1; the authors' code: 10)")
      ->check(non_negative())
      ->capture_default_str();
}

// The alternation of Algorithm 1 (Sec. 5.4): iterations per stage, the X-step solver
// (Sec. 5.2), the boundary-fixed stage and Anderson acceleration.
void add_alternation_options(CLI::App* app, VolumeMapArgs& a) {
  app->add_option("--max-iterations", a.opt.max_iterations,
                  "Outer iterations of stage 4 at most (Sec. 5.4); stage 2: times --boundary-fixed-iteration-factor")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--decrease-tol", a.opt.decrease_tol,
                  "Stages 2 and 4 stop when Eq. 25 falls by less than this between outer iterations "
                  "(Sec. 5.4 (ii)) ...")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--decrease-rel-tol", a.opt.decrease_rel_tol, "... or by less than this times Eq. 25")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--xstep-iterations", a.opt.xstep_iterations, "L-BFGS iterations per X-step")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--solver", a.solver, "X-step solver (Sec. 5.2): newton (projected Newton, "
                                           "analytic ARAP eigensystem, CHOLMOD) or lbfgs (the paper's)")
      ->check(CLI::IsMember({"newton", "lbfgs"}))
      ->capture_default_str();
  app->add_option("--boundary-fixed-stage", a.boundary_stage,
                    "Algorithm 1 stage 2 (lines 6-10, boundary of X fixed): on, off, or auto (off from "
                    "landmarks, whose initial boundary is collapsed onto them; on from a surface map or "
                    "the ball, as the authors' code does)")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  app->add_option("--interior-init", a.interior_init,
                  "Interior of X at the start: closest (Sec. 5.1: the target of the closest boundary "
                  "vertex or landmark) or harmonic (ours: the harmonic extension of the images of the "
                  "boundary vertices; meant for a surface-map start)")
      ->check(CLI::IsMember({"closest", "harmonic"}))
      ->capture_default_str();
  app->add_option("--newton-iterations", a.opt.newton_iterations, "Newton iterations per X-step at most")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--newton-iterations-final", a.opt.newton_iterations_final,
                  "Newton iterations per X-step at most in stage 4 once beta and gamma are final (ours; "
                  "0 = --newton-iterations)")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--newton-refactor-cg", a.opt.newton_refactor_cg,
                  "Joint X-steps: keep the Hessian's Cholesky factors as the CG preconditioner while CG "
                  "needs at most this many iterations (ours, speed; 0 = factor every Newton step)")
      ->check(non_negative())
      ->capture_default_str();
  app->add_option("--newton-cg-tol", a.opt.newton_cg_rel_tol,
                  "Joint X-steps: conjugate gradients stop at this fraction of the first preconditioned "
                  "residual (ours, speed)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app->add_option("--boundary-fixed-expansions", a.opt.boundary_fixed_expansions,
                  "Stage 2: when a full Newton step is accepted, try doubling it up to this many times "
                  "while Eq. 25 keeps falling (ours; 0 = off)")
      ->check(CLI::Range(0, 10))
      ->capture_default_str();
  app->add_option("--boundary-fixed-iteration-factor", a.opt.boundary_fixed_iteration_factor,
                  "Stage 2 may take this many times --max-iterations outer iterations (ours: its X-steps "
                  "are 2 Newton steps, where Sec. 5.4's cap counts X-steps taken to convergence)")
      ->check(CLI::Range(1, 20))
      ->capture_default_str();
  app->add_option("--anderson", a.opt.anderson_memory,
                    "Stages 2 and 4: Anderson acceleration of the P/X alternation with this memory, "
                    "each proposal kept only if it lowers Eq. 25 (ours; 0 = off)")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  app->add_option("--eliminate-p", a.opt.eliminate_p,
                  "Newton X-steps with P eliminated: each trial X re-solves its P-step and the Hessian "
                  "takes P's response (ours; 0 = the paper's alternation of fixed-P steps)")
      ->capture_default_str();
  app->add_option("--joint-xstep", a.opt.joint_xstep,
                  "With --eliminate-p: both directions' X-steps as one Newton step, with the blocks "
                  "that couple X12 and X21 through the P's (ours; 0 = one step per direction)")
      ->capture_default_str();
}

// Stage 5 (post-repair) and the landing on the target (ours, issue 19).
void add_post_repair_and_landing_options(CLI::App* app, VolumeMapArgs& a) {
  app->add_flag("--no-land-on-target", [&a](std::int64_t) { a.opt.land_on_target = false; },
                  "Skip the final stage that puts X's boundary on the target's boundary and relaxes the "
                  "interior (ours; without it the map files snap images left outside into the target)");
  app->add_option("--post-repair-penalty", a.opt.post_repair_penalty.floor,
                    "Stage 5: ARAP plus a 6th-order penalty on signed singular values below this "
                    "(the authors' released code; 0 = ARAP alone, the paper's text)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app->add_option("--land-gamma-rounds", a.opt.land_gamma_rounds,
                    "Landing: rounds raising gamma (Eq. 25) before the boundary is projected (ours; 0 = "
                    "project at once)")
      ->capture_default_str()
      ->check(CLI::Range(0, 20));
  app->add_option("--land-uncovered-edges", a.opt.land_uncovered_edges,
                  "Landing: one more gamma round, there alone, where a target boundary vertex is farther "
                  "than this many mean edges from the image (ours; 0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  app->add_option("--land-gamma-factor", a.opt.land_gamma_factor,
                    "Landing: factor on gamma per round")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 100.0));
  app->add_option("--land-newton-iterations", a.opt.land_newton_iterations,
                    "Landing: Newton steps per gamma round and per relaxation")
      ->capture_default_str()
      ->check(CLI::Range(1, 200));
  app->add_option("--land-passes", a.opt.land_passes,
                    "Landing with the barrier: passes that relax the interior and retry the boundary "
                    "vertices left off the target")
      ->capture_default_str()
      ->check(CLI::Range(0, 20));
  app->add_flag("--no-land-return", [&a](std::int64_t) { a.opt.land_return_rows = false; },
                "Landing, last: do not put boundary vertices that the repairs left inside the target "
                "back toward its boundary (ours)");
  app->add_option("--land-reconcile-rounds", a.opt.land_reconcile_rounds,
                    "Landing, last: rounds that make the two maps' boundaries mutually inverse (Eq. 18 on "
                    "the boundary; ours; 0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0, 50));
  app->add_flag("--no-land-interior-final", [&a](std::int64_t) { a.opt.land_interior_final = false; },
                "Landing, last: do not relax both interiors together at --alpha-final with the landed "
                "boundaries held (ours)");
  app->add_option("--land-reconcile-gap", a.opt.land_reconcile_gap,
                    "Landing's reconciliation: a move is refused when it leaves a vertex of the target's "
                    "boundary farther than this many mean edges from the image, and farther than before")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  app->add_option("--land-reconcile-det", a.opt.land_reconcile_det,
                    "Landing's reconciliation: a move is refused when a tet of the moved vertex keeps less "
                    "than this fraction of its det J")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app->add_option("--land-reconcile-arap", a.opt.land_reconcile_arap,
                    "Landing's reconciliation: a move is refused when the ARAP energy (Eq. 20) of the moved "
                    "vertex's tets rises by more than this fraction of itself")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  app->add_option("--land-pull-rounds", a.opt.land_pull_rounds,
                    "Landing with the barrier: rounds that pull images still outside the target to "
                    "points just inside it (ours; 0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0, 50));
  app->add_option("--land-untangle-rounds", a.opt.land_untangle_rounds,
                  "Landing, last: sweeps that untangle the located map's inverted tets inside the "
                  "target (max-min ascent of tet volumes; ours; 0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app->add_option("--land-regularized-rings", a.opt.land_regularized_rings,
                  "Landing, last: tets still inverted are untangled by the regularized energy of "
                  "Garanzha et al. 2021 with 1, 2, 4, ... up to this many rings around them free "
                  "(ours; 0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0, 64));
  app->add_option("--land-untangle-rings", a.opt.land_untangle_rings,
                  "Landing's untangling: when it stalls, vertices this many edges from the inverted "
                  "tets move too, raising their own tets' smallest volume (ours)")
      ->capture_default_str()
      ->check(CLI::Range(0, 5));
  app->add_option("--land-barrier", a.opt.land_barrier_floor,
                    "Landing: log barrier on det J below this, so that no tet positive at its start "
                    "turns over (ours; 0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
}

CLI::App* add_volume_map_command(CLI::App& parent, VolumeMapArgs& a) {
  CLI::App* app = parent.add_subcommand("volume-map", "Symmetric volume map between two tetrahedral meshes");
  add_pair_options(app, a.A, a.B, a.out, "Source: tet mesh or closed surface", "Target: tet mesh or closed surface");
  add_initialization_options(app, a);
  add_energy_weight_options(app, a);
  add_alternation_options(app, a);
  add_post_repair_and_landing_options(app, a);
  app->add_flag("--boundary-to-boundary", a.opt.boundary_to_boundary,
                  "Hard boundary constraint in the P-step (Sec. 5.2)");
  return app;
}

}  // namespace

}  // namespace shapemap::cli
