// The whole surface-map command as one library call (BIM, or elastic refinement of BIM /
// landmark / given initial maps), shared by `shapemap surface-map` and the Python module:
// input repairs and checks, initial maps, the method, the maps carried back to the inputs'
// numbering, and report.json's method sections and metrics. No files, no printing: notes
// are returned, progress goes through the callback.
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/progress.h"
#include "shapemap/repair.h"
#include "shapemap/surface/bim.h"
#include "shapemap/surface/elastic.h"
#include "shapemap/surface/refine_surface_maps.h"
#include <nlohmann/json.hpp>
#include <memory>
#include <string>
#include <vector>

namespace shapemap {

// Elastic refinement settings as the command line names them (--elastic-*); negative
// numbers mean "the ElasticOptions default".
struct ElasticSettings {
  std::string preset = "auto";  // auto | non-isometric (eta 0.1) | near-isometric (0.01) | degenerate (0.002)
  double eta = -1;              // overrides the preset's bending weight (Eq. 2)
  double alpha = 20;            // membrane weight (Eq. 2)
  int iterations = 300;         // K, outer iterations (Algorithm 1)
  bool injective = false;       // E_inj (Eq. 4) instead of E_bij (Eq. 6)
  bool partial = false;         // Sec. 6.2: no unit-area scaling
  double beta_start = -1;       // Sec. 5.2 beta ramp start (default 1e3)
  double log_eps = -1;          // Sec. 4.1 log threshold (default 1e-4; 0 = true barrier)
  bool keep_orientation = false;
  bool gamma_ramp = false;
  bool plain_projection = false;  // ElasticOptions::safe_projection = false
  bool plain_projection_in_ramp = false;  // ElasticOptions::safe_projection_in_ramp = false
  bool keep_worse = false;        // collapse guard off (ElasticOptions::keep_no_worse)
  bool guard_before_untangling = false;  // SurfaceRefinementOptions::guard_untangled = false
  int inner_iterations = -1;      // ElasticOptions::inner_max_iterations (default 50)
  double inner_f_tol = -1;        // ElasticOptions::inner_f_tol (default 1e-6)
  double ramp_inner_f_tol = -1;   // ElasticOptions::inner_f_tol_ramp (default 1e-5; 0 = inner_f_tol)
  bool no_precondition = false;   // ElasticOptions::precondition_stiffness = 0 (plain L-BFGS)
  double start_inner_f_tol = -1;  // ElasticOptions::inner_f_tol_start (default 1e-7; 0 = off)
  double start_min_folds = -1;    // ElasticOptions::inner_f_tol_start_min_folds (default 1e-3)
  double mask_tol = -1;           // ElasticOptions::mask_tol (default 1e-2; 0 = off)
  bool unit_first_step = false;   // ElasticOptions::interpolate_initial_step = false
  // Untangle the returned maps (surface/untangle.h): the images around flipped or collapsed
  // triangles slide on the target; kept per region only where the fold count falls.
  bool untangle = true;
  // Then the same over wide regions with more sweeps, for what the first pass left (mostly
  // patches mapped mirrored; refine_surface_maps.h, stage 3).
  bool wide_untangle = true;
  bool sliver_untangle = true;  // stage 4 of refine_surface_maps.h (--elastic-no-sliver-untangle)
  bool bridge_untangle = true;  // stage 5 of refine_surface_maps.h (--elastic-no-bridge-untangle)
  bool search_untangle = true;  // stage 6 of refine_surface_maps.h (--elastic-no-search-untangle)
  int untangle_passes = 3;      // stages 2-4 repeated while folds fall (--elastic-untangle-passes)
  // Before stage 0 of refine_surface_maps.h: the initial maps' collapsed parts re-extended
  // (collapsed_parts.h). --elastic-no-collapsed-parts.
  bool collapsed_parts = true;
  // Stage 0 of refine_surface_maps.h: feature anchors (feature_anchors.h; the landmarks when
  // the initial maps come from landmarks). --elastic-no-feature-anchors, --elastic-anchor-weight.
  bool feature_anchors = true;
  double anchor_weight = -1;    // ElasticAnchors::weight (default 10)
  double anchor_tolerance = -1; // FeatureAnchorOptions::tolerance (--elastic-anchor-tolerance)
  double anchor_activation = -1;  // ElasticAnchors::activation (--elastic-anchor-activation)
  bool anchor_hold_to_end = false;  // !ElasticAnchors::release_after_ramp (--elastic-anchors-hold-to-end)
};

// The stages around the refinement in `o` (refine_surface_maps.h: stage 0, the anchors, and
// stages 2 to 5, the untangling) set in `ro`. Shared by the surface-map command and
// volume-map's automatic initialization.
void set_refinement_stages(const ElasticSettings& o, SurfaceRefinementOptions& ro);

// The elastic refinement's options for `o` (the preset's bending weight, or with preset "auto"
// Sec. 5.2's rule on the initial maps: bending_weight_for_initial_maps; Q counts only when
// q_given, not when made here by closest point). eta_choice: how eta was chosen, for
// report.json. Shared by the surface-map command and volume-map's automatic initialization.
ElasticOptions elastic_options_from_settings(const ElasticSettings& o, const TriMesh& A, const TriMesh& B,
                                             const BarycentricMap& initAB, const BarycentricMap& initBA,
                                             bool q_given, std::string& eta_choice);

// A surface after its input repairs, with BIM's per-surface stage (bim_prepare: geodesics,
// sampling, features, flattening) done once, for every BIM map from or to it (batches).
struct PreparedSurface {
  SurfaceRepair repair;
  std::shared_ptr<const BIMSurface> bim;
  BIMOptions options;  // the options it was prepared with (seed, max_features, num_even, ...)
};

// Repairs (strict: refuses instead), checks and prepares `mesh` for BIM with `opt`
// (landmarks are not used: a prepared surface serves maps without landmarks).
std::shared_ptr<PreparedSurface> prepare_surface(const TriMesh& mesh, const std::string& name,
                                                 const BIMOptions& opt, bool strict,
                                                 const ProgressCallback& progress = {});

struct SurfaceMapRequest {
  std::string method = "bim";   // "bim" (Blended Intrinsic Maps) or "elastic"
  bool symmetric = false;       // BIM: also B -> A (elastic's bijective model always has it)
  bool strict = false;          // refuse defective inputs instead of repairing them
  BIMOptions bim;               // seed, names (for messages), landmarks in the inputs' numbering
  ElasticSettings elastic;
  // elastic: initial maps in the inputs' numbering (init_AB empty: BIM, or landmarks when
  // given; init_BA empty: B -> A by closest point on the mapped surface).
  BarycentricMap init_AB, init_BA;
  std::string init_description;  // report.json "init" for given maps ("file map_AB.txt")
  BarycentricMap truth_AB;       // optional ground truth A -> B (geodesic error in the metrics)
  // BIM (also elastic's BIM initial maps) without landmarks (reverse_candidates or not: the
  // inverse is taken by bim_prepared too): prepared surfaces of A and B (made
  // with the same seed, max_features, num_even and min_vertices as `bim`) are used instead of
  // repairing and preparing again; the map is the same.
  std::shared_ptr<const PreparedSurface> prepared_A, prepared_B;
};

struct SurfaceMapRun {
  BarycentricMap AB, BA;          // in the inputs' numbering; BA empty without a B -> A map
  SurfaceRepair repair_A, repair_B;
  BarycentricMap AB_repaired, BA_repaired;    // on repair_A.mesh / repair_B.mesh
  std::vector<int> landmarks_A, landmarks_B;  // on the repaired surfaces
  Eigen::VectorXd error_AB;       // with truth: per vertex of repair_A.mesh, -1 where not evaluated
  std::vector<std::string> notes; // input repairs and notes, one line each
  std::vector<std::string> warnings;  // said after the run (collapse guard)
  nlohmann::json report;          // method, inputs, parameters, bim / elastic, metrics
  std::string summary;            // one line for the terminal
  bool has_BA() const { return BA.size() > 0; }
};

// Throws InputError ("<name>: ...") on bad input: open, non-manifold, several pieces,
// genus > 0, fewer than bim.min_vertices vertices, mismatched maps or landmarks.
SurfaceMapRun run_surface_map(const TriMesh& A, const TriMesh& B, const SurfaceMapRequest& req,
                              const ProgressCallback& progress = {});

// Q from P: every vertex of B onto the mapped surface P(A) (A's triangulation) by closest
// point: a face of A and barycentric coordinates per vertex of B.
BarycentricMap invert_surface_map(const BarycentricMap& P, const TriMesh& A, const TriMesh& B);

// The surface-map metrics of P: S -> T (elastic-correspondence.txt Sec. 6.1), as
// report.json's metrics.AB / BA; reversibility when Q is given, geodesic error against
// `truth` when given (vertex_error: per vertex of S, -1 where not evaluated).
nlohmann::json surface_map_metrics_json(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                                        const BarycentricMap* Q, const BarycentricMap* truth,
                                        Eigen::VectorXd* vertex_error = nullptr);

}  // namespace shapemap
