// Shared pieces of `shapemap ball`, `shapemap register` and `shapemap evaluate ball`:
// loading a volume (tet mesh, or closed surface tetrahedralized first) and the JSON of
// the ball-map metrics.
#pragma once
#include "common.h"
#include "shapemap/boundary_chords.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/eval/ball_metrics.h"
#include "shapemap/io.h"
#include "shapemap/repair.h"
#include "shapemap/volume/ball_param.h"
#include "shapemap/volume/tetrahedralize.h"
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>

namespace shapemap::cli {

// The volume of `ball` / `register`: read from `path` (.vtk .mesh .msh .node .ele), or a
// closed genus-0 surface (.obj .off .ply .stl) tetrahedralized with about `tets` tets (0:
// default). Boundary chords (shapemap/boundary_chords.h) are split in meshes we make and,
// with split_chords, in given ones; a given mesh with chords left gets a note.
struct BallInput {
  TetMesh mesh;
  bool tetrahedralized = false;
  int chords_split = 0;
  int chords_left = 0;
  int pinches_split = 0;  // vertex copies made by split_pinched_tet_vertices
  std::vector<std::string> repairs;  // notes of the input repairs (report.json: inputs.repairs)
  bool changed() const { return tetrahedralized || chords_split > 0 || pinches_split > 0; }  // write it to OUT
};

// Parts touching along an edge or at a vertex (given so, or made so by the tetrahedralizer
// from a surface that touches itself): the boundary is not a manifold, so not a sphere.
// Splitting those vertices (copies appended: rows 0..n-1 stay the user's) repairs it.
inline void split_pinches(BallInput& in, const std::string& path, const GlobalOptions& g) {
  const MeshReport r = check_volume(in.mesh);
  if (!r.indices_in_range || (r.non_manifold_edges == 0 && r.non_manifold_vertices == 0)) return;
  auto count = [](int k, const char* one, const char* many) { return std::to_string(k) + (k == 1 ? one : many); };
  const std::string what = "boundary surface has " +
                           count(r.non_manifold_edges, " non-manifold edge", " non-manifold edges") + " and " +
                           count(r.non_manifold_vertices, " non-manifold vertex", " non-manifold vertices") +
                           " (tets touching along an edge or at a vertex)";
  if (g.strict) throw InputError(path + ": " + what + " (--strict: not repaired)");
  in.pinches_split = split_pinched_tet_vertices(in.mesh);
  if (in.pinches_split > 0) {
    in.repairs.push_back(path + ": note: " + what + ": " + std::to_string(in.pinches_split) +
                         " vertices split (copies appended after the given vertices, which keep their numbers)");
    info(g, in.repairs.back());
  }
}

inline BallInput load_ball_input(const std::string& path, int tets, bool split_chords,
                                 const ProgressCallback& progress, const GlobalOptions& g) {
  const bool quiet = g.quiet;
  BallInput in;
  if (is_volume_path(path)) {
    in.mesh = read_volume(path);
    split_pinches(in, path, g);
  } else if (is_surface_path(path)) {
    const TriMesh s = repaired_genus0_surface(read_surface(path), path, g, &in.repairs);
    TetrahedralizeOptions o;
    o.target_tets = tets;
    in.mesh = tetrahedralize_input(s, o, progress, path, quiet);
    in.tetrahedralized = true;
    split_pinches(in, path, g);
    split_chords = true;
  } else {
    throw InputError(path + ": unknown mesh format (use .vtk .mesh .msh .node .ele, or a closed surface .obj .off .ply .stl)");
  }
  // The checks of ball_parameterization(), before the chords are looked at.
  require_valid_volume(in.mesh, path, 0.0);
  require_ball_topology(in.mesh, path);
  if (split_chords) {
    in.chords_split = split_boundary_chords(in.mesh);
  } else {
    in.chords_left = int(boundary_chords(in.mesh).size());
    if (in.chords_left > 0 && !quiet)
      std::cerr << path << ": note: " << in.chords_left << " interior edges join two boundary vertices ("
                << boundary_only_tets(in.mesh)
                << " tets have all four vertices on the boundary); the ball map squeezes them flat. "
                   "--split-chords splits them (docs/methods.md)\n";
  }
  return in;
}

// E_I alone lets the boundary layer fold over (docs/methods.md): one note when more than
// 0.1% of the ball is covered twice and the map is otherwise usable (`warning` empty);
// "" otherwise. Points located in such a region (register) have two candidate images.
inline std::string ball_overlap_note(const std::string& what, const BallMetrics& m,
                                     const std::string& warning) {
  if (!warning.empty() || !(m.overlap_fraction > 1e-3)) return "";
  char line[256];
  std::snprintf(line, sizeof line,
                "%s: note: the map covers %.2f%% of the ball twice (boundary layer folded over); "
                "--boundary-barrier 0.01 prevents it",
                what.c_str(), 100 * m.overlap_fraction);
  return line;
}

// One warning line when a ball map came out unusable (folded tets, or mean D_V above 0.2),
// with the likely cause when the spherical boundary map already folded; "" otherwise.
inline std::string ball_quality_warning(const std::string& what, const BallMetrics& m,
                                        const BallParamResult& r) {
  if (m.folded_tets == 0 && !(m.dv_mean > 0.2)) {
    if (!r.fold_retry) return "";
    return what + ": note: " + std::to_string(r.inverted_before_retry) +
           " inverted tets were left; the rerun with the boundary barrier (docs/methods.md, \"Fold retry\") removed them";
  }
  char line[512];
  std::snprintf(line, sizeof line, "%s: warning: the ball map is not bijective or not volume-preserving: %d folded tets (%.2f%%), mean D_V %.3g",
                what.c_str(), m.folded_tets, 100.0 * m.folded_tets / std::max(1, m.num_tets), m.dv_mean);
  std::string s = line;
  if (m.max_radius > 1.01) {  // folds let interior vertices leave the ball
    std::snprintf(line, sizeof line, "; vertices mapped outside the ball (max radius %.3g)", m.max_radius);
    s += line;
  }
  if (r.sphere_folded_faces > 0)
    s += "; the spherical boundary map already folded " + std::to_string(r.sphere_folded_faces) +
         " faces (a shape with long thin parts; docs/methods.md)";
  if (r.fold_retry)
    s += std::string("; rerun with the boundary barrier: ") + (r.fold_retry_kept ? "kept" : "not better, first run kept") +
         " (first run: " + std::to_string(r.inverted_before_retry) + " inverted tets)";
  return s;
}

inline nlohmann::json ball_metrics_json(const BallMetrics& m) {
  nlohmann::json j;
  j["num_vertices"] = m.num_vertices;
  j["num_tets"] = m.num_tets;
  j["num_boundary_vertices"] = m.num_boundary_vertices;
  j["D_V"] = {{"mean", m.dv_mean}, {"sd", m.dv_sd},   {"p25", m.dv_p25}, {"p50", m.dv_p50},
              {"p75", m.dv_p75},   {"p95", m.dv_p95}, {"max", m.dv_max}};
  j["E_I"] = m.energy;
  j["folded_tets"] = m.folded_tets;
  j["positive_tets"] = m.positive_tets;
  j["negative_tets"] = m.negative_tets;
  j["flipped_boundary_faces"] = m.flipped_boundary_faces;
  j["overlap_fraction"] = m.overlap_fraction;
  j["uncovered_fraction"] = m.uncovered_fraction;
  j["coverage_samples"] = m.coverage_samples;
  j["boundary_sphere_error"] = m.boundary_sphere_error;
  j["max_radius"] = m.max_radius;
  return j;
}

// The ball options of a run, as report.json's parameters.
inline nlohmann::json ball_parameters_json(const BallParamOptions& o) {
  return {{"max_iterations", o.max_iterations},
          {"tolerance", o.tolerance},
          {"vsem_iterations", o.vsem_iterations},
          {"anisotropic_scaling", o.anisotropic_scaling},
          {"boundary_barrier", o.boundary_barrier},
          {"fold_retry_barrier", o.fold_retry_barrier},
          {"prevent_new_folds", o.prevent_new_folds}};
}

inline nlohmann::json ball_result_json(const BallParamResult& r) {
  nlohmann::json j;
  j["E_I_after_vsem"] = r.energy_vsem;
  j["E_I_final"] = r.energy_final;
  j["iterations"] = r.iterations;
  j["converged"] = r.converged;
  j["quadratic_steps"] = r.quadratic_steps;
  j["preconditioner_fallbacks"] = r.preconditioner_fallbacks;
  j["wolfe_steps"] = r.wolfe_steps;
  j["restarts"] = r.restarts;
  j["frame_rotations"] = r.frame_rotations;
  j["evaluations"] = r.evaluations;
  j["sphere_map_folded_faces"] = r.sphere_folded_faces;
  j["sphere_map_start"] = r.sphere_start == 2 ? "latitude-longitude" : r.sphere_start == 1 ? "linear" : "conformal";
  j["inverted_tets_after_vsem"] = r.inverted_vsem;
  j["inverted_tets_after_cg"] = r.inverted_cg;
  j["polish_iterations"] = r.polish_iterations;
  j["penalty_rounds"] = r.penalty_rounds;
  j["E_I_after_cg"] = r.energy_cg;
  j["inverted_tets_final"] = r.inverted_final;
  j["flipped_boundary_faces_after_cg"] = r.flipped_boundary_faces_cg;
  j["flipped_boundary_faces_final"] = r.flipped_boundary_faces_final;
  j["preconditioner_refreshes"] = r.preconditioner_refreshes;
  j["fold_retry"] = {{"ran", r.fold_retry},
                     {"kept", r.fold_retry_kept},
                     {"inverted_tets_before", r.inverted_before_retry},
                     {"seconds", r.seconds_retry}};
  j["sphere_map_area_distortion"] = {{"mean", r.sphere_area_distortion_mean},
                                     {"max", r.sphere_area_distortion_max}};
  j["seconds"] = {{"total", r.seconds_total},      {"sphere_map", r.seconds_sphere},
                  {"vsem", r.seconds_vsem},        {"preconditioner_factor", r.seconds_factor},
                  {"cg", r.seconds_cg},            {"cg_preconditioner_solves", r.seconds_cg_solve},
                  {"cg_energy_gradient", r.seconds_cg_eval},
                  {"post_untangle_polish", r.seconds_post},
                  {"cg_per_iteration", r.iterations > r.polish_iterations
                                           ? r.seconds_cg / (r.iterations - r.polish_iterations)
                                           : 0.0},
                  {"cg_cpu", r.cpu_seconds_cg}};
  return j;
}

inline void add_ball_options(CLI::App* app, BallParamOptions& o) {
  app->add_option("--max-iterations", o.max_iterations, "MaxIter of the nonlinear CG (paper: 500)")
      ->check(non_negative());
  app->add_option("--tolerance", o.tolerance, "Stop when E_old - E_new < tol (paper: 1e-6)")
      ->check(non_negative());
  app->add_option("--vsem-iterations", o.vsem_iterations, "VSEM fixed-point updates (paper: 15)")
      ->check(in_range(0, 10000));
  app->add_flag("!--no-ast", o.anisotropic_scaling, "Skip the anisotropic scaling (Eq. 11)");
  app->add_option("--boundary-barrier", o.boundary_barrier,
                  "Weight of the boundary-layer barrier added to E_I during CG (0: the paper's "
                  "plain E_I; see docs/methods.md)")
      ->check(non_negative());
  app->add_option("--fold-retry-barrier", o.fold_retry_barrier,
                  "When inverted tets remain, run again with this boundary barrier and keep the "
                  "result with fewer (0: off; docs/methods.md)")
      ->check(non_negative())
      ->capture_default_str();
  app->add_flag("--prevent-new-folds", o.prevent_new_folds,
                "Halve CG steps that would increase the number of inverted tets");
}

}  // namespace shapemap::cli
