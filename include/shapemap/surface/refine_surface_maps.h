// The elastic stage as shapemap returns it (issue 20), one call for every user of it: the
// surface-map command's elastic method (surface_map_pipeline.h), the Python module through it,
// and the automatic initialization of volume maps (volume/symmetric_map.h,
// surface_map_for_volumes):
//   after stage 0 (anchors from the initial maps), the collapsed parts of the initial maps
//      re-extended (collapsed_parts.h): the
//      parts that BIM's conformal maps shrink to a point, which the refinement cannot undo;
//   0. feature anchors (feature_anchors.h): the AGD maxima that the initial maps send onto
//      each other are held together through stage 1 (ElasticOptions::anchors), unless anchors
//      are given;
//   1. Algorithm 1 of elastic-correspondence.txt with its collapse guard (elastic.h,
//      ElasticOptions::keep_no_worse);
//   2. the untangling of the returned maps on their targets (untangle.h) over local regions:
//      A -> B with the reverse map as the refinement returned it, then B -> A with the new
//      A -> B;
//   3. the same untangling again over wide regions with more sweeps (UntangleOptions::wide),
//      for what stage 2 leaves: mostly patches mapped mirrored (docs/methods.md);
//   4. the same untangling over regions around slivers, mapped triangles squashed nearly flat
//      (UntangleOptions::slivers);
//   5. stage 2's regions again with their bridges re-seated first: corners mapped across a thin
//      part of the target, which the local steps cannot bring back (UntangleOptions::bridges);
//   6. the re-seating search over the corners of the folds still left (UntangleOptions::search):
//      crumpled parts of scans, collapsed triangles.
// Stages 2, 3 and 5 keep a region's new images only where its fold count falls, stage 4 where its
// sliver count falls and its fold count does not rise, stage 6 a corner's where the folds around
// it do not rise, so the returned maps never have more
// flipped or collapsed triangles than the refinement's. Stages 2 to 4 are repeated while a pass
// lowers the folds (SurfaceRefinementOptions::untangle_passes); stage 5 runs once, where those
// passes would stop, and the passes go on when it lowered the folds.
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/surface/collapsed_parts.h"
#include "shapemap/surface/elastic.h"
#include "shapemap/surface/feature_anchors.h"
#include "shapemap/surface/untangle.h"

namespace shapemap {

struct SurfaceRefinementOptions {
  // after stage 0, per initial map (--elastic-no-collapsed-parts turns it off)
  bool reextend_collapsed = true;
  CollapsedPartOptions collapsed_parts;
  // stage 0 (bijective model, elastic.anchors empty; --elastic-no-feature-anchors turns it off)
  bool feature_anchors = true;
  FeatureAnchorOptions anchoring;
  ElasticOptions elastic;       // stage 1 (progress goes through elastic.progress)
  bool untangle = true;         // stages 2 to 5 (--elastic-no-untangle turns them off)
  UntangleOptions untangling;   // stage 2
  bool wide_untangle = true;    // stage 3 (--elastic-no-wide-untangle turns it off)
  UntangleOptions wide_untangling = UntangleOptions::wide();
  bool sliver_untangle = true;  // stage 4 (--elastic-no-sliver-untangle turns it off)
  UntangleOptions sliver_untangling = UntangleOptions::slivers();
  bool bridge_untangle = true;  // stage 5 (--elastic-no-bridge-untangle turns it off)
  UntangleOptions bridge_untangling = UntangleOptions::bridges();
  bool search_untangle = true;  // stage 6 (--elastic-no-search-untangle turns it off)
  UntangleOptions search_untangling = UntangleOptions::search();
  // Stages 2 to 4 are repeated (stage 5 once among them), at most this many times, while a pass lowers the flipped +
  // collapsed count of both maps (the 45 camel pose pairs, one pass -> 3: 12 -> 15 fold-free
  // after repair, folds 14,322 -> 13,068; docs/methods.md). 1 = one pass.
  int untangle_passes = 3;
  // Ours (issue 20): the collapse guard (ElasticOptions::keep_no_worse) judges the maps as they
  // are returned, after stages 2 to 6. When it set a last iterate aside, the last iterates are
  // untangled too and returned if neither direction then has more flipped + collapsed triangles
  // than its initial map; else the guard's choice is untangled, as before. The untangling
  // removes most of the folds that the plain projection (--elastic-plain-projection) leaves,
  // which the guard saw before it and answered with the initial map (docs/methods.md).
  bool guard_untangled = true;
};

// Stages 2 to 5, per direction (BA: only with a reverse map).
struct SurfaceUntangling {
  UntangleResult AB, BA;            // stage 2
  bool wide = false;                // stage 3 ran
  UntangleResult wide_AB, wide_BA;  // stage 3
  bool slivers = false;             // stage 4 ran
  UntangleResult sliver_AB, sliver_BA;  // stage 4
  bool bridges = false;             // stage 5 ran
  UntangleResult bridge_AB, bridge_BA;  // stage 5
  bool search = false;              // stage 6 ran
  UntangleResult search_AB, search_BA;  // stage 6
  FoldCounts final_AB, final_BA;    // the returned maps
  int passes = 0;                   // passes of stages 2 to 4 run (untangle_passes); each
                                    // stage's result: before = the first pass's, after = the
                                    // last's, regions, vertices and seconds summed
};

struct SurfaceRefinement {
  CollapsedPartResult collapsed_AB, collapsed_BA;  // after stage 0 (BA: bijective model)
  FeatureAnchors anchors;  // stage 0's pairs (or the anchors given), empty when none
  double anchor_seconds = 0;
  // elastic.map_AB / map_BA: the returned maps, untangled when `untangled`; the rest of
  // `elastic` (history, guard, timings) is the refinement's.
  ElasticResult elastic;
  bool untangled = false;
  SurfaceUntangling untangling;
  // guard_untangled: the guard had set a last iterate aside and the untangled last iterates were
  // returned instead (elastic.guard_AB/BA then say "last iterate"; the counts before untangling).
  bool guard_revised = false;
};

// A, B: closed triangle meshes; init_AB: A's vertices onto B's faces; init_BA: B's vertices
// onto A's faces (the bijective model; ignored by the injective one). Throws as
// elastic_correspondence does, and Error on a non-finite refinement.
SurfaceRefinement refine_surface_maps(const TriMesh& A, const TriMesh& B, const BarycentricMap& init_AB,
                                      const BarycentricMap& init_BA, const SurfaceRefinementOptions& opt = {});

// Stages 2 to 5 alone on P: A -> B and Q: B -> A (Q empty: A -> B only, without the
// reversibility term), both changed in place. held_A / held_B: vertices of A (of B) whose
// images stay (UntangleOptions::held; refine_surface_maps passes stage 0's anchors).
SurfaceUntangling untangle_surface_maps(const TriMesh& A, const TriMesh& B, BarycentricMap& P, BarycentricMap& Q,
                                        const SurfaceRefinementOptions& opt = {},
                                        const std::vector<int>& held_A = {}, const std::vector<int>& held_B = {});

}  // namespace shapemap
