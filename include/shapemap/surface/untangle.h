// Untangling a surface map on its target (issue 20, our addition; docs/methods.md,
// "Untangling the returned maps").
//
// The elastic refinement converges with some mapped triangles turned over or collapsed on the
// target: its deformed shell Y keeps triangles folded against the target, the membrane energy
// does not see a triangle turned over, and the projection P follows Y. This final stage works
// on the map itself: the images of the vertices of flipped or collapsed triangles, plus a few
// rings around them, slide on the target (tangent-plane steps on the target's faces, projected
// back onto the faces near the current image) to lower the symmetric Dirichlet energy of the
// mapped triangles, measured against the source triangles in the target's tangent frame
//
//   E_t(J) = a_t (|J|_F^2 + |J|_F^2 / h(det J)^2),   h(s) = (s + sqrt(s^2 + 4 delta^2)) / 2,
//
// (|J^{-1}|_F^2 = |J|_F^2 / det(J)^2 for 2×2 J). h is the smooth positive replacement of det J
// of mesh untangling (Escobar et al. 2003, "Simultaneous untangling and smoothing of
// tetrahedral meshes"): a turned-over triangle (det J < 0) costs about |J|^2 det^2 / delta^4,
// so minimizing E turns it back; delta shrinks over the sweeps to 1e-3 where E is the
// symmetric Dirichlet energy with its barrier at det J = 0. Two quadratic terms per free
// vertex keep the images near where they were and consistent with the other direction: a
// tether to the refined image and, given the reverse map Q, the round trip |Q(y_v) - x_v|^2
// (Sec. 3.2's reversibility). The vertices outside the regions stay where they are. A
// region's new images are kept only when the flipped + collapsed count of
// eval/surface_distortion.h (fold_counts) over its triangles falls, so the stage never adds a
// fold; regions still bad are retried with twice as many rings. Slivers, mapped triangles
// neither flipped nor collapsed but squashed nearly flat (MIPS - 2 above sliver_mips), are
// bad too: their regions are relaxed by the same energy, whose barrier they sit against, and
// kept when they leave fewer slivers and no more folds.
#pragma once
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <Eigen/Core>

namespace shapemap {

struct UntangleOptions {
  int rings = 2;              // free region: the corners of bad triangles and this many rings
  int rounds = 3;             // rounds; each retries the regions still bad with twice the rings
  int smooth_sweeps = 20;     // Tutte (uniform average) sweeps over the corners of bad triangles first
  int smooth_min_flag = 2;    // ... of collapsed (2) or of flipped and collapsed (1) triangles
  int sweeps = 80;            // Gauss-Seidel sweeps over a region's free vertices per round
  double delta_start = 0.1;   // regularization of det J at the first sweep ...
  double delta_end = 1e-3;    //   ... shrunk geometrically to this at the last
  // Tether: + tether * m_v |y_v - y_v^0|^2 / l_v^2 per free vertex (m_v its lumped rest area,
  // l_v its mean rest edge length, y_v^0 its image at the start): keeps the images that need
  // not move near the refined map (and the round trip with the other direction). 0 = none;
  // 1 measured best of 0, 0.1, 1, 10 on camel-01-08 and cat-lion (docs/methods.md).
  double tether = 1;
  // Reversibility (given the reverse map Q): + reverse_weight * m_v |Q(y_v) - x_v|^2 / l_v^2 per
  // free vertex, Q(y) interpolated linearly over y's face (the round trip P then Q, Sec. 3.2).
  double reverse_weight = 10;
  double degenerate_tol = 1e-12;  // collapsed: a <= tol a^ (as surface_distortion counts)
  // Source vertices whose images stay in every stage: the refinement's anchors (feature points
  // or landmarks, feature_anchors.h), which it held on their partners; the rest of a region
  // moves around them (cat -> lion: the sliver stage moved the cat's tail tip 0.05 off the
  // lion's, docs/methods.md, "Anchors kept through the untangling").
  std::vector<int> held;
  // Sliver: a mapped triangle, not flipped or collapsed, whose conformal distortion MIPS - 2
  // (surface_distortion's, s1/s2 + s2/s1 - 2) exceeds this (10: singular values ~12 apart).
  // 0 = folds only (stages 2 and 3); slivers() sets it for stage 4.
  double sliver_mips = 0;
  bool seed_folds = true;     // regions grow from folds (and slivers); false: from slivers only
  // Bridges: a vertex whose image lies on the far side of a thin part of the target (a leg,
  // an ear) from its neighbours' images: its face's normal turned more than 90 degrees from
  // the mean of theirs when they agree (mean at least half a unit long), or from both other
  // corners' of a fold it is a corner of. Before a fold's region is relaxed, each of its
  // bridges is re-seated at the closest point of the whole target to its neighbours' average
  // image on their side (lifted along their normal by up to two edge lengths until that
  // point's face is turned their way; the relaxation's steps walk on the faces near the image
  // and cannot get round). Kept, like the rest of the region, only where its folds fall (a
  // bridge without a fold is left: counted as bad, it moved hundreds of vertices on camel
  // pairs whose two maps disagree and lengthened their round trip, docs/methods.md).
  // bridges() sets it for stage 5.
  bool reseat_bridges = false;
  // Re-seating search: > 0 replaces the regions' relaxation by this many sweeps over the corners
  // of the flipped and collapsed triangles, each corner's image tried at every point of a
  // barycentric grid (search_grid + 1 points along an edge) on the target faces within
  // search_rings vertex rings (rounded up to even) of its own and its neighbours' images, and
  // put where the fewest triangles around it are folded, then the energy E above (at
  // delta_end) is lowest; kept where the folds around it fall, or stay and
  // the energy falls. For folds the relaxation cannot reach: on crumpled parts of real scans
  // (the camel's ears, sheets folded back onto themselves) a tangent-plane step does not cross
  // the crease, and a collapsed triangle gives every rotation-invariant energy a zero gradient.
  // search() sets it for stage 6.
  int search_sweeps = 0;
  int search_grid = 8;
  int search_rings = 4;  // 2: camel-gallop alike, cat -> lion 2 / 15 folds left instead of 0 / 12
  // ... and a corner is not moved where a face around it that is not folded ends with a
  // conformal distortion MIPS - 2 above this, or above its own before when it was not folded,
  // whichever is larger.
  double search_max_mips = 300;
  // Stage 3 of refine_surface_maps.h, for what the defaults leave: regions of 4 (then 8) rings
  // and 200 sweeps from delta 0.3. A patch mapped mirrored needs both: the first try of a
  // 2-ring region around it adds folds at its rim, which marks its faces as not to be tried
  // again, and 80 sweeps do not carry a turn-over across a patch many rings wide. Measured
  // best of rings 4 / 8, sweeps 200 / 300, delta_start 0.3 / 0.5 on five bench pairs
  // (docs/methods.md).
  static UntangleOptions wide() {
    UntangleOptions o;
    o.rings = 4;
    o.rounds = 2;
    o.sweeps = 200;
    o.delta_start = 0.3;
    return o;
  }
  // Stage 4 of refine_surface_maps.h, after the folds: regions grown from slivers only (2
  // rings), kept when they leave fewer slivers and no more folds. Separate from the fold
  // stages because slivers seeded with the folds merge regions and cost folds (cat -> lion
  // A -> B: 29 folds left without slivers, 65 with them in stage 2 and 3) and time. Threshold
  // 10 measured against 100 and 4 on airplane -> bird and cat -> lion (docs/methods.md).
  static UntangleOptions slivers() {
    UntangleOptions o;
    o.sliver_mips = 10;
    o.seed_folds = false;
    o.rounds = 2;
    return o;
  }
  // Stage 5 of refine_surface_maps.h, after the others: stage 2's regions with their bridges
  // re-seated first (camel-gallop pairs: a corner across a leg, its image 17-30 times its
  // triangle's area; docs/methods.md, "Bridges").
  static UntangleOptions bridges() {
    UntangleOptions o;
    o.reseat_bridges = true;
    return o;
  }
  // Stage 6 of refine_surface_maps.h, last: the re-seating search over what stages 2 to 5 left.
  static UntangleOptions search() {
    UntangleOptions o;
    o.search_sweeps = 10;
    return o;
  }
  // Both surfaces are measured as unit-area copies (Sec. 5.2's global scale, and the frame in
  // which surface_distortion counts), so a rest triangle and its image compare at one scale.
};

struct UntangleResult {
  FoldCounts before, after;   // flipped / collapsed triangles of the map, whole map
  int slivers_before = 0, slivers_after = 0;  // slivers (sliver_mips), whole map
  int regions = 0;            // regions tried (all rounds)
  int regions_kept = 0;       // regions whose new images were kept
  int vertices_moved = 0;     // vertices whose image changed
  double seconds = 0;
};

// S: source (n vertices), T: target; P: n rows onto T's faces, changed in place.
// Q (optional): the reverse map T -> S (T's vertices onto S's faces), for the reversibility term.
UntangleResult untangle_surface_map(const TriMesh& S, const TriMesh& T, BarycentricMap& P,
                                    const UntangleOptions& opt = {}, const BarycentricMap* Q = nullptr);

// The energy E_t above of one mapped triangle and its gradient, in the frame given:
// Y: 3×3, row j = the image of corner j (R^3); n: unit normal of the tangent plane the
// triangle is measured in (held fixed); Rinv: inverse of the 2×2 rest edge matrix
// [r1 - r0, r2 - r0] (columns, source triangle in an isometric 2D frame); rest_area: a_t;
// delta > 0. dY (optional): dE/dY, 3×3 (row j: d/dy_j).
double untangle_triangle_energy(const Eigen::Matrix3d& Y, const Eigen::Vector3d& n,
                                const Eigen::Matrix2d& Rinv, double rest_area, double delta,
                                Eigen::Matrix3d* dY = nullptr);

// The reversibility term of one free vertex: w |Q(y) - x|^2, Q(y) = sum_j b_j(y) Qc.row(j) with
// b(y) the barycentric coordinates of y (projected onto the plane of the face with corners
// C.row(0..2)), Qc.row(j) the reverse map's image of corner j, x the vertex on the source.
// g (optional): d/dy.
double untangle_reversibility_energy(const Eigen::Vector3d& y, const Eigen::Matrix3d& C,
                                     const Eigen::Matrix3d& Qc, const Eigen::Vector3d& x, double w,
                                     Eigen::Vector3d* g = nullptr);

}  // namespace shapemap
