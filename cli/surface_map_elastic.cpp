// The --elastic-* options of `shapemap surface-map` (elastic-correspondence.txt); the
// method itself runs in the library (shapemap/surface/surface_map_pipeline.h).
#include "surface_map_elastic.h"

#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"


namespace shapemap::cli {

namespace {

// The model, its weights and schedule, the projection and the collapse guard.
void add_elastic_model_options(CLI::App* app, ElasticSettings& o) {
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
  app->add_flag("--elastic-plain-projection-in-ramp", o.plain_projection_in_ramp,
                "elastic: the plain P/Q steps while beta ramps up (Sec. 5.2), the safe ones after it");
  app->add_flag("--elastic-keep-worse", o.keep_worse,
                "elastic: return the last iterate even when it has more flipped or collapsed "
                "triangles than the initial map (default: the collapse guard keeps the latest "
                "iterate that has no more, or the initial map; report.json: elastic.guard)");
  app->add_flag("--elastic-guard-before-untangling", o.guard_before_untangling,
                "elastic: the collapse guard judges the refinement's iterates alone (default: when "
                "it sets the last iterate aside, that iterate untangled is returned if it then has "
                "no more flipped or collapsed triangles than the initial map)");
}

// Our stages around Algorithm 1: the untangling of the returned maps and the feature anchors.
void add_elastic_stage_options(CLI::App* app, ElasticSettings& o) {
  app->add_flag("--elastic-no-untangle", [&o](std::int64_t) { o.untangle = false; },
                "elastic: return the refined maps as they are (default: a final stage slides the "
                "images around flipped or collapsed triangles on the target, minimizing a "
                "symmetric Dirichlet energy with a barrier on the mapped triangles' signed "
                "area, and keeps a region's change only where the fold count falls; "
                "docs/methods.md)");
  app->add_flag("--elastic-no-wide-untangle", [&o](std::int64_t) { o.wide_untangle = false; },
                "elastic: skip the untangling's second pass (default: what the first pass leaves, "
                "mostly patches mapped mirrored, is untangled again over regions of 4 and 8 rings "
                "with 200 sweeps, kept only where the fold count falls; docs/methods.md)");
  app->add_flag("--elastic-no-sliver-untangle", [&o](std::int64_t) { o.sliver_untangle = false; },
                "elastic: leave slivers (default: a last pass relaxes the regions around mapped "
                "triangles squashed nearly flat, MIPS - 2 > 10, and keeps a region's change only "
                "where the sliver count falls and the fold count does not rise; docs/methods.md)");
  app->add_flag("--elastic-no-bridge-untangle", [&o](std::int64_t) { o.bridge_untangle = false; },
                "elastic: leave folds with a corner mapped across a thin part of the target (default: "
                "a last stage re-seats such a corner at the closest point to its neighbours' images "
                "over the whole target before relaxing its region, kept only where the fold count "
                "falls; docs/methods.md)");
  app->add_flag("--elastic-no-search-untangle", [&o](std::int64_t) { o.search_untangle = false; },
                "elastic: leave the folds the other stages leave (default: a last stage re-seats each "
                "corner of a fold at the best point of a grid on the target faces near its "
                "neighbours' images, kept only where the folds around it do not rise; "
                "docs/methods.md)");
  app->add_option("--elastic-untangle-passes", o.untangle_passes,
                  "elastic: repeat the untangling's stages at most this many times while a pass "
                  "lowers the flipped + collapsed count of both maps (default 3; 1: one pass; "
                  "docs/methods.md)")
      ->check(CLI::Range(1, 100));
  app->add_flag("--elastic-no-collapsed-parts", [&o](std::int64_t) { o.collapsed_parts = false; },
                "elastic: start from the initial maps as they are (default: the parts they collapse, "
                "e.g. thin parts that BIM's conformal maps shrink to a point, are first put back at "
                "their own shape by as-rigid-as-possible and projected; ours, docs/methods.md)");
  app->add_flag("--elastic-no-feature-anchors", [&o](std::int64_t) { o.feature_anchors = false; },
                "elastic: no anchors (default: the AGD maxima that the initial maps send onto each "
                "other, or the landmarks, keep their partners through the refinement; ours, "
                "docs/methods.md)");
  app->add_option("--elastic-anchor-weight", o.anchor_weight,
                  "elastic: weight of the anchors' term, times beta and the vertex's mass "
                  "(default 10; 0: only their fixed rows of P and Q)")
      ->check(non_negative());
  app->add_option("--elastic-anchor-activation", o.anchor_activation,
                  "elastic: an anchor holds once the refinement moves its vertex's image farther "
                  "than this from its partner (unit-area frames; default 0.01; 0: from the start)")
      ->check(non_negative());
  app->add_flag("--elastic-anchors-hold-to-end", o.anchor_hold_to_end,
                "elastic: anchors hold to the last outer iteration (default: they let go once beta "
                "has reached its final value, Sec. 5.2's ramp, so that the patch around each "
                "relaxes)");
  app->add_option("--elastic-anchor-tolerance", o.anchor_tolerance,
                  "elastic: a pair of AGD maxima is an anchor when the initial maps send each within "
                  "this distance of the other (unit-area frames; default 0.005)")
      ->check(non_negative());
}

// The Y steps' L-BFGS: iterations, stopping tolerances, bending mask, preconditioner.
void add_elastic_solver_options(CLI::App* app, ElasticSettings& o) {
  app->add_option("--elastic-inner-iterations", o.inner_iterations,
                  "elastic: at most this many L-BFGS iterations per Y step (Sec. 5.1: 50)")
      ->check(non_negative());
  app->add_option("--elastic-inner-f-tol", o.inner_f_tol,
                  "elastic: a Y step stops when an iteration lowers E by less than this times "
                  "max(1, |E|) (default 1e-6)")
      ->check(non_negative());
  app->add_option("--elastic-ramp-inner-f-tol", o.ramp_inner_f_tol,
                  "elastic: the same during the beta ramp (default 1e-5; 0: as "
                  "--elastic-inner-f-tol; docs/methods.md)")
      ->check(non_negative());
  app->add_option("--elastic-start-inner-f-tol", o.start_inner_f_tol,
                  "elastic: the same during the first 40 outer iterations (default 1e-7: lets the "
                  "map leave its start's basin while beta is small; 0: as the ramp's; "
                  "docs/methods.md), when the initial maps fold enough triangles (below)")
      ->check(non_negative());
  app->add_option("--elastic-start-min-folds", o.start_min_folds,
                  "elastic: the tighter start runs only when an initial map has at least this "
                  "fraction of its triangles flipped or collapsed (default 0.001; 0: always)")
      ->check(CLI::Range(0.0, 1.0));
  app->add_option("--elastic-mask-tol", o.mask_tol,
                  "elastic: a Y step whose line search fails leaves out of the bending term (Eq. 9) "
                  "the edges of triangles of Y below this fraction of their rest area and carries on "
                  "(default 0.01; 0: off, Sec. 5.2's mask only; docs/methods.md)")
      ->check(CLI::Range(0.0, 1.0));
  app->add_flag("--elastic-no-precondition", o.no_precondition,
                "elastic: plain L-BFGS in the Y steps (default: initial inverse Hessian from "
                "the cotangent Laplacian and the mismatch terms, docs/methods.md)");
  app->add_flag("--elastic-unit-first-step", o.unit_first_step,
                "elastic: every Y-step line search tries the unit step first (default: after "
                "the first iteration, the step that repeats the last decrease, docs/methods.md)");
}

}  // namespace

void add_elastic_options(CLI::App* app, ElasticSettings& o, std::string& truth_ab) {
  add_elastic_model_options(app, o);
  add_elastic_stage_options(app, o);
  add_elastic_solver_options(app, o);
  app->add_option("--truth", truth_ab,
                  "ground-truth map A->B (map file) for the geodesic error in report.json");
}

BarycentricMap read_checked_map(const std::string& path, int n_source, int m_target) {
  BarycentricMap m = read_map(path);
  validate_map(m, n_source, m_target, 3, path);
  return m;
}

}  // namespace shapemap::cli
