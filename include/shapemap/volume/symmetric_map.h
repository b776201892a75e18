// Symmetric volume maps between tetrahedral meshes (symmetric-volume-maps.txt,
// Abulnaga, Stein, Golland, Solomon 2023): two maps, phi: M1 -> M2 and psi: M2 -> M1,
// each represented twice (Sec. 4.2): P_ij (vertex -> tet of the target + barycentric,
// "inside the target") and X_ij (free vertex positions, X_ij ~ P_ij V_j), found by
// block-coordinate descent on Eq. 25 with the five stages of Algorithm 1.
//
//   E = alpha E_ARAP + (1 - alpha) E_R + gamma E_P + beta E_Q                 (Eq. 25)
//   E_ARAP  Eq. 20 (sarap.h)
//   E_R  = sum_{i!=j} 1/c_i^2      || P_ij X_ji - V_i ||^2_{M_i}               (Eq. 18)
//   E_Q  = sum_{i!=j} 1/(c_i c_j)  || X_ij - P_ij V_j ||^2_{M_i}               (Eq. 17)
//   E_P  = E_P,f + E_P,b                                                       (Eq. 23)
//   E_P,f = sum 1/s_i || (X_ij)_dMi - proj((X_ij)_dMi, dM_j) ||^2_{dM_i}       (Eq. 21)
//   E_P,b = sum 1/s_i || V_i - proj(V_i, dF_j(X_ji)) ||^2_{dM_i}               (Eq. 22)
//   ||G||^2_M = tr(G^T C G), C the lumped vertex mass (volumes for M_i, boundary
//   areas for dM_i); c_i total volume, s_i total boundary area.
//
// Both meshes are first scaled to unit volume (Sec. 5.5); results come back in the
// target's original coordinates.
#pragma once
#include "shapemap/geometry/closest_point.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/optim/block_hessian.h"
#include "shapemap/progress.h"
#include "shapemap/volume/inversion_barrier.h"
#include "shapemap/volume/sarap.h"
#include <memory>
#include <string>
#include <utility>
#include <functional>
#include <vector>

namespace shapemap {

// The X-step solver (Sec. 5.2 uses L-BFGS; Sec. 8.1 names a second-order method as the way
// forward: projected Newton with the analytic ARAP eigensystem, issue 19).
enum class XStepSolver { Newton, Lbfgs };

struct SymmetricVolumeMapOptions {
  XStepSolver solver = XStepSolver::Newton;
  int newton_iterations = 2;   // Newton iterations per X-step at most (each ends earlier on
                               // newton_rel_tol: a relative decrease of Eq. 25 below it)
  double newton_rel_tol = 1e-7;
  // Ours (issue 19): Newton iterations per X-step at most in stage 4 once beta and gamma
  // are final. With the P's eliminated (and the joint X-step) an X-step is Newton on Eq. 25
  // itself, so Algorithm 1's "X <- argmin" is taken further than the 2 steps that suffice
  // while the weights still change: stage 4 then ends on its decrease rule on the real
  // bench pairs instead of its 50-iteration cap (docs/methods.md); 0 = newton_iterations.
  int newton_iterations_final = 10;
  // Ours (issue 19, speed; off by default): > 0 lets each joint X-step keep the Cholesky
  // factors of its Hessian blocks as the conjugate-gradient preconditioner of its later
  // Newton steps while CG needs at most this many iterations (NewtonOptions::refactor_cg).
  // On cat -> lion with 12, stage 4 took 22.7 s instead of 31.5 s (factor 5.4 s instead of
  // 13.8), metrics as good; on airplane -> bird the run ended with 5 / 7 inverted tets
  // instead of 1 / 0 and its landing took 678 s instead of 125 s (docs/methods.md).
  int newton_refactor_cg = 0;
  // Joint X-steps: the conjugate-gradient solve of each Newton system stops when its
  // preconditioned residual is this fraction of the first (NewtonOptions::cg_rel_tol).
  double newton_cg_rel_tol = 1e-3;
  double alpha = 0.5;          // Eq. 25, Sec. 5.5: rigidity (ARAP) vs reversibility (E_R)
  // Ours (issue 19): >= 0 and != alpha: once stage 4 has converged at alpha, it runs again
  // (stage "full-reversible") at this alpha from the map found at alpha; stage 5 and the
  // landing then use alpha again. From the start, alpha = 0.2 tripled the largest error on the
  // generated pair with ground truth; as a continuation it lowers E_R on every real bench pair
  // (docs/methods.md, "A second stage 4 at a lower alpha"). < 0 = off (the paper's alpha).
  // 0.005 since the 38th session (was 0.1): E_R 0.14-0.88x of 0.1's on 11 bench pairs, E_ARAP
  // -15% ... +37%, the truth error on the generated pairs within 0.2% (docs/methods.md,
  // "alpha_final = 0.005").
  double alpha_final = 0.005;
  double gamma = 25.0;         // Eq. 25, Sec. 5.5: weight of the projection term E_P
  double beta_start = 0.25;    // Sec. 4.4: E_Q weight at the first iteration ...
  double beta_end = 5.0;       // ... increased linearly to this ...
  int beta_ramp_iterations = 20;  // ... over this many outer iterations (Sec. 4.4, 5.5)
  double gamma_start = -1;     // >= 0: gamma ramps linearly from this to gamma over the
                               // beta_ramp_iterations (the authors' code: both from 1/N);
                               // < 0: gamma constant (the paper's Sec. 5.5)
  // Eq. 23: E_P = E_P,f + scale * E_P,b (paper: 1; the authors' code: 10). 2, tuned on the real
  // bench (docs/methods.md, "The backward projection's weight"): d-hat lower on cat -> lion,
  // airplane -> bird and gen-30k, mixed on glasses and busts; E_R higher on most.
  double backward_projection_scale = 2.0;
  // Stopping rules of stages 2 and 4 (Sec. 5.4). The decrease rule only applies once
  // beta has reached beta_end (while beta grows, Eq. 25 itself changes).
  double grad_tol = 1e-6;      // Sec. 5.4 (i): ||grad E||_2 (free variables) after the X-steps
  double decrease_tol = 1e-7;  // Sec. 5.4 (ii): E_prev - E between outer iterations ...
  double decrease_rel_tol = 1e-6;  // ... or below this times E (ours: on real pairs stage 2
                                   // sat at E = 28.87 falling 4e-7 per iteration for 150)
  int max_iterations = 50;     // Sec. 5.4 (iii): outer iterations per stage (stage 4)
  // Stage 2 (boundary fixed), ours. Where the fixed boundary forces folds (the busts: ~3k
  // inverted tets that only freeing the boundary undoes), Eq. 25 creeps down as the folded
  // tets take up the distortion of their neighbours: a projected Newton step, blind to the
  // negative curvature there, is accepted whole and moves far less than the descent allows.
  // So an accepted full step is doubled up to this many times while Eq. 25 keeps falling
  // (NewtonOptions::max_expansions), and stage 2's cap is this factor times max_iterations
  // (150 outer iterations of 2 Newton steps each by default, where Sec. 5.4 caps 50 X-steps
  // taken to convergence). Measured on the busts (docs/methods.md, "Stage 2's creep").
  int boundary_fixed_expansions = 6;
  int boundary_fixed_iteration_factor = 3;
  int min_iterations = 1;      // outer iterations before a stopping rule may apply
  // Ours (issue 19): Anderson acceleration (optim/anderson.h) of the P/X alternation of
  // stages 2 and 4 with this memory, once beta and gamma are final; each proposal is kept
  // only if Eq. 25 after its P-step is below the last X-step's energy. 0 = off. Default 5
  // since the X-steps eliminate P (fewer inverted tets on all four real bench pairs but
  // cat -> lion A -> B, docs/methods.md).
  int anderson_memory = 5;
  // Ours (issue 19): Newton X-steps on Eq. 25 with both P's eliminated (re-solved at every
  // trial X; DirectionalEnergy::add_eliminated_p_hessian). The alternation of fixed-P steps
  // moves X and P together by about a/(a + b) of the way per iteration (b, a the weights of
  // E_Q and E_R: 1/11 at beta = 5, alpha = 0.5), so stage 4 crawled on real pairs. Newton
  // solver only.
  bool eliminate_p = true;
  // Ours (issue 19): with eliminate_p, both directions' X-steps as one Newton step with the
  // blocks that couple X_ij and X_ji through the eliminated P's (coupled_newton.h); false:
  // one step per direction, each holding the other's X.
  bool joint_xstep = true;
  int xstep_iterations = 15;   // L-BFGS iterations per X-step (Sec. 5.2; not in the paper:
                               // 15 gave the same maps as 30 on a 30k-tet pair at half the
                               // cost, docs/methods.md)
  int repair_iterations = 200; // Sec. 5.3: L-BFGS iterations of the inverted-tet repair
  int repair_rings = 1;        // Sec. 5.3: 1-ring neighbourhood of inverted tets' vertices
  int post_repair_steps = 100; // Sec. 5.4 stage 5: at most 100 L-BFGS steps ...
  int post_repair_rounds = 5;  // ... per round, rounds while inversions remain (ref. code: 5)
  // Ours: when those rounds (vertices of inverted tets only) leave inverted tets, as many
  // rounds again on this many rings around them (stage 3's neighbourhood), and stage 5 is
  // undone per direction unless it lowered the inverted count; 0 = off (the paper's stage).
  int post_repair_fallback_rings = 1;
  // The authors' released code (not in the paper): in stage 5 (and the landing's repair),
  // ARAP plus a 6th-order penalty on signed singular values below 0.1 (sarap.h).
  SigmaPenalty post_repair_penalty;
  // Ours (issue 19), after stage 5: the boundary of X projected onto the target's boundary,
  // the interior relaxed with it held (Newton, at most land_newton_iterations, then the
  // Sec. 5.3 repair on interior vertices); per direction the result replaces X unless its
  // located copy inverts more tets than stage 5's X located in the target ("snapped"). X is
  // then exactly what the map files (barycentric coordinates in the target) hold.
  bool land_on_target = true;
  int land_newton_iterations = 10;
  // Ours: before the projection, gamma (Eq. 25) is raised land_gamma_rounds times by
  // land_gamma_factor with every vertex free (Newton, land_newton_iterations per round,
  // closest points recomputed each evaluation), so the boundary approaches dM_j sliding
  // along it, ARAP spreading the motion; the final projection then moves it little.
  // 0 rounds = project at once.
  int land_gamma_rounds = 2;
  double land_gamma_factor = 4.0;
  // Ours: after those rounds, where a vertex of dM_j is farther than this many mean target
  // edges from the image of dM_i (the image's triangles span a ridge or a crease there),
  // one more round raises gamma by land_gamma_factor there alone: E_P,b of dM_j's vertices
  // within 2 rings of such a vertex and E_P,f of dM_i's vertices whose images lie within 3
  // mean edges of one (docs/methods.md, "A local gamma round where the image does not
  // cover the target"). Only where at most 1% of dM_j's vertices are that far (a local
  // miss, not surfaces that differ broadly). <= 0: off. 0.35 until the forty-third session.
  double land_uncovered_edges = 0.3;
  // Landing's repair: boundary vertices of inverted tets slide along dM_j, held near their
  // starting points by a spring this many times softer than the one to dM_j (ours).
  double land_slide_anchor = 0.03;
  // Ours: the landing keeps every tet that is positive when it starts positive: the clamped
  // log barrier of inversion_barrier.h on det J below this floor is added to Eq. 25, the
  // Newton line search rejects a step that turns a tet over, and the projection puts a
  // boundary vertex on dM_j, or just inside M_j, only where its tets stay positive (vertices
  // that cannot are located, i.e. snapped, at the end). 0 = off (the landing before).
  double land_barrier_floor = 0.1;
  // With the barrier: passes in which the interior and the boundary vertices that could not
  // be put on dM_j relax (gamma at its last continuation value), then try again (ours).
  int land_passes = 3;
  // With the barrier: rounds that pull images still outside M_j (after the passes) to anchors
  // just inside it, with springs that stiffen each round (ours; cat -> lion A -> B: 38 rows
  // outside, whose snap turned 154 tets over; with 6 rounds 37 inverted, B -> A 0). 0 = off.
  int land_pull_rounds = 6;
  // Last, the located map's inverted tets untangled in M_j (max-min ascent of the volumes,
  // untangle.h), at most this many sweeps (ours). 0 = off.
  int land_untangle_rounds = 30;
  int land_untangle_rings = 1;  // UntangleRules::rings (0: the folded tets' vertices alone)
  // Then, while tets are inverted, the regularized untangling of Garanzha et al. 2021
  // (foldover_free.h) around them, with 1, 2, 4, ... up to this many rings of vertices free,
  // each kept when it inverts fewer tets (ours). 0 = off.
  int land_regularized_rings = 8;
  // Last (ours): boundary vertices that the repairs left inside M_j go back to dM_j, or
  // toward it, where their tets stay positive (d^, Eq. 27-28).
  bool land_return_rows = true;
  // Last (ours): rounds that make the two maps' boundaries mutually inverse (Eq. 18 on the
  // boundary; reconcile_boundary.h). 0 = off.
  int land_reconcile_rounds = 6;
  // A move of the reconciliation is refused when it leaves a vertex of dM_j farther than
  // this many mean boundary edges from the image of dM_i, and farther than it was
  // (target_coverage.h).
  double land_reconcile_gap = 0.1;
  // ... and when one of the moved vertex's tets keeps less than this fraction of its det J,
  double land_reconcile_det = 0.5;
  // ... or their ARAP energy (Eq. 20) rises by more than this fraction of itself: the
  // reconciliation trades E_ARAP for E_R (cat -> lion, without this guard: E_R -35%, E_ARAP
  // +8%; 0.2 against 0.1 on the bench: E_R -7% to -48%, E_ARAP +4.2% at most; "Mutually
  // inverse boundaries" in docs/methods.md).
  double land_reconcile_arap = 0.2;
  // Last (ours): with alpha_final in use, both interiors relax together at alpha_final
  // (stage 4's joint X-steps, boundaries held where the landing put them, the inversion
  // barrier on); the landing's own relaxations ran at alpha, one map held.
  bool land_interior_final = true;
  // Sec. 5.1 copies each interior vertex's target from its closest boundary vertex, which
  // folds the interior of X onto its boundary. Ours: with this set the interior rows of X
  // start at the harmonic extension of its boundary rows instead (harmonic_extension.h), so
  // the boundary-fixed stage starts from a map that is not collapsed (docs/methods.md).
  bool harmonic_interior = false;
  bool fix_boundary_first = true;  // Algorithm 1 lines 6-10 (stage 2): boundary of X fixed,
                                   // boundary rows of P restored each iteration
  bool boundary_to_boundary = false;  // Sec. 5.2: hard constraint P in P*_ij (boundary rows
                                      // projected onto boundary faces); Eq. 24 uses P_ij
  int lbfgs_memory = 10;
};

// One stage of Algorithm 1, for the report.
struct SymmetricMapStage {
  std::string name;
  int iterations = 0;        // outer iterations (stages 2, 4) or L-BFGS iterations (3, 5)
  double seconds = 0;
  double energy = 0;         // Eq. 25 at the end of the stage (weights of the last iteration)
  int inverted12 = 0, inverted21 = 0;  // det J <= 0 in X_12, X_21 at the end
  double time_pstep = 0, time_xstep = 0;  // seconds in P-steps / X-steps (stages 2, 4)
  int lbfgs_iterations = 0, evaluations = 0; // X-step solver iterations and energy evaluations
                                             // (stages 2, 4; Newton or L-BFGS)
  double newton_seconds[4] = {0, 0, 0, 0};   // Newton X-steps, both directions: energy
                                             // evaluations, Hessian assembly, factorization,
                                             // solves
  int anderson_accepted = 0, anderson_rejected = 0;  // accelerated points kept / undone
  int cg_iterations = 0;     // joint X-steps: conjugate-gradient iterations of the solves
  int factorizations = 0;    // joint X-steps: numeric Cholesky factorizations (newton_refactor_cg)
  int land_unprojected = 0;  // landing: boundary vertices put inside M_j or left, not on dM_j
  int land_returned = 0;     // landing: boundary vertices put back from inside M_j toward dM_j
  int land_uncovered = 0;    // landing: vertices of dM_j the local gamma round pulled the image to
  int land_reconciled = 0;   // landing: boundary images moved to make the two maps mutually inverse
  int relocated12 = 0, relocated21 = 0;  // interior-reversible: interior rows put back where
                             // locating them in M_j turned a tet over (-1: the whole stage undone)
  std::string stop_reason;   // "gradient", "decrease", "iterations" (stages 2, 4)
  std::vector<double> energy_history, gradient_history;  // per outer iteration
};

struct SymmetricVolumeMapResult {
  Eigen::MatrixXd X12, X21;  // n1×3 in M2's original coordinates, n2×3 in M1's
  BarycentricMap P12, P21;   // the P variables (Sec. 4.2), vertex -> target tet
  BarycentricMap map12, map21;  // the map files of the CLI: with land_on_target, X itself
                                // (X12 = map12 applied to B); else X located in the target,
                                // boundary vertices snapped to the target boundary
  std::vector<SymmetricMapStage> stages;
  // Eq. 25 terms at the end, unit-volume frame, final weights.
  double E = 0, E_arap = 0, E_R = 0, E_P = 0, E_Q = 0;
  int iterations = 0;        // outer iterations, stages 2 + 4
};

// Algorithm 1. A, B: valid tet meshes (positively oriented). init12: each vertex of A ->
// tet of B + barycentric; init21 likewise (Sec. 5.1). Throws InputError on mismatched maps.
SymmetricVolumeMapResult symmetric_volume_map(const TetMesh& A, const TetMesh& B,
                                              const BarycentricMap& init12,
                                              const BarycentricMap& init21,
                                              const SymmetricVolumeMapOptions& opt = {},
                                              const ProgressCallback& progress = {});

// ---- Initializations (Sec. 5.1) -------------------------------------------------

// Landmarks: LA[k] (vertex of A) <-> LB[k] (vertex of B). Every vertex of A copies the
// target of its closest landmark (Euclidean, in A). Returns the A -> B map (a tet of B
// incident to LB[k], barycentric 1 at that corner). Throws InputError on count mismatch
// or out-of-range indices.
BarycentricMap landmark_initial_map(const TetMesh& A, const TetMesh& B, const std::vector<int>& LA,
                                    const std::vector<int>& LB);

// From the images of A's boundary vertices: boundary_targets is nb×3 (row i: image of
// boundary vertex boundary_surface(A).to_volume[i], in B's coordinates), snapped to B's
// boundary; every interior vertex copies the target of its closest boundary vertex
// (Sec. 5.1, "every boundary vertex is a landmark").
BarycentricMap boundary_initial_map(const TetMesh& A, const TetMesh& B,
                                    const Eigen::MatrixXd& boundary_targets);

// From a surface map between the boundary surfaces: map_AB takes each vertex of SA to a
// face of SB + barycentric, where SA, SB are the surfaces the map was computed on (the
// boundary surfaces of A and B, or the closed surfaces A and B were tetrahedralized
// from: A's boundary vertices are located on SA by closest point).
BarycentricMap surface_initial_map(const TetMesh& A, const TetMesh& B, const TriMesh& SA,
                                   const TriMesh& SB, const BarycentricMap& map_AB);

// The automatic mode: a surface map between two closed genus-0 surfaces in both
// directions (BIM, then, when `elastic_refinement`, the elastic method exactly as
// `surface-map --method elastic` runs it: surface/refine_surface_maps.h, refinement, collapse
// guard and untangling). Returns {map_AB, map_BA} (vertex -> face + barycentric). `used`
// receives a short description of the method. elastic: the elastic settings (null: the
// surface-map command's defaults). landmarks_A/B (vertices of SA / SB, k >= 3 pairs, or
// none): the initial maps are BIM guided by the landmarks (BIMOptions::landmark_feature_points)
// and the landmarks anchor the elastic refinement, as `surface-map --method elastic --landmarks` does. reverse_candidates
// (without landmarks only): BIMOptions::reverse_candidates (surface-map's default: the less
// confident direction takes the inverse of the other's blend). (elastic_refinement, elastic,
// landmarks, reverse_candidates: added, backward compatible.)
struct ElasticSettings;
std::pair<BarycentricMap, BarycentricMap> surface_map_for_volumes(const TriMesh& SA,
                                                                  const TriMesh& SB,
                                                                  const ProgressCallback& progress = {},
                                                                  std::string* used = nullptr,
                                                                  bool elastic_refinement = true,
                                                                  const ElasticSettings* elastic = nullptr,
                                                                  const std::vector<int>& landmarks_A = {},
                                                                  const std::vector<int>& landmarks_B = {},
                                                                  bool reverse_candidates = true);

// Locates positions X (k×3) in the tet mesh M: a containing tet (or the closest one);
// rows listed in `boundary_rows` are instead snapped to the closest point of M's
// boundary surface (face -> its tet, 4th coordinate 0). `outside`, if given, receives how
// many positions lay outside every tet (they went to the closest tet, coordinates clamped).
BarycentricMap locate_in_tets(const TetMesh& M, const Eigen::MatrixXd& X,
                              const std::vector<int>& boundary_rows = {}, int* outside = nullptr);

// ---- The objective of one direction, exposed for tests ----------------------------

// The part of Eq. 25 that depends on X_ij with P_ij, P_ji fixed (Sec. 5.2, X-step):
//   alpha/(2c_i) sum_k v_k f(J_k(X_ij))                    [E_ARAP, Eq. 20]
// + (1-alpha)/c_j^2 || P_ji X_ij - V_j ||^2_{M_j}           [E_R, Eq. 18, term (j,i)]
// + gamma/s_i sum_{b in dM_i} a_b |X_ij(b) - proj(X_ij(b), dM_j)|^2          [Eq. 21]
// + gamma*scale/s_j sum_{b in dM_j} a_b |V_j(b) - proj(V_j(b), dF_i(X_ij))|^2 [Eq. 22]
// + beta/(c_i c_j) || X_ij - P_ij V_j ||^2_{M_i}            [E_Q, Eq. 17]
// Meshes are used as given (normalize them first to follow the paper).
class DirectionalEnergy {
 public:
  struct Terms {
    double arap = 0, reversibility = 0, projection_forward = 0, projection_backward = 0,
           auxiliary = 0, barrier = 0, anchors = 0, total = 0;  // unweighted terms, total = weighted sum
  };
  DirectionalEnergy(const TetMesh& Mi, const TetMesh& Mj);
  void set_weights(double alpha, double beta, double gamma, double backward_scale = 1.0);
  double alpha() const { return alpha_; }
  double beta() const { return beta_; }
  double gamma() const { return gamma_; }
  double backward_scale() const { return bscale_; }
  // P_ij: n_i rows -> tets of M_j; P_ji: n_j rows -> tets of M_i.
  void set_maps(const BarycentricMap& P_ij, const BarycentricMap& P_ji);
  void set_forward_map(const BarycentricMap& P_ij);   // P_ij alone
  void set_backward_map(const BarycentricMap& P_ji);  // P_ji alone
  // (1 - alpha) E_R (Eq. 18, term (j,i)) + beta E_Q (Eq. 17), the terms with P in them, as
  // they enter evaluate().
  double weighted_map_terms(const Eigen::MatrixXd& X) const;
  // Adds the inversion barrier (landing stage, inversion_barrier.h) to Eq. 25 with weight
  // 1, or removes it (nullptr). Kept by pointer: the caller owns it.
  void set_barrier(const InversionBarrier* barrier) { barrier_ = barrier; }
  // Adds k sum_r |X_r - A_r|^2 over `rows` (landing stage: pulls images that lie outside
  // M_j to points just inside it), or removes it (empty rows). Copies its arguments.
  void set_anchors(const std::vector<int>& rows, const Eigen::MatrixXd& A, double k);
  // Multiplies the lumped areas a_b of Eq. 21 (boundary vertices b of M_i with
  // marked_i[b]) and of Eq. 22 (marked_j[b], vertices of dM_j) by `factor`: gamma raised
  // there alone (landing stage). s_i, s_j stay; factor 1 (or empty flags) restores them.
  void emphasize_projection(const std::vector<char>& marked_i, const std::vector<char>& marked_j, double factor);
  // Eq. 25 (X_ij part). X: n_i×3; grad n_i×3 if non-null.
  double evaluate(const Eigen::MatrixXd& X, Eigen::MatrixXd* grad = nullptr,
                  Terms* terms = nullptr) const;
  // Adds a positive semi-definite Hessian of evaluate() at X to H (pattern: M_i's tets, any
  // free set): E_ARAP's per-tet Hessians with clamped twist eigenvalues (sarap.h); E_Q and
  // E_R exactly (quadratic in X for fixed P); E_P,f exactly for the closest points of the
  // last evaluation (2 n n^T on a face, 2 (I - e e^T) on an edge, 2 I at a vertex of dM_j);
  // E_P,b by Gauss-Newton with the closest point's barycentric coordinates held (point to
  // plane on a face of dF_i(X), point to point on an edge or a vertex).
  void add_hessian(const Eigen::MatrixXd& X, BlockHessian& H) const;
  // Ours (issue 19): the X-step with both P's eliminated. Row v of P_ij minimizes
  // b|X_v - y|^2 + a|X_ji(y) - V_i(v)|^2 over points y of M_j (E_Q of this direction, E_R of
  // the other: the P-step), row w of P_ji likewise with E_R of this direction; with the P's
  // at their minimizers, Eq. 25 as a function of X has the fixed-P gradient (envelope
  // theorem) and a Hessian with these terms replaced by their Schur complements (y's
  // response; see the .cpp; T spans the directions in which y is free: all, or along the
  // faces of the boundary it lies on). add_hessian() holds the P's fixed; this adds the
  // difference, so X and P move together in one Newton step where the alternation of
  // fixed-P steps crawls. X: this direction's X_ij, X_ji the other's (held); held_ij,
  // held_ji: rows of P_ij, P_ji that the P-step does not move (stage 2's boundary), or null.
  void add_eliminated_p_hessian(const Eigen::MatrixXd& X, const BarycentricMap& P_ij,
                                const Eigen::MatrixXd& X_ji, BlockHessian& H,
                                const std::vector<char>* held_ij = nullptr,
                                const std::vector<char>* held_ji = nullptr) const;
  // Ours (issue 19): the coupling of X_ij and X_ji when both X-steps are one Newton step
  // (the joint X-step). With row v of P_ij eliminated as above, Eq. 25's Gauss-Newton
  // Hessian has the block 2ab l_k S A^T between X_ij(v) and corner k of y's tet in X_ji
  // (l_k its barycentric coordinate, S = T (bI + a T^T A^T A T)^-1 T^T): passed to
  // add(v, vertex of M_j, block) for every row of P_ij that is not held. The other
  // direction's object gives the blocks of P_ji's rows.
  void add_coupling(const BarycentricMap& P_ij, const Eigen::MatrixXd& X_ji, const std::vector<char>* held_ij,
                    const std::function<void(int, int, const Eigen::Matrix3d&)>& add) const;
  // ARAP only (Sec. 5.3) on the tets incident to `free_vertices`.
  const ArapEnergy& arap() const { return arap_; }
  const TetBoundary& boundary_i() const { return bi_; }
  const TetBoundary& boundary_j() const { return bj_; }
  const Eigen::VectorXd& mass_i() const { return Ci_; }
  double volume_i() const { return ci_; }
  double area_i() const { return si_; }

 private:
  void projection_terms(const Eigen::MatrixXd& X, Eigen::MatrixXd* grad, bool all, Terms& t) const;
  // Row v of P_ij eliminated: the weights a, b, X_ji's Jacobian A on y's tet and S (see
  // add_coupling); false when y is held at a corner of dM_j.
  bool forward_row_schur(int v, const BarycentricMap& P_ij, const Eigen::MatrixXd& X_ji, double& a, double& b,
                         Eigen::Matrix3d& A, Eigen::Matrix3d& S) const;

  TetMesh Mi_, Mj_;
  ArapEnergy arap_;
  TetBoundary bi_, bj_;
  Eigen::VectorXd Ci_, Cj_;          // lumped tet masses
  Eigen::VectorXd ai_, aj_;          // lumped boundary areas per boundary (surface) vertex
  Eigen::VectorXd ai_rest_, aj_rest_;  // the same without emphasize_projection's factors
  double ci_ = 1, cj_ = 1, si_ = 1, sj_ = 1;
  double alpha_ = 0.5, beta_ = 0.25, gamma_ = 25, bscale_ = 1;
  Eigen::MatrixXi Fi_vol_;           // boundary faces of M_i in volume numbering
  std::vector<unsigned char> bi_faces_, bj_faces_;  // per tet: bit q = face opposite corner q on the boundary
  const InversionBarrier* barrier_ = nullptr;
  std::vector<int> anchor_rows_;     // set_anchors
  Eigen::MatrixXd anchor_pts_;
  double anchor_k_ = 0;
  ClosestPoint3 target_boundary_;    // dM_j (static)
  mutable ClosestPoint3 mapped_boundary_;  // dF_i(X): refit per evaluation
  mutable bool mapped_built_ = false;
  Eigen::MatrixXd PijVj_;            // n_i×3
  BarycentricMap Pji_;
  Eigen::MatrixXi Pji_verts_;        // n_j×4 vertices of M_i
  // E_R gradient gather (set_maps): vertex v of M_i <- entries (w, q) with
  // Pji_verts_(w, q) == v, CSR in increasing 4w+q (fixed order: deterministic).
  std::vector<int> rev_start_, rev_list_;
  // Scratch reused across evaluations (no per-evaluation allocation once sized); the
  // closest-point answers of the last evaluation are the hints of the next (Sec. 5.2:
  // consecutive L-BFGS iterates move little). Not thread-safe, like ArapEnergy.
  mutable Eigen::MatrixXd Qf_, Dr_;
  mutable Eigen::VectorXd ef_, eb_, er_, eq_;
  mutable std::vector<ClosestPointResult> hits_f_, hits_b_;
  mutable Eigen::MatrixXd last_X_;  // X of the last evaluation (the hits above belong to it)
};

}  // namespace shapemap
