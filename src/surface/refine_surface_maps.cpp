// The elastic stage as shapemap returns it: see refine_surface_maps.h.
#include "shapemap/surface/refine_surface_maps.h"

#include "shapemap/error.h"
#include "shapemap/timing.h"

#include <algorithm>

namespace shapemap {

namespace {
// A stage's result over several passes: the first pass's counts before, the last pass's after,
// the work summed (vertices_moved: summed, a vertex moved in two passes counts twice).
void accumulate(UntangleResult& total, const UntangleResult& pass, bool first) {
  if (first) {
    total = pass;
    return;
  }
  total.after = pass.after;
  total.slivers_after = pass.slivers_after;
  total.regions += pass.regions;
  total.regions_kept += pass.regions_kept;
  total.vertices_moved += pass.vertices_moved;
  total.seconds += pass.seconds;
}
}  // namespace

SurfaceUntangling untangle_surface_maps(const TriMesh& A, const TriMesh& B, BarycentricMap& P, BarycentricMap& Q,
                                        const SurfaceRefinementOptions& opt, const std::vector<int>& held_A,
                                        const std::vector<int>& held_B) {
  SurfaceUntangling u;
  const bool bij = Q.size() == B.num_vertices();
  u.wide = opt.wide_untangle;
  u.slivers = opt.sliver_untangle;
  u.bridges = opt.bridge_untangle;
  // one stage: A -> B with the reverse map as it is, then B -> A with the new A -> B
  auto stage = [&](UntangleOptions o, UntangleResult& ab, UntangleResult& ba, bool first) {
    o.held = held_A;
    const UntangleResult rab = untangle_surface_map(A, B, P, o, bij ? &Q : nullptr);
    accumulate(ab, rab, first);
    u.final_AB = rab.after;
    if (bij) {
      o.held = held_B;
      const UntangleResult rba = untangle_surface_map(B, A, Q, o, &P);
      accumulate(ba, rba, first);
      u.final_BA = rba.after;
    }
  };
  auto count = [&] { return u.final_AB.bad() + (bij ? u.final_BA.bad() : 0); };
  // Stage 5: bridges, once, where the passes would stop (run inside every pass it cost
  // camel-gallop 04 -> 10 a fold elsewhere: the passes are path dependent), then stage 4 again
  // for the slivers its regions leave.
  bool bridged = false;
  auto bridges = [&] {
    bridged = true;
    stage(opt.bridge_untangling, u.bridge_AB, u.bridge_BA, true);
    if (u.slivers) stage(opt.sliver_untangling, u.sliver_AB, u.sliver_BA, false);
  };
  int folds = -1;  // flipped + collapsed, both directions, after the last pass
  for (int pass = 0; pass < std::max(1, opt.untangle_passes); ++pass) {
    const bool first = pass == 0;
    stage(opt.untangling, u.AB, u.BA, first);
    // Stage 3: what the local regions left (a patch mapped mirrored: every try of a small region
    // around it adds folds at its rim, so stage 2 gives it up).
    if (u.wide) stage(opt.wide_untangling, u.wide_AB, u.wide_BA, first);
    // Stage 4: slivers, after the folds so that their regions do not change the fold stages'.
    if (u.slivers) stage(opt.sliver_untangling, u.sliver_AB, u.sliver_BA, first);
    u.passes = pass + 1;
    // Another pass starts with no region given up (untangle.cpp's `hopeless` marks are per
    // call) and with each direction's reverse term on the other's latest map; it is run while
    // the last one lowered the folds (each pass never raises them), and after stage 5 when
    // that lowered them.
    int now = count();
    bool more = now > 0 && (first || now < folds);
    if (!more && u.bridges && !bridged) {
      const int before = now;
      bridges();
      now = count();
      more = now > 0 && now < before;
    }
    if (!more) break;
    folds = now;
  }
  if (u.bridges && !bridged) bridges();  // the passes ended on their cap
  // Stage 6: the search over the corners of what is left, then stage 4 for the slivers its
  // moves leave (a corner goes where the fewest faces around it fold; their shapes are only
  // held under UntangleOptions::search_max_mips).
  u.search = opt.search_untangle && count() > 0;
  if (u.search) {
    stage(opt.search_untangling, u.search_AB, u.search_BA, true);
    if (u.slivers) stage(opt.sliver_untangling, u.sliver_AB, u.sliver_BA, false);
  }
  return u;
}

namespace {
// SurfaceRefinementOptions::guard_untangled: the last iterates (where the guard set them aside;
// elsewhere the returned map is the last iterate) untangled, and made r's maps when neither
// direction then has more folds than its initial map. Returns whether they were.
bool last_iterates_untangled(const TriMesh& A, const TriMesh& B, ElasticResult& r,
                             const SurfaceRefinementOptions& opt, const FeatureAnchors& held, SurfaceUntangling& u) {
  const bool bij = r.map_BA.size() == B.num_vertices();
  BarycentricMap P = r.last_AB.size() > 0 ? r.last_AB : r.map_AB;
  BarycentricMap Q = bij && r.last_BA.size() > 0 ? r.last_BA : r.map_BA;
  SurfaceUntangling v = untangle_surface_maps(A, B, P, Q, opt, held.A, held.B);
  if (v.final_AB.bad() > r.guard_AB.initial_bad || (bij && v.final_BA.bad() > r.guard_BA.initial_bad)) return false;
  auto revise = [&](ElasticGuard& g, BarycentricMap& last) {
    if (last.size() == 0) return;
    g.returned = ElasticReturned::Last;
    g.iteration = r.outer_iterations;
    g.returned_bad = g.last_bad;
    last = BarycentricMap{};
  };
  revise(r.guard_AB, r.last_AB);
  revise(r.guard_BA, r.last_BA);
  r.map_AB = std::move(P);
  if (bij) r.map_BA = std::move(Q);
  u = std::move(v);
  return true;
}
}  // namespace

SurfaceRefinement refine_surface_maps(const TriMesh& A, const TriMesh& B, const BarycentricMap& init_AB,
                                      const BarycentricMap& init_BA, const SurfaceRefinementOptions& opt) {
  SurfaceRefinement out;
  ElasticOptions eo = opt.elastic;
  if (!eo.anchors.A.empty()) {
    out.anchors.A = eo.anchors.A;
    out.anchors.B = eo.anchors.B;
  } else if (opt.feature_anchors && eo.model == ElasticModel::Bijective) {
    const auto t0 = Clock::now();
    out.anchors = mutual_feature_anchors(A, B, init_AB, init_BA, opt.anchoring);
    out.anchor_seconds = seconds_since(t0);
    eo.anchors.A = out.anchors.A;
    eo.anchors.B = out.anchors.B;
  }
  BarycentricMap P = init_AB, Q = init_BA;
  if (opt.reextend_collapsed) {
    P = reextend_collapsed_parts(A, B, init_AB, opt.collapsed_parts, &out.collapsed_AB);
    if (eo.model == ElasticModel::Bijective && init_BA.size() == B.num_vertices())
      Q = reextend_collapsed_parts(B, A, init_BA, opt.collapsed_parts, &out.collapsed_BA);
  }
  out.elastic = elastic_correspondence(A, B, P, Q, eo);
  ElasticResult& r = out.elastic;
  if (!r.map_AB.bary.allFinite() || !r.Y.allFinite()) throw Error("elastic: non-finite result");
  if (!opt.untangle) return out;
  out.untangled = true;
  if (opt.guard_untangled && eo.keep_no_worse && (r.last_AB.size() > 0 || r.last_BA.size() > 0) &&
      last_iterates_untangled(A, B, r, opt, out.anchors, out.untangling)) {
    out.guard_revised = true;
    return out;
  }
  out.untangling = untangle_surface_maps(A, B, r.map_AB, r.map_BA, opt, out.anchors.A, out.anchors.B);
  return out;
}

}  // namespace shapemap
