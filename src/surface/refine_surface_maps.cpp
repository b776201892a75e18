// The elastic stage as shapemap returns it: see refine_surface_maps.h.
#include "shapemap/surface/refine_surface_maps.h"

#include "shapemap/error.h"

namespace shapemap {

SurfaceUntangling untangle_surface_maps(const TriMesh& A, const TriMesh& B, BarycentricMap& P, BarycentricMap& Q,
                                        const SurfaceRefinementOptions& opt) {
  SurfaceUntangling u;
  const bool bij = Q.size() == B.num_vertices();
  u.AB = untangle_surface_map(A, B, P, opt.untangling, bij ? &Q : nullptr);
  u.final_AB = u.AB.after;
  if (bij) {
    u.BA = untangle_surface_map(B, A, Q, opt.untangling, &P);
    u.final_BA = u.BA.after;
  }
  if (opt.wide_untangle) {
    // Stage 3: what the local regions left (a patch mapped mirrored: every try of a small
    // region around it adds folds at its rim, so stage 2 gives it up), in the same order.
    u.wide = true;
    u.wide_AB = untangle_surface_map(A, B, P, opt.wide_untangling, bij ? &Q : nullptr);
    u.final_AB = u.wide_AB.after;
    if (bij) {
      u.wide_BA = untangle_surface_map(B, A, Q, opt.wide_untangling, &P);
      u.final_BA = u.wide_BA.after;
    }
  }
  if (opt.sliver_untangle) {
    // Stage 4: slivers, after the folds so that their regions do not change the fold stages'
    u.slivers = true;
    u.sliver_AB = untangle_surface_map(A, B, P, opt.sliver_untangling, bij ? &Q : nullptr);
    u.final_AB = u.sliver_AB.after;
    if (bij) {
      u.sliver_BA = untangle_surface_map(B, A, Q, opt.sliver_untangling, &P);
      u.final_BA = u.sliver_BA.after;
    }
  }
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
