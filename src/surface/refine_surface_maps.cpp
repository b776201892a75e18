// The elastic stage as shapemap returns it: see refine_surface_maps.h.
#include "shapemap/surface/refine_surface_maps.h"

#include "shapemap/error.h"

namespace shapemap {

SurfaceUntangling untangle_surface_maps(const TriMesh& A, const TriMesh& B, BarycentricMap& P, BarycentricMap& Q,
                                        const SurfaceRefinementOptions& opt) {
  SurfaceUntangling u;
  const bool bij = Q.size() == B.num_vertices();
  // one stage: A -> B with the reverse map as it is, then B -> A with the new A -> B
  auto stage = [&](const UntangleOptions& o, UntangleResult& ab, UntangleResult& ba) {
    ab = untangle_surface_map(A, B, P, o, bij ? &Q : nullptr);
    u.final_AB = ab.after;
    if (bij) {
      ba = untangle_surface_map(B, A, Q, o, &P);
      u.final_BA = ba.after;
    }
  };
  stage(opt.untangling, u.AB, u.BA);
  // Stage 3: what the local regions left (a patch mapped mirrored: every try of a small region
  // around it adds folds at its rim, so stage 2 gives it up).
  u.wide = opt.wide_untangle;
  if (u.wide) stage(opt.wide_untangling, u.wide_AB, u.wide_BA);
  // Stage 4: slivers, after the folds so that their regions do not change the fold stages'.
  u.slivers = opt.sliver_untangle;
  if (u.slivers) stage(opt.sliver_untangling, u.sliver_AB, u.sliver_BA);
  return u;
}

SurfaceRefinement refine_surface_maps(const TriMesh& A, const TriMesh& B, const BarycentricMap& init_AB,
                                      const BarycentricMap& init_BA, const SurfaceRefinementOptions& opt) {
  SurfaceRefinement out;
  out.elastic = elastic_correspondence(A, B, init_AB, init_BA, opt.elastic);
  ElasticResult& r = out.elastic;
  if (!r.map_AB.bary.allFinite() || !r.Y.allFinite()) throw Error("elastic: non-finite result");
  if (!opt.untangle) return out;
  out.untangled = true;
  out.untangling = untangle_surface_maps(A, B, r.map_AB, r.map_BA, opt);
  return out;
}

}  // namespace shapemap
