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

struct VolumeInput {
  TetMesh mesh;
  bool from_surface = false;
  TriMesh surface;  // the input surface when from_surface, repaired (what was tetrahedralized)
  TriMesh given;    // the input surface as given (landmark indices and map files refer to it)
  std::vector<std::string> repairs;  // notes of the input repairs (report.json: inputs.repairs)
};

VolumeInput load_volume_input(const std::string& path, const std::string& name, int tets,
                              const ProgressCallback& progress, const GlobalOptions& g) {
  VolumeInput in;
  if (is_volume_path(path)) {
    in.mesh = read_volume(path);
  } else if (is_surface_path(path)) {
    in.given = read_surface(path);
    in.surface = repaired_genus0_surface(in.given, path, g, &in.repairs);
    TetrahedralizeOptions to;
    to.target_tets = tets;
    to.seed = unsigned(g.seed);
    in.mesh = tetrahedralize_input(in.surface, to, progress, path, g.quiet);
    in.from_surface = true;
  } else {
    throw InputError(path + ": unknown extension (tet mesh: .mesh .vtk .msh .node .ele; "
                            "surface: .obj .off .ply .stl)");
  }
  // Up to 1% bad tets are accepted (and said); more is the one-line error below.
  require_valid_volume(in.mesh, path, 0.01);
  MeshReport rep = check_volume(in.mesh);
  int bad = rep.inverted_elements + rep.degenerate_elements;
  if (bad > 0)
    info(g, path + ": " + std::to_string(rep.inverted_elements) + " inverted and " +
                std::to_string(rep.degenerate_elements) + " degenerate tets of " +
                std::to_string(rep.num_elements));
  return in;
}

// Landmarks of a volume input, in the numbering of the file the user gave: for a tet mesh its
// vertices (x y z lines snap to the nearest boundary vertex); for a surface input its surface
// vertices, carried to the nearest boundary vertex of the tet mesh made from it (their
// numbering differs: Mesh_3 remeshes the surface).
std::vector<int> volume_landmarks(const std::string& file, const VolumeInput& in, const TetBoundary& bd) {
  const std::vector<int> cand(bd.to_volume.data(), bd.to_volume.data() + bd.to_volume.size());
  if (!in.from_surface) return read_landmarks(file, in.mesh.V, cand);
  const std::vector<int> on_surface = read_landmarks(file, in.given.V);
  std::vector<int> out;
  for (size_t k = 0; k < on_surface.size(); ++k) {
    const Eigen::RowVector3d x = in.given.V.row(on_surface[k]);
    int best = cand.front();
    for (int v : cand)
      if ((in.mesh.V.row(v) - x).squaredNorm() < (in.mesh.V.row(best) - x).squaredNorm()) best = v;
    out.push_back(best);  // two landmarks on one tet vertex: repeats (tidy_landmark_pairs)
  }
  return out;
}

nlohmann::json metrics_json(const VolumeMapMetrics& m) {
  nlohmann::json j;
  j["num_tets"] = m.num_tets;
  j["n_inv"] = m.n_inv;
  j["inverted_fraction"] = m.inverted_fraction;
  j["d_max_hat"] = m.d_max;
  j["d_avg_hat"] = m.d_avg;
  j["det_J_mean"] = m.det_mean;
  j["det_J_sd"] = m.det_sd;
  j["E_ARAP"] = m.E_arap;
  if (!std::isnan(m.E_R)) j["E_R"] = m.E_R;
  if (m.has_truth) {
    j["truth_error_mean"] = m.truth_mean;
    j["truth_error_max"] = m.truth_max;
  }
  return j;
}

}  // namespace

nlohmann::json volume_metrics_json(const VolumeMapMetrics& m) { return metrics_json(m); }

Command register_volume_map(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("volume-map", "Symmetric volume map between two tetrahedral meshes");
  struct Args {
    std::string A, B, out, init;
    std::vector<std::string> landmarks, surface_map, surface_map_meshes;
    int tets = 0;
    std::string auto_surface = "elastic";
    std::string solver = "newton";
    std::string boundary_stage = "auto";
    SymmetricVolumeMapOptions opt;
  };
  auto a = std::make_shared<Args>();
  c.app->add_option("A", a->A, "Source: tet mesh or closed surface")->required();
  c.app->add_option("B", a->B, "Target: tet mesh or closed surface")->required();
  c.app->add_option("-o,--output", a->out, "Output folder")->required();
  c.app->add_option("--init", a->init, "Initialization: auto (surface map by BIM + elastic), "
                                       "ball (registration through ball maps, both ways), "
                                       "landmarks, surface-map (default: landmarks if given, "
                                       "else surface-map if given, else auto)")
      ->check(CLI::IsMember({"auto", "ball", "landmarks", "surface-map"}));
  c.app->add_option("--landmarks", a->landmarks, "Landmark files LA LB (vertex index or x y z per line)")
      ->expected(2);
  c.app->add_option("--surface-map", a->surface_map,
                    "Surface map files MAP_AB MAP_BA between the boundary surfaces (or the input surfaces)")
      ->expected(2);
  c.app->add_option("--surface-map-meshes", a->surface_map_meshes,
                    "SA SB: the closed surfaces the --surface-map files were computed on (default: the "
                    "boundary surfaces of A and B as extracted here, or the input surfaces); boundary "
                    "vertices are located on them by closest point")
      ->expected(2);
  c.app->add_option("--auto-surface-map", a->auto_surface,
                    "--init auto: surface map between the boundaries by BIM only (bim) or BIM "
                    "refined by elastic correspondence (elastic)")
      ->check(CLI::IsMember({"bim", "elastic"}))
      ->capture_default_str();
  c.app->add_option("--tets", a->tets, "Target tet count when tetrahedralizing surfaces (0: default)")
      ->check(in_range(0, kMaxTets));
  c.app->add_option("--alpha", a->opt.alpha, "Eq. 25 rigidity weight alpha")->check(non_negative())->capture_default_str();
  c.app->add_option("--gamma", a->opt.gamma, "Eq. 25 projection weight gamma")->check(non_negative())->capture_default_str();
  c.app->add_option("--beta-start", a->opt.beta_start, "Eq. 25 beta at the first iteration")->check(non_negative())->capture_default_str();
  c.app->add_option("--beta-end", a->opt.beta_end, "Eq. 25 beta after the ramp")->check(non_negative())->capture_default_str();
  c.app->add_option("--beta-ramp-iterations", a->opt.beta_ramp_iterations,
                    "Sec. 4.4: outer iterations over which beta (and gamma, with --gamma-start) ramp")
      ->check(non_negative())
      ->capture_default_str();
  c.app->add_option("--gamma-start", a->opt.gamma_start,
                    "gamma at the first iteration, ramped to --gamma with beta (the authors' code; "
                    "default -1: gamma constant, Sec. 5.5)")
      ->capture_default_str();
  c.app->add_option("--backward-projection-scale", a->opt.backward_projection_scale,
                    "Eq. 23: E_P = E_P,f + scale E_P,b (paper: 1; the authors' code: 10)")
      ->check(non_negative())
      ->capture_default_str();
  c.app->add_option("--max-iterations", a->opt.max_iterations, "Outer iterations per stage (Sec. 5.4)")
      ->check(non_negative())
      ->capture_default_str();
  c.app->add_option("--xstep-iterations", a->opt.xstep_iterations, "L-BFGS iterations per X-step")
      ->check(non_negative())
      ->capture_default_str();
  c.app->add_option("--solver", a->solver, "X-step solver (Sec. 5.2): newton (projected Newton, "
                                           "analytic ARAP eigensystem, CHOLMOD) or lbfgs (the paper's)")
      ->check(CLI::IsMember({"newton", "lbfgs"}))
      ->capture_default_str();
  c.app->add_option("--boundary-fixed-stage", a->boundary_stage,
                    "Algorithm 1 stage 2 (lines 6-10, boundary of X fixed): on, off, or auto (off from "
                    "landmarks, whose initial boundary is collapsed onto them; on from a surface map or "
                    "the ball, as the authors' code does)")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  c.app->add_option("--newton-iterations", a->opt.newton_iterations, "Newton iterations per X-step at most")
      ->check(non_negative())
      ->capture_default_str();
  c.app->add_option("--anderson", a->opt.anderson_memory,
                    "Stages 2 and 4: Anderson acceleration of the P/X alternation with this memory, "
                    "each proposal kept only if it lowers Eq. 25 (ours; 0 = off)")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  c.app->add_flag("--no-land-on-target", [a](std::int64_t) { a->opt.land_on_target = false; },
                  "Skip the final stage that puts X's boundary on the target's boundary and relaxes the "
                  "interior (ours; without it the map files snap images left outside into the target)");
  c.app->add_option("--post-repair-penalty", a->opt.post_repair_penalty.floor,
                    "Stage 5: ARAP plus a 6th-order penalty on signed singular values below this "
                    "(the authors' released code; 0 = ARAP alone, the paper's text)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  c.app->add_option("--land-gamma-rounds", a->opt.land_gamma_rounds,
                    "Landing: rounds raising gamma (Eq. 25) before the boundary is projected (ours; 0 = "
                    "project at once)")
      ->capture_default_str()
      ->check(CLI::Range(0, 20));
  c.app->add_option("--land-gamma-factor", a->opt.land_gamma_factor,
                    "Landing: factor on gamma per round")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 100.0));
  c.app->add_flag("--boundary-to-boundary", a->opt.boundary_to_boundary,
                  "Hard boundary constraint in the P-step (Sec. 5.2)");

  c.run = [a, &g]() -> int {
    StageTimer timer;
    ProgressCallback progress = make_progress(g);
    a->opt.solver = a->solver == "lbfgs" ? XStepSolver::Lbfgs : XStepSolver::Newton;
    OutputDir out(a->out);
    std::string init = a->init;
    if (init.empty()) init = !a->landmarks.empty() ? "landmarks" : !a->surface_map.empty() ? "surface-map" : "auto";
    const std::string init_name = "--init " + init + (a->init.empty() ? " (the default)" : "");
    if (init == "landmarks" && a->landmarks.size() != 2)
      throw InputError("--init landmarks: needs --landmarks LA LB");
    if (init == "surface-map" && a->surface_map.size() != 2)
      throw InputError("--init surface-map: needs --surface-map MAP_AB MAP_BA");
    // Inputs of another initialization are an error, not silently ignored.
    if (!a->landmarks.empty() && init != "landmarks")
      throw InputError(init_name + ": --landmarks is only used by --init landmarks");
    if ((!a->surface_map.empty() || !a->surface_map_meshes.empty()) && init != "surface-map")
      throw InputError(init_name + ": --surface-map/--surface-map-meshes are only used by --init surface-map");

    // Map files are read (syntax) before the inputs, which may need tetrahedralizing first;
    // they are checked against the meshes below.
    BarycentricMap sAB, sBA;
    if (init == "surface-map") {
      sAB = read_map(a->surface_map[0]);
      sBA = read_map(a->surface_map[1]);
    }

    timer.start("load");
    VolumeInput inA = load_volume_input(a->A, "A", a->tets, progress, g);
    VolumeInput inB = load_volume_input(a->B, "B", a->tets, progress, g);
    const TetMesh& A = inA.mesh;
    const TetMesh& B = inB.mesh;
    TetBoundary bA = boundary_surface(A), bB = boundary_surface(B);

    timer.start("init");
    BarycentricMap i12, i21;
    std::string init_detail = init;
    if (init == "landmarks") {
      std::vector<int> LA = volume_landmarks(a->landmarks[0], inA, bA);
      std::vector<int> LB = volume_landmarks(a->landmarks[1], inB, bB);
      for (const std::string& n : tidy_landmark_pairs(LA, LB, a->landmarks[0], a->landmarks[1])) info(g, n);
      if (LA.size() != LB.size())
        throw InputError(a->landmarks[1] + ": " + std::to_string(LB.size()) + " landmarks but " +
                         a->landmarks[0] + " has " + std::to_string(LA.size()));
      i12 = landmark_initial_map(A, B, LA, LB);
      i21 = landmark_initial_map(B, A, LB, LA);
    } else if (init == "ball") {
      // Both directions from one pair of ball maps (Sec. 7 of the isovolumetric paper):
      // volume-preserving, landmark-free, no surface map needed. Both inputs are checked
      // before either ball map is computed (the ball map needs every tet positive).
      for (const auto& [M, path] : {std::pair<const TetMesh*, std::string>{&A, a->A}, {&B, a->B}}) {
        require_valid_volume(*M, path + " (--init ball)", 0.0);
        require_ball_topology(*M, path + " (--init ball)");
      }
      // The ball maps run on copies with their boundary chords split (a tet with four
      // boundary vertices is squeezed flat by any ball map; docs/methods.md, "Boundary
      // chords"). Splitting only appends vertices and subdivides tets, so the images of the
      // user's vertices are the first rows, located again in the user's tets.
      TetMesh As = A, Bs = B;
      const int chords = split_boundary_chords(As) + split_boundary_chords(Bs);
      RegisterResult rr = register_through_ball(As, Bs, {}, progress, a->A, a->B);
      const Eigen::MatrixXd phi = rr.A_on_B.topRows(A.num_vertices());
      i12 = locate_in_tets(B, phi);
      i21 = locate_in_tets(A, rr.B_on_A.topRows(B.num_vertices()));
      // d(phi) (Sec. 7) over the user's A (rr.d_phi is over the split copy).
      const Eigen::VectorXd w = vertex_volumes(A.V, A.T);
      const double d_phi = w.dot((A.V - phi).rowwise().norm()) / w.sum();
      char d[96];
      std::snprintf(d, sizeof d, "%.4g of A's bbox diagonal; %d boundary chords split", d_phi / bbox_diagonal(A.V),
                    chords);
      init_detail = std::string("ball (registration through the ball, d(phi) ") + d + ")";
      // A poor ball map makes a poor start: say so, as `register` does.
      for (const auto& [w, M, br] : {std::tuple{std::string("volume-map --init ball: A"), &As, &rr.ball_A},
                                     std::tuple{std::string("volume-map --init ball: B"), &Bs, &rr.ball_B}})
        if (const std::string msg = ball_quality_warning(w, ball_metrics(*M, br->f), *br); !msg.empty())
          info(g, msg);
    } else {
      // The surfaces the surface map lives on.
      auto pick = [](const VolumeInput& in, const TetBoundary& bd, int n, const std::string& file) {
        if (n == bd.surface.num_vertices()) return bd.surface;
        if (in.from_surface && n == in.surface.num_vertices()) return in.surface;
        if (in.from_surface && n == in.given.num_vertices()) return in.given;  // e.g. surface-map's output
        throw InputError(file + ": " + std::to_string(n) + " rows, but the boundary surface has " +
                         std::to_string(bd.surface.num_vertices()) + " vertices");
      };
      TriMesh SA, SB;
      if (init == "surface-map") {
        if (a->surface_map_meshes.size() == 2) {
          SA = read_surface(a->surface_map_meshes[0]);
          SB = read_surface(a->surface_map_meshes[1]);
          // Checked copies (closed, genus 0, a size that areas can represent): the maps
          // refer to the faces as given.
          TriMesh ca = SA, cb = SB;
          require_genus0_surface(ca, a->surface_map_meshes[0]);
          require_genus0_surface(cb, a->surface_map_meshes[1]);
        } else {
          SA = pick(inA, bA, sAB.size(), a->surface_map[0]);
          SB = pick(inB, bB, sBA.size(), a->surface_map[1]);
        }
        // Checked here, so that an error names the map file.
        validate_map(sAB, SA.num_vertices(), SB.num_faces(), 3, a->surface_map[0]);
        validate_map(sBA, SB.num_vertices(), SA.num_faces(), 3, a->surface_map[1]);
      } else {
        SA = inA.from_surface ? inA.surface : bA.surface;
        SB = inB.from_surface ? inB.surface : bB.surface;
        // Boundaries of tet meshes get the surface repairs too (tets touching along an edge make
        // a non-manifold boundary); A's boundary vertices are located on SA by closest point.
        if (!inA.from_surface) SA = repaired_genus0_surface(SA, a->A + " (boundary)", g, &inA.repairs);
        if (!inB.from_surface) SB = repaired_genus0_surface(SB, a->B + " (boundary)", g, &inB.repairs);
        std::string used;
        std::tie(sAB, sBA) =
            surface_map_for_volumes(SA, SB, progress, &used, a->auto_surface == "elastic");
        init_detail = "auto (" + used + ")";
      }
      i12 = surface_initial_map(A, B, SA, SB, sAB);
      i21 = surface_initial_map(B, A, SB, SA, sBA);
    }

    a->opt.fix_boundary_first =
        a->boundary_stage == "on" || (a->boundary_stage == "auto" && init != "landmarks");
    timer.start("optimize");
    SymmetricVolumeMapResult r = symmetric_volume_map(A, B, i12, i21, a->opt, progress);

    timer.start("metrics");
    VolumeMapMetrics m12 = volume_map_metrics(A, B, r.X12, &r.map12, &r.X21);
    VolumeMapMetrics m21 = volume_map_metrics(B, A, r.X21, &r.map21, &r.X12);
    // The map files hold barycentric coordinates in the target's tets, so images that the
    // free boundary left outside the target (Eq. 25 fits the boundary by a penalty) are
    // snapped into it, and more tets can invert: the maps a user reads back are measured too.
    const Eigen::MatrixXd F12 = map_positions(r.map12, B.V, B.T), F21 = map_positions(r.map21, A.V, A.T);
    VolumeMapMetrics f12 = volume_map_metrics(A, B, F12, &r.map12, &F21);
    VolumeMapMetrics f21 = volume_map_metrics(B, A, F21, &r.map21, &F12);
    double snap12 = 0, snap21 = 0;  // largest move of an image by the snapping
    for (int i = 0; i < A.num_vertices(); ++i) snap12 = std::max(snap12, (F12.row(i) - r.X12.row(i)).norm());
    for (int i = 0; i < B.num_vertices(); ++i) snap21 = std::max(snap21, (F21.row(i) - r.X21.row(i)).norm());

    timer.start("write");
    write_map(out.path("map_AB.txt"), r.map12);
    write_map(out.path("map_BA.txt"), r.map21);
    auto detn = [](const TetMesh& src, const Eigen::MatrixXd& X) {
      Eigen::VectorXd d(src.num_tets());
      for (int k = 0; k < src.num_tets(); ++k) {
        Eigen::Matrix3d Dm, Ds;
        for (int j = 0; j < 3; ++j) {
          Dm.col(j) = (src.V.row(src.T(k, j + 1)) - src.V.row(src.T(k, 0))).transpose();
          Ds.col(j) = (X.row(src.T(k, j + 1)) - X.row(src.T(k, 0))).transpose();
        }
        // Volume ratio (<= 0: inverted); 0 for a degenerate rest tet (up to 1% are accepted).
        const double q = Ds.determinant() / Dm.determinant();
        d(k) = std::isfinite(q) ? q : 0.0;
      }
      return d;
    };
    write_vtk(out.path("A_on_B.vtk"), TetMesh{r.X12, A.T}, {}, {{"volume_ratio", detn(A, r.X12)}});
    write_vtk(out.path("B_on_A.vtk"), TetMesh{r.X21, B.T}, {}, {{"volume_ratio", detn(B, r.X21)}});
    // The maps index the tets we made from surface inputs: without them map_AB.txt and the
    // rest positions of A_on_B.vtk's vertices could not be read.
    if (inA.from_surface) write_volume(out.path("A.vtk"), A);
    if (inB.from_surface) write_volume(out.path("B.vtk"), B);
    timer.stop();

    nlohmann::json j = report_header(g, "volume-map");
    j["inputs"] = {{"A", a->A}, {"B", a->B}, {"A_vertices", A.num_vertices()}, {"A_tets", A.num_tets()},
                   {"B_vertices", B.num_vertices()}, {"B_tets", B.num_tets()},
                   {"A_tetrahedralized", inA.from_surface}, {"B_tetrahedralized", inB.from_surface}};
    j["inputs"]["repairs"] = inA.repairs;
    for (const std::string& n : inB.repairs) j["inputs"]["repairs"].push_back(n);
    if (!a->landmarks.empty()) j["inputs"]["landmarks"] = a->landmarks;
    const auto& o = a->opt;
    j["parameters"] = {{"init", init_detail}, {"alpha", o.alpha}, {"gamma", o.gamma},
                       {"beta_start", o.beta_start}, {"beta_end", o.beta_end},
                       {"beta_ramp_iterations", o.beta_ramp_iterations},
                       {"gamma_start", o.gamma_start}, {"backward_projection_scale", o.backward_projection_scale},
                       {"max_iterations", o.max_iterations}, {"solver", a->solver},
                       {"newton_iterations", o.newton_iterations},
                       {"boundary_fixed_stage", o.fix_boundary_first}, {"land_on_target", o.land_on_target}, {"land_gamma_rounds", o.land_gamma_rounds}, {"land_gamma_factor", o.land_gamma_factor}, {"post_repair_penalty", o.post_repair_penalty.floor}, {"xstep_iterations", o.xstep_iterations},
                       {"grad_tol", o.grad_tol}, {"decrease_tol", o.decrease_tol},
                       {"decrease_rel_tol", o.decrease_rel_tol},
                       {"repair_rings", o.repair_rings}, {"post_repair_steps", o.post_repair_steps},
                       {"boundary_to_boundary", o.boundary_to_boundary}};
    nlohmann::json stages = nlohmann::json::array();
    for (auto& s : r.stages)
      stages.push_back({{"name", s.name}, {"iterations", s.iterations}, {"seconds", s.seconds},
                        {"energy", s.energy}, {"n_inv_AB", s.inverted12}, {"n_inv_BA", s.inverted21},
                        {"seconds_P_step", s.time_pstep}, {"seconds_X_step", s.time_xstep},
                        {"solver_iterations", s.lbfgs_iterations}, {"evaluations", s.evaluations},
                        {"anderson_accepted", s.anderson_accepted}, {"anderson_rejected", s.anderson_rejected},
                        {"newton_seconds", {{"energy", s.newton_seconds[0]}, {"hessian", s.newton_seconds[1]},
                                            {"factor", s.newton_seconds[2]}, {"solve", s.newton_seconds[3]}}},
                        {"stop_reason", s.stop_reason}, {"energy_history", s.energy_history},
                        {"gradient_history", s.gradient_history}});
    j["algorithm_stages"] = stages;
    j["energy"] = {{"E", r.E}, {"E_ARAP", r.E_arap}, {"E_R", r.E_R}, {"E_P", r.E_P}, {"E_Q", r.E_Q},
                   {"outer_iterations", r.iterations}};
    j["metrics"] = {{"AB", metrics_json(m12)}, {"BA", metrics_json(m21)}};
    j["metrics_map_files"] = {{"AB", metrics_json(f12)}, {"BA", metrics_json(f21)},
                              {"max_snap_AB", snap12 / bbox_diagonal(B.V)},
                              {"max_snap_BA", snap21 / bbox_diagonal(A.V)}};
    timer.start("pictures");
    const auto figures = volume_map_figures(A, r.X12, &B, &r.X21);
    const ViewerData viewer = volume_map_viewer(A, r.X12, &B, &r.X21);
    timer.stop();
    j["timings"] = timer.json();
    write_reports(out, j, "shapemap volume-map", figures, &viewer, &g);
    out.commit();
    info(g, "volume-map: n_inv " + std::to_string(m12.n_inv) + " / " + std::to_string(m21.n_inv) +
                ", d_avg^ " + std::to_string(m12.d_avg) + " / " + std::to_string(m21.d_avg) +
                ", |det J| " + std::to_string(m12.det_mean) + " / " + std::to_string(m21.det_mean) +
                ", " + std::to_string(timer.total()) + " s -> " + a->out);
    if (f12.n_inv != m12.n_inv || f21.n_inv != m21.n_inv) {
      char line[320];
      std::snprintf(line, sizeof line,
                    "volume-map: note: map_AB.txt / map_BA.txt snap images left outside the target into it "
                    "(by up to %.2g / %.2g of the target's bounding-box diagonal): n_inv %d / %d there "
                    "(report.json: metrics_map_files)",
                    snap12 / bbox_diagonal(B.V), snap21 / bbox_diagonal(A.V), f12.n_inv, f21.n_inv);
      info(g, line);
    }
    return 0;
  };
  return c;
}

}  // namespace shapemap::cli
