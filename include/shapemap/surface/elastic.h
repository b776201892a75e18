// Elastic, crease-aware correspondence between two triangle meshes
// (elastic-correspondence.txt, Ezuz, Heeren, Azencot, Rumpf, Ben-Chen 2019).
//
//   E_inj(Y, P)        = W_def(X, Y) + beta |P X~ - Y|_X^2                         (Eq. 4)
//   E_bij(Y, Y~, P, Q) = W_def(X, Y) + beta |P X~ - Y|_X^2
//                      + W_def(X~, Y~) + beta |Q X - Y~|_X~^2
//                      + gamma |P Y~ - X|_X^2 + gamma |Q Y - X~|_X~^2              (Eq. 6)
// with W_def the thin-shell energy (shell_energy.h, Eq. 2/7/9), |A|_X^2 = tr(A^T M_X A)
// with the lumped mass matrix (Eq. 3), and P (n×n~), Q (n~×n) barycentric projection
// matrices (one triangle and 3 coordinates per row = a BarycentricMap).
//
// Algorithm 1 (alternating): P <- projection of the rows of B = [sqrt(beta) Y, sqrt(gamma) X]
// onto the target triangulation embedded in R^6 with vertex coordinates
// A = [sqrt(beta) X~, sqrt(gamma) Y~] (a ClosestPoint6 BVH, built once and refit every
// outer iteration); Y <- L-BFGS with Armijo backtracking; then Q and Y~ symmetrically.
// The injective model has only the P and Y steps (gamma = 0: a projection in R^3).
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/progress.h"
#include <Eigen/Core>
#include <vector>

namespace shapemap {

// Anchored vertex pairs (ours, issue 20; feature_anchors.h finds them): A[k] <-> B[k]. The P
// step fixes P's row A[k] at vertex B[k] (and Q's row B[k] at A[k]), and the Y step adds
//   weight * beta * sum_k m_A[k] |Y_A[k] - X~_B[k]|^2  (+ the same for Y~ with m~, X)
// to the mismatch term of Eq. 4/6: with weight 0 the fixed rows alone pull as one vertex of
// the mismatch term does. An anchor holds (row fixed, term on) only from the first P step that
// puts its vertex farther than `activation` from its partner (unit-area frames; per direction):
// where the refinement keeps the pair together (near-isometric pairs) it changes nothing.
// Empty = none (the paper's Algorithm 1).
struct ElasticAnchors {
  std::vector<int> A, B;
  double weight = 10;
  double activation = 0.01;  // 0 = holding from the start
  // Let go once beta has reached beta_end (outer iteration beta_ramp_iterations): the tips are
  // placed while the map moves far (the ramp), and the last iterations relax the patch
  // around each held vertex, where a held row can leave a fold (docs/methods.md).
  bool release_after_ramp = true;
};

enum class ElasticModel {
  Injective,  // E_inj, Eq. 4 (near-isometric and partial matching)
  Bijective,  // E_bij, Eq. 6 (non-isometric; reversibility terms)
};

struct ElasticOptions {
  ElasticModel model = ElasticModel::Bijective;  // Sec. 3.1 / 3.2
  double alpha = 20.0;            // membrane weight, Eq. 2 (Sec. 5.2: alpha = 20)
  double eta = 0.1;               // bending weight, Eq. 2 (Sec. 6.1 SHREC'07, non-isometric)
  double lambda = 1.0, mu = 1.0;  // Lame coefficients, Eq. 7 (Sec. 4.1: lambda = mu = 1)
  double log_eps = 1e-4;          // Sec. 4.1: -log det G linearly extended below eps
  double degenerate_tol = 1e-8;   // Sec. 5.2 masking edge sets: |n_t(Y)| <= tol |n_t(X)|
  // When a Y step's line search fails (from the L-BFGS direction and again from -K^-1 g), the
  // step freezes the admissible set again without the edges of slivers of Y, triangles below
  // this fraction of their rest area, and carries on (ShellEnergyOptions::mask_tol; ours,
  // issue 20). At a sliver the bending term of Eq. 9 is all but discontinuous: on SHREC'07
  // busts no Y step accepted an iteration over the last 150 of 200 outer iterations, the map
  // frozen while beta grew (docs/methods.md, "Slivers and the bending mask"). The membrane's
  // barrier opens the slivers; the next Y step starts from the paper's set again. 0 = off.
  double mask_tol = 1e-2;
  double beta_start = 1e3;        // mismatch penalty, Eq. 4/6 (Sec. 5.2: from 1e3 ...
  double beta_end = 2e5;          //   ... linearly to 2e5 ...
  int beta_ramp_iterations = 200; //   ... over the first 200 outer iterations)
  double gamma = 2e4;             // reversibility penalty, Eq. 6 (Sec. 5.2: 2e4); gamma~ = gamma
  // Ramp gamma from 0 with beta's schedule (our addition, issue 20; the paper keeps it fixed):
  // at gamma = 20 beta the first P step's R^6 closest point compares X with the chords
  // Y~ = Q X and collapses triangles (docs/methods.md).
  bool gamma_ramp = false;
  // P / Q step that never folds a mapped triangle that was fine (issue 20, our addition): the
  // projection's energy is a sum over rows, so rows that would flip or collapse a triangle
  // keep their previous value and E still does not increase. false = Sec. 5.1's P step, the
  // plain argmin, whose R^6 closest points can collapse whole patches (docs/methods.md).
  bool safe_projection = true;
  // ... also during the beta ramp (Sec. 5.2). false: the plain P step while beta ramps up (Y is
  // free enough then to carry a patch that BIM squeezed out again), the safe one after it
  // (docs/methods.md, "The three projections on the surface bench").
  bool safe_projection_in_ramp = true;
  int max_outer_iterations = 300; // Algorithm 1: K = 300
  // Algorithm 1 stop: |E_k - E_{k-1}| < energy_tol * |E_k|, tested once beta has reached
  // beta_end (before, E changes because beta does). 0 = always run K iterations.
  double energy_tol = 1e-5;
  int inner_max_iterations = 50;  // Sec. 5.1: at most 50 quasi-Newton iterations
  double inner_tol = 1e-8;        // Sec. 5.1: stopping criterion 1e-8 (||grad||_inf)
  // Inner stop on stalled progress: f_old - f_new < inner_f_tol * max(1, |f|) (0 = off;
  // our addition, see docs/methods.md: later outer iterations start near the optimum).
  // 1e-6 since issue 20's speed work (was 1e-9): with the preconditioned Y steps below the
  // result at 10k vertices is as good as with 1e-9 before, with far fewer evaluations.
  double inner_f_tol = 1e-6;
  // The same stop during the beta ramp (outer iterations below beta_ramp_iterations), where
  // the next outer iteration changes beta anyway (0 = inner_f_tol). Issue 20: 1e-5
  // (docs/methods.md, "Speed at 10k vertices").
  double inner_f_tol_ramp = 1e-5;
  // The same stop during the first inner_f_tol_start_iterations outer iterations, while beta
  // is still small and the map can move far from its start (Sec. 5.2, "beta"); 0 = as above.
  // Issue 20: with 1e-6 / 1e-5 from the start, a 1,500-vertex pair whose BIM map has flipped
  // triangles stays in BIM's basin (geodesic error 0.040 -> 0.037 instead of -> 0.013); 1e-7
  // over the first 40 outer iterations leaves it (not 30), docs/methods.md.
  double inner_f_tol_start = 1e-7;
  int inner_f_tol_start_iterations = 40;
  // ... and only when an initial map has at least this fraction of its source's triangles
  // flipped or collapsed (the larger of the two directions; issue 20 speed, our addition): a
  // start with a few isolated folds needs no far deviation, and at 10k vertices a side (1 of
  // 18,976 triangles flipped) the tighter start took 60% of the Y steps' time for the same
  // map (docs/methods.md, "Only where the start folds"). 0 = whenever inner_f_tol_start > 0.
  double inner_f_tol_start_min_folds = 1e-3;
  int lbfgs_memory = 10;          // L-BFGS history (the paper uses BFGS; see docs/methods.md)
  // Y-step L-BFGS with the initial inverse Hessian H0 = (theta K)^-1 (issue 20 speed, our
  // addition; surface/elastic_preconditioner.h): K = kappa L_X + 2 beta M + 2 gamma
  // diag(Q^T M~ 1), kappa = precondition_stiffness * alpha * mu (alpha mu L_X: the Hessian of
  // Eq. 7's tr G term at the rest state); theta = s'y / s'Ks from the newest curvature pair
  // (so H0 = theta' K^-1 with theta' = s'Ks / s'y, below).
  // 0 = off: H0 = gamma I (Nocedal & Wright Eq. 7.20).
  double precondition_stiffness = 1;
  bool precondition_scaling = true;  // theta as above (false: theta = 1)
  // Upper bound on the scale of H0 = theta' K^-1, theta' = s'Ks / s'y (issue 20 speed): 1 =
  // never a larger step than K^-1 g, i.e. never a model softer than K. While beta is small,
  // pairs along which the membrane is softer than K (s'y < s'Ks) made theta' 2-3 and the
  // next unit step overshoot, in the directions where the bending term grows fastest.
  double precondition_theta_max = 1;
  // K is refactored at the start of a Y step only when some entry of its diagonal (beta and
  // Q change) has moved by more than this factor since the last factorization
  // (ElasticPreconditioner::update_diagonal; issue 20 speed: a factorization at 12k vertices
  // costs about as much as two energy evaluations). 0 = every Y step.
  double precondition_refactor_tol = 0.25;
  // First trial step of the Y-step line search (issue 20 speed, our addition): instead of 1,
  // alpha0 = min(1, max(alpha_last, 1.01 * 2 (f_{k-1} - f_k) / |g'd|)): the larger of the
  // last accepted step (of an iteration with curvature pairs, kept across Y steps) and the
  // step that repeats the last decrease (Nocedal & Wright Eq. 3.60). While beta is small the
  // unit step of the preconditioned direction turns triangles of Y by tens of degrees, the
  // bending term (Eq. 9) grows far faster than K's quadratic model and the unit step was
  // rejected in about half of all iterations (docs/methods.md). Eq. 3.60 alone ratchets
  // down after one short step (a distorted 1k-vertex start: E 163 instead of 55 after 30
  // iterations per side); the max with alpha_last does not.
  bool interpolate_initial_step = true;
  // Keep each side's L-BFGS curvature pairs from one outer iteration's Y step to the next
  // (our addition, docs/methods.md: a quasi-Newton Hessian approximation is carried over,
  // as BFGS in the paper could be). false = every Y step starts from steepest descent.
  bool lbfgs_warm_start = true;
  // Sec. 5.2 "Global scale": scale each mesh to unit area. false = the partial-matching
  // variant of Sec. 6.2: no scaling; alpha divided by the source area s (s~ for the
  // reverse shell), beta and gamma divided by s * s~.
  bool normalize_area = true;
  // Y-step line search that never passes a triangle of Y through zero area (issue 20, our
  // addition): a trial step that turns a non-collapsed triangle's normal by more than 90
  // degrees is shortened. With log_eps = 0 the membrane's -log det G (Eq. 7) is then a true
  // barrier (Sec. 4.1 extends it linearly below eps, which lets Y collapse at a finite cost).
  bool keep_orientation = false;
  // Collapse guard (issue 20, our addition): per direction, never return a map with more
  // flipped or collapsed triangles (the counts of eval/surface_distortion.h, on unit-area
  // copies) than the initial one. The returned map is the last iterate if it has no more
  // than the start, else the latest iterate that has no more, else the initial map
  // (ElasticResult::guard_AB/BA say which). false = always the last iterate.
  bool keep_no_worse = true;
  ElasticAnchors anchors;         // none by default (refine_surface_maps.h finds feature anchors)
  ProgressCallback progress;      // stage "elastic", fraction of max_outer_iterations

  // Presets of Sec. 5.2 / 6.1: eta = 0.01 (near-isometric, FAUST intra-class),
  // eta = 0.002 (degenerate initial maps, e.g. nearest-vertex snapped).
  static ElasticOptions near_isometric() { ElasticOptions o; o.eta = 0.01; return o; }
  static ElasticOptions degenerate_init() { ElasticOptions o; o.eta = 0.002; return o; }
};

// One row per outer iteration (after its last inner step).
struct ElasticIterate {
  double beta = 0;
  double energy = 0;          // E_inj (Eq. 4) or E_bij (Eq. 6)
  double deformation = 0;     // W_def(X, Y) (+ W_def(X~, Y~))
  double mismatch = 0;        // beta terms, weighted
  double reversibility = 0;   // gamma terms, weighted
  int inner_iterations = 0;   // L-BFGS iterations, Y and Y~ steps
  int inner_evaluations = 0;  // energy + gradient evaluations of the Y and Y~ steps
  double time_projection = 0; // seconds in the P (and Q) steps of this iteration
  double time_deformation = 0;// seconds in the Y (and Y~) steps
  // Where triangles collapse (issue 20), after this iteration, on unit-area copies: mapped
  // triangles of P (A -> B) and Q (B -> A) and of the deformed shells Y and Y~, flipped
  // (normal against the target's at the corners' images) and collapsed (a <= 1e-12 a^),
  // counted as eval/surface_distortion.h does.
  FoldCounts P_folds, Q_folds, Y_folds, Yt_folds;
};

// Which map a direction returns (ElasticOptions::keep_no_worse).
enum class ElasticReturned { Last, EarlierIterate, Initial };
struct ElasticGuard {
  ElasticReturned returned = ElasticReturned::Last;
  int iteration = 0;       // outer iteration (1-based) of the returned map; 0 = the initial map
  int initial_bad = 0;     // flipped + collapsed triangles of the initial map
  int last_bad = 0;        // ... of the last iterate
  int returned_bad = 0;    // ... of the returned map
};

// The first outer iteration at which the flipped + collapsed count of a map (P or Q) or of a
// shell (Y or Y~) exceeds its value at the start, and where: the source faces that turned bad
// then (at most 64, ascending), their area-weighted centroid on the source (input
// coordinates) and the mean distance |Y - P X~| (unit-area frame) at their corners against
// the mean over all vertices (the Y step leaves P's projections far off the surface there?).
struct ElasticCollapseEvent {
  int iteration = 0;               // 0: never
  std::vector<int> faces;
  Eigen::RowVector3d centroid = Eigen::RowVector3d::Zero();
  double mismatch_at_faces = 0, mismatch_mean = 0;
};

struct ElasticResult {
  BarycentricMap map_AB;      // P: vertices of A -> faces of B
  BarycentricMap map_BA;      // Q: vertices of B -> faces of A (empty for the injective model)
  Eigen::MatrixXd Y;          // final deformation of A (n×3), in B's input coordinates
  Eigen::MatrixXd Ytilde;     // final deformation of B (n~×3), in A's input coordinates
  std::vector<ElasticIterate> history;
  int outer_iterations = 0;
  bool converged = false;     // the energy-change stop triggered (else K reached)
  double time_setup = 0, time_projection = 0, time_deformation = 0, time_total = 0;
  int degenerate_faces_initial = 0;  // faces of Y (and Y~) masked at the start
  int degenerate_faces_final = 0;
  ElasticGuard guard_AB, guard_BA;   // which iterate each direction returns, and why
  BarycentricMap last_AB, last_BA;   // the last iterate, kept only when the guard returned another
  long long projection_rows_kept = 0;  // rows the safe projection kept at their previous value
  int sliver_mask_steps = 0;  // Y steps that left slivers out of the bending term (mask_tol)
  // Flipped + collapsed triangles of the initial maps over their source's triangles (the larger
  // direction), and whether the tighter start (inner_f_tol_start) ran because of them.
  double initial_fold_fraction = 0;
  bool tight_start = false;
  // ElasticAnchors that held by the end of the ramp (release_after_ramp) or of the run
  int anchors_holding_AB = 0, anchors_holding_BA = 0;
  bool anchors_released = false;  // they let go after the ramp
  // First collapses, per direction (AB: P and Y; BA: Q and Y~).
  ElasticCollapseEvent first_P_collapse, first_Y_collapse, first_Q_collapse, first_Yt_collapse;
};

// A, B: closed triangle meshes (A: n vertices, B: n~ vertices). init_AB: n rows onto B's
// faces; init_BA: n~ rows onto A's faces (required for the bijective model, ignored by
// the injective one). Throws InputError on mismatched maps (validate_map).
ElasticResult elastic_correspondence(const TriMesh& A, const TriMesh& B,
                                     const BarycentricMap& init_AB,
                                     const BarycentricMap& init_BA,
                                     const ElasticOptions& opt = {});

// The energy of Eq. 6 (or Eq. 4 when Q is empty) and its gradients, exactly as the Y and
// Y~ steps of Algorithm 1 evaluate it, in the frames given (no normalization):
// X n×3, F m×3 (source S); Xt n~×3, Ft (target S~); P: n rows onto Ft; Q: n~ rows onto F
// (or empty); Y n×3, Yt n~×3 (ignored when Q is empty). gY, gYt (may be null) receive
// dE/dY (n×3) and dE/dY~ (n~×3). shell: alpha, eta, ... of W_def (both shells). anchors (may
// be null): their term is added to the mismatch (P and Q are taken as given).
struct ElasticEnergyTerms {
  double total = 0, deformation = 0, mismatch = 0, reversibility = 0;
};
struct ShellEnergyOptions;
// The shell options (alpha, eta, lambda, mu, log_eps, degenerate_tol) of W_def in `opt`, as
// Algorithm 1 uses them (partial matching then rescales alpha per surface).
ShellEnergyOptions shell_energy_options(const ElasticOptions& opt);
double elastic_energy(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F,
                      const Eigen::MatrixXd& Xt, const Eigen::MatrixXi& Ft,
                      const BarycentricMap& P, const BarycentricMap& Q,
                      const Eigen::MatrixXd& Y, const Eigen::MatrixXd& Yt, double beta,
                      double gamma, const ShellEnergyOptions& shell, Eigen::MatrixXd* gY = nullptr,
                      Eigen::MatrixXd* gYt = nullptr, ElasticEnergyTerms* terms = nullptr,
                      const ElasticAnchors* anchors = nullptr);

// The bending weight eta for given initial maps (Sec. 5.2, "eta"): "if flipped, or nearly
// degenerate, triangles appear in the initial map, eta should have a smaller value, to allow
// the membrane energy to recover a smooth map". Returns the degenerate-initial-map preset
// (ElasticOptions::degenerate_init().eta = 0.002) when P: A -> B, or Q: B -> A if given
// (non-empty), maps some triangle to a flipped or collapsed one (the counts of
// eval/surface_distortion.h, as reported in the initial metrics), else eta_clean (the
// non-isometric default 0.1). BIM maps of a few thousand vertices almost always have some.
struct BendingWeightChoice {
  double eta = 0;
  int flipped = 0;     // flipped triangles of P (+ Q)
  int degenerate = 0;  // collapsed triangles of P (+ Q)
};
BendingWeightChoice bending_weight_for_initial_maps(const TriMesh& A, const TriMesh& B,
                                                    const BarycentricMap& P,
                                                    const BarycentricMap& Q,
                                                    double eta_clean = 0.1);

// Landmark-driven initial maps (docs/methods.md, "Elastic correspondence"): BIM
// restricted to the given correspondences: the feature points of both surfaces are the
// landmarks, the candidate Mobius maps are all triplets of corresponding landmarks
// (BIMOptions::landmarks_A/B), blended as usual, in both directions.
// la, lb: k >= 3 corresponding vertex indices (la[i] <-> lb[i]). `bim` supplies the
// other BIM options (its landmark fields and `symmetric` are overwritten).
// Throws InputError on mismatched or out-of-range landmarks.
struct BIMOptions;
void landmark_initial_maps(const TriMesh& A, const TriMesh& B, const std::vector<int>& la,
                           const std::vector<int>& lb, BarycentricMap& init_AB,
                           BarycentricMap& init_BA, const BIMOptions* bim = nullptr);

}  // namespace shapemap
