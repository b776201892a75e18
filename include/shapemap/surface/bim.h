// Blended Intrinsic Maps (Kim, Lipman, Funkhouser 2011): a fully automatic map between
// two closed genus-0 surfaces, blending many conformal (Möbius) maps with smooth
// weights b_i(p) = c_i(p) w_i (confidence × consistency), Eq. 1.
//
// Pipeline (section numbers of the paper):
//   bim_prepare (per surface): checks, unit-area normalization, outward orientation;
//     P_even by farthest-point sampling and heat geodesics from it (Sec. 5);
//     AGD and its local maxima as feature points (Sec. 4); conformal flattening (Sec. 4).
//   bim_map (per direction): candidate Möbius maps for all pairs of feature triplets
//     (Sec. 4), confidence c_i at P_even (Eq. 2, Sec. 5), blending matrix S over
//     consistent pairs (Eq. 5, Sec. 6.2), top eigenvectors, consistent groups, the
//     blended map of each group (Sec. 7) and the one with the best integrated confidence.
//   blended_intrinsic_maps: both, A->B (and B->A with options.symmetric).
#pragma once
#include "shapemap/error.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/progress.h"
#include "shapemap/surface/conformal_flattening.h"
#include "shapemap/surface/mobius.h"
#include "shapemap/surface/sphere_locator.h"
#include <Eigen/Sparse>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace shapemap {

struct BIMOptions {
  // --- Sec. 4: feature points and candidate maps
  int max_features = 10;            // Sec. 4: "|P_l| <= 10" AGD maxima per surface
  int min_features = 3;             // fewer AGD maxima (e.g. a sphere): add P_even points (FPS order)
  double feature_radius = 0.1;      // AGD maxima must be maximal within this geodesic radius
                                    // (unit-area surfaces); our choice, the paper gives none
  int max_candidates = 10000;       // Sec. 6.2: "we randomly remove maps until we are left with 10,000"
  // Our choice (docs/methods.md, "Candidates kept by confidence"): with more candidates than
  // max_candidates, up to candidate_pool of them (Sec. 6.2's random removal down to the pool)
  // are ranked by their mean confidence (Eq. 2 at P_even) and the best max_candidates kept,
  // so the few correct triples are not removed at random. 0: Sec. 6.2's random removal alone
  // (always with landmarks, whose triples are all correct).
  int candidate_pool = 100000;
  // --- Sec. 5: confidence
  int num_even = 256;               // Sec. 5: |P_even| = 256 farthest-point samples
  double interpolation_sigma = 0;   // Sec. 5: Gaussian interpolation width; 0 = 1/sqrt(num_even)
                                    // (the sample spacing on a unit-area surface)
  // --- Sec. 6: consistency
  double sigma = 0.5;               // Eq. 4/5: sigma = 0.5
  double eigenvalue_fraction = 0.75;  // Sec. 6.2: eigenvalues within 75% of the top one (>= 0.75 λ1)
  double entry_fraction = 0.25;     // Sec. 6.2: "high entries (top 25%)": |w_i| >= 0.25 max |w|
  int num_eigenvectors = 8;         // how many top eigenpairs to compute (Spectra)
  int max_groups = 16;              // at most this many consistent groups are blended and compared
  bool symmetrize_consistency = false; // true: S_ij := (S_ij + S_ji)/2 (Eq. 5 is not symmetric);
                                    // false: Eq. 5 as written, evaluated for i < j
  double consistency_skip = 0.02;   // skip P_even points where c_i c_j < this (their term is < this)
  // Our choice (docs/methods.md, "Implied correspondences"): the groups of Sec. 6.2 test for
  // conflicts also the correspondences a map implies: a source feature that it maps within
  // this geodesic distance (unit-area target) of a target feature, paired with the nearest
  // one. So a map that sends a limb onto the wrong limb is not blended with maps that send it
  // right. 0: the generating correspondences alone, as the paper.
  double implied_radius = 0.05;
  // Our addition (docs/methods.md, "The matching search"): after Sec. 6.2's groups, change
  // the selected group's feature matching one correspondence (or one swap of two) at a time
  // while the blend of every candidate within it gains integrated confidence; at most this
  // many changes (0: off, the paper's groups alone; never with landmarks). A change must
  // gain at least matching_search_min_gain.
  int matching_search_sweeps = 8;
  double matching_search_min_gain = 1e-4;
  // Its budget, in images of candidate maps computed plus blends projected (each a pass over
  // the source's vertices): a sweep that would go past it is not started (a sweep's moves,
  // and the maps within each, grow with the number of feature points).
  long long matching_search_max_work = 50000;
  // --- Sec. 7: blend and output
  bool symmetric = false;           // also the map B -> A
  // With symmetric: the direction whose blend has the lower integrated confidence takes the
  // inverse of the other direction's blend instead (located by closest point on the mapped
  // surface), so the two maps agree (issue 20: on cat -> lion the lion -> cat blend is the
  // better one; on the camel poses the two blends disagree on a leg; docs/methods.md). On by
  // default since 3 Dec 2026 (surface-map --no-reverse-candidates turns it off).
  bool reverse_candidates = true;
  // --- general
  std::uint64_t seed = 1;           // random first P_even vertex, candidate pruning
  double heat_t_factor = 1.0;       // heat method t = factor * h^2
  int min_vertices = 100;           // input guard
  std::string name_A = "A", name_B = "B";  // names used in error messages (file paths)
  // Known correspondences (landmarks): if non-empty, the first feature points are these vertex
  // pairs and the candidates include all triplets of them (no permutations; the others:
  // landmark_feature_points below).
  std::vector<int> landmarks_A, landmarks_B;
  // Our addition (docs/methods.md, "Landmarks among the feature points"): with landmarks, the
  // AGD maxima farther than feature_radius from every landmark are feature points too, and
  // the candidates are every triple of corresponding features in which a landmark is matched
  // to its partner only; a candidate that is not a landmark triple must carry every landmark
  // within landmark_agreement (geodesic, unit-area target) of its partner. So 3 landmarks,
  // one triple, still give BIM maps to blend, and the landmarks reject the swapped ones.
  // blended_intrinsic_maps keeps the added maxima only when both surfaces have some, and only
  // while the maxima found give at most landmark_mixed_max mixed triples (else, or when false:
  // the landmark triples alone).
  bool landmark_feature_points = true;
  double landmark_agreement = 0.35;  // docs/methods.md: 0.1 kept too few maps to blend
  long long landmark_mixed_max = 1000000;
  // Our addition (docs/methods.md, "Too few features to blend"): Sec. 6.2 blends maps that share
  // two correspondences without a conflict; with 3 feature points on a surface no two maps do,
  // and BIM's map is one Moebius map, exact only near its triple (glasses). Then, without
  // landmarks, BIM runs again with P_even samples (FPS order) added up to blend_min_features a
  // side, guided by the single map's triple as by landmarks with blend_agreement as their
  // landmark_agreement, and keeps that blend when it is more confident. 0: off.
  int blend_min_features = 12;
  double blend_agreement = 1.0;
  // The single maps whose triples guide such a run, one run each, the most confident first; the
  // most confident blend of all is kept. 1 (the best single map's triple only) by default: on
  // SHREC'07's glasses the blends guided by the right triple and by its symmetric flip score
  // within 0.1% of each other, and the flip won (docs/methods.md, "Too few features to blend").
  int blend_retry_triples = 1;
  // Our addition (docs/methods.md, "Too few features to blend: the stretch guide"): when no such
  // run is more confident than the single map, one more run, guided by the triple of the least
  // stretched candidate map (membrane energy W_mem of its own Moebius map, elastic-correspondence
  // Eq. 7) among this many most confident candidates on the spread features, when it is less
  // stretched than every single map; kept when it blends. Confidence (Eq. 2) is bounded per point
  // and does not see a part crushed (SHREC'07 busts: the single map puts the head on the base).
  // 0: off.
  int blend_guide_maps = 32;
};

// A surface prepared for BIM (all in the normalized frame: unit area, area centroid at 0).
struct BIMSurface {
  TriMesh mesh;                     // normalized, outward oriented
  Eigen::MatrixXd V_input;          // vertices as given
  Eigen::MatrixXi F_input;          // faces as given (before orientation fixes)
  Normalization normalization;
  Eigen::VectorXd mass;             // lumped vertex areas (sum 1)
  std::vector<int> even;            // P_even (Sec. 5), FPS order
  std::vector<int> even_chain;      // P_even visiting order (nearest-neighbour tour) for walks
  Eigen::MatrixXd even_dist;        // n × |P_even| heat geodesic distances
  Eigen::SparseMatrix<double, Eigen::RowMajor> interp;  // n × |P_even| Gaussian weights, rows sum 1
  Eigen::VectorXd agd;              // average geodesic distance (Sec. 4)
  std::vector<int> features;        // feature vertices (AGD maxima; or the landmarks first,
                                    // then the AGD maxima away from them)
  Eigen::MatrixXd feature_dist;     // n × |features| heat geodesic distances from the features
  ConformalFlattening flat;         // vertices on the Riemann sphere
  std::vector<Homogeneous> hom;     // vertices in homogeneous plane coordinates
  std::shared_ptr<SphereLocator> locator;
  std::shared_ptr<ClosestPoint3> closest;  // on mesh (normalized frame)
  std::vector<int> bfs_order, bfs_parent;  // vertex order for coherent walks
  std::vector<std::pair<std::string, double>> timings;
};

// The first steps of bim_prepare on a mesh in its unit-area frame: P_even (Sec. 5, FPS with
// options.seed), heat geodesics from it, the AGD (Sec. 4) and the feature points (its maxima,
// at least options.min_features; or `landmarks` when non-empty), and when asked the geodesic
// distances from the features. No input checks.
void bim_sample_features(const TriMesh& mesh, const BIMOptions& options, const std::vector<int>& landmarks,
                         std::vector<int>& even, Eigen::MatrixXd& even_dist, Eigen::VectorXd& agd,
                         std::vector<int>& features, Eigen::MatrixXd* feature_dist = nullptr);

// Throws InputError("<name>: <problem>") for invalid input (see require_genus0_surface).
// If landmarks is non-empty, they are the feature points.
BIMSurface bim_prepare(const TriMesh& mesh, const std::string& name, const BIMOptions& options,
                       const std::vector<int>& landmarks = {}, const ProgressCallback& progress = {});

// One candidate map, with its generating correspondences (vertex indices).
struct BIMCandidate {
  std::array<int, 3> source{}, target{};  // feature indices into src.features / dst.features
  Mobius mobius;
};

// Whether BIMOptions::landmark_feature_points applies to this many landmarks (at least 3);
// blended_intrinsic_maps then keeps the added maxima when both surfaces have some and they give
// at most landmark_mixed_max mixed triples.
bool bim_landmark_guided(const BIMOptions& options, int num_landmarks);

// All candidates (Sec. 4), pruned to max_candidates: by seeded random removal (Sec. 6.2) down
// to options.candidate_pool, then the most confident ones (when candidate_pool > max_candidates
// and the features are not landmarks).
std::vector<BIMCandidate> bim_candidates(const BIMSurface& src, const BIMSurface& dst,
                                         const BIMOptions& options, long long* total = nullptr);

// The (source, target) feature-index pairs a candidate stands for in Sec. 6.2's conflict test:
// its generating triple and, with options.implied_radius > 0, each other source feature that
// the candidate maps within implied_radius (geodesic, on dst) of a target feature, paired with
// the nearest one.
std::vector<std::pair<int, int>> bim_correspondences(const BIMSurface& src, const BIMSurface& dst,
                                                     const BIMCandidate& candidate, const BIMOptions& options);

// Sec. 6.2's conflict between two sets of feature pairs: a source feature sent to two targets,
// or two sources sent to one target.
bool bim_correspondences_conflict(const std::vector<std::pair<int, int>>& x,
                                  const std::vector<std::pair<int, int>>& y);

// Image of every source vertex under one Möbius map, on the target surface
// (normalized frame), n×3; also the target face and barycentric coordinates.
Eigen::MatrixXd bim_apply(const BIMSurface& src, const BIMSurface& dst, const Mobius& m,
                          Eigen::VectorXi* face = nullptr, Eigen::MatrixXd* bary = nullptr);

// Confidence (Eq. 2) of map m at every P_even point of src, |P_even| values in [0,1].
Eigen::VectorXd bim_confidence(const BIMSurface& src, const BIMSurface& dst, const Mobius& m);

struct BIMMapInfo {
  int index = -1;                      // candidate index
  std::array<int, 3> source{}, target{};  // generating correspondences (vertex indices)
  double integrated_confidence = 0;    // mean c_i over P_even
};

struct BIMDirectionResult {
  BarycentricMap map;               // source vertex -> target face (input faces) + barycentric
  Eigen::MatrixXd positions;        // n×3 mapped positions, target input coordinates
  Eigen::VectorXd confidence;       // c_f per source vertex (Eq. 2 on the blended map)
  double integrated_confidence = 0; // ∫ c_f dA (unit area) of the selected blend (Sec. 6.2)
  std::vector<BIMMapInfo> selected; // maps of the selected group (binary weights)
  int num_candidates = 0;           // K after pruning
  long long num_candidates_total = 0;  // K before pruning
  long long num_consistent_pairs = 0;  // off-diagonal pairs of S that were evaluated
  std::vector<double> eigenvalues;  // top eigenvalues of S, descending
  int num_eigenvectors_used = 0;    // within eigenvalue_fraction of the top
  std::vector<double> group_confidence;  // integrated confidence of each group's blend
  std::vector<int> group_sizes;
  std::vector<BIMMapInfo> group_leads;  // each group's first map (its largest eigenvector entry)
  int selected_group = -1;         // the best of Sec. 6.2's groups (matching_search.kept: not the one output)
  bool from_reverse = false;        // the inverse of the other direction's blend (reverse_candidates)
  double own_integrated_confidence = 0;  // with from_reverse: this direction's own blend's
  double best_candidate_confidence = 0;  // best single Möbius map (mean c_i at P_even)
  struct MatchingSearch {
    bool ran = false;
    double start_confidence = 0;    // blend of every candidate within the selected group's matching
    double final_confidence = 0;    // ... within the matching the search ended on
    int changes = 0;                // correspondences changed (each the best of its sweep)
    int evaluations = 0;            // blends evaluated
    bool kept = false;              // its blend replaced the selected group's (it was better)
    long long work = 0;             // images computed + blends projected (the budget's unit)
    bool over_budget = false;       // it stopped before a sweep that would exceed the budget
  } matching_search;
  std::vector<std::pair<std::string, double>> timings;
};

struct BIMResult {
  BIMDirectionResult AB, BA;        // BA only with options.symmetric
  std::vector<int> features_A, features_B;
  int num_even = 0;
  // The seed the maps came from: options.seed, or another one when blended_intrinsic_maps
  // found no candidate map with it (seed_retries > 0; see NoCandidateMaps).
  std::uint64_t seed = 0;
  int seed_retries = 0;
  // > 0: the features each surface had when BIM found no two maps to blend, ran again with
  // options.blend_min_features a side and kept that blend (features_A / features_B are its).
  int blend_retry_features_A = 0, blend_retry_features_B = 0;
  double blend_retry_confidence = 0;  // > 0: the best second run's integrated confidence (kept or not;
                                      // the stretch guide's when its run is kept)
  int blend_retry_runs = 0;           // second runs made (one per guiding triple)
  int blend_retry_rank = 0;           // kept: the rank of the single map whose triple guided it (0: the best;
                                      // -1: the stretch guide)
  bool blend_retry_stretch_guide = false;  // the kept run was guided by BIMOptions::blend_guide_maps
  double single_map_stretch = 0;      // > 0 when the stretch guide was sought: W_mem of the single map (A -> B)
  double blend_retry_stretch = 0;     // ... and of the least stretched guide
  std::vector<std::pair<std::string, double>> timings;  // per stage, seconds
  double total_seconds = 0;
};

// Thrown when no triplet of feature correspondences gives a Möbius map: the feature points
// coincide numerically on the flattened sphere (a thin shape's flattening crushes whole parts
// to a point, e.g. a pair of glasses, SHREC'07 41 -> 44 with seed 2).
struct NoCandidateMaps : Error {
  using Error::Error;
};

BIMDirectionResult bim_map(const BIMSurface& src, const BIMSurface& dst, const BIMOptions& options,
                           const ProgressCallback& progress = {});

// With no candidate map for options.seed, the surfaces are prepared again with up to
// kBimSeedRetries other seeds (P_even's first sample, hence the AGD, its minimum where the
// sphere is punctured, and the features all depend on it); then one InputError naming both
// surfaces (exit 2 in the tool).
constexpr int kBimSeedRetries = 3;
BIMResult blended_intrinsic_maps(const TriMesh& A, const TriMesh& B, const BIMOptions& options = {},
                                 const ProgressCallback& progress = {});

// blended_intrinsic_maps() on surfaces bim_prepare() made (with the options' landmarks). The
// A/ and B/ timings are the surfaces' own with `prepared_here`, else 0 (prepared before, once
// for many pairs); total_seconds counts the maps only.
BIMResult bim_prepared(const BIMSurface& sa, const BIMSurface& sb, const BIMOptions& options,
                       const ProgressCallback& progress = {}, bool prepared_here = false);

}  // namespace shapemap
