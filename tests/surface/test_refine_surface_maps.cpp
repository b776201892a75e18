// Issue 20: the untangling stages of the elastic method (surface/refine_surface_maps.h) on a
// generated pair: the ground-truth map with an annulus folded over (a patch mapped mirrored, as
// camel-gallop 01 -> 04's head after the refinement) and a reverse map that agrees with it (the
// inverse of the folded map), so that the round-trip term does not point the way out. Stage 2
// (local regions) leaves much of the patch (762 -> 300 flipped or collapsed triangles when
// written); stage 3 (wide regions) undoes a good part of the rest (-> 171), and neither stage
// adds a fold. Passes (SurfaceRefinementOptions::untangle_passes): the stages run again while
// a pass lowers the folds, and a pass never adds one.
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/generate.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/surface/refine_surface_maps.h"
#include "shapemap/surface/surface_map_pipeline.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace shapemap;

namespace {

int bad(const TriMesh& S, const TriMesh& T, const BarycentricMap& P) {
  const SurfaceDistortion d = surface_distortion(S, T, P);
  return d.flipped + d.degenerate;
}

// The ground-truth map folded around vertex c: in the target's tangent plane at c's image, a
// point at distance r from it moves to distance g(r): r up to a, then back to 2a - r up to b
// (the annulus a < r < b turned over onto the disk: a patch mapped mirrored, with fold curves
// at r = a and r = b, continuous everywhere), then out again to r at e, unchanged beyond.
// Each moved point is put back onto the target by closest point. a, b, e: fractions of the
// target's bounding-box diagonal.
BarycentricMap fold_annulus(const GeneratedPair& pair, int c, double a, double b, double e) {
  const TriMesh& B = pair.B;
  const Eigen::MatrixXd Y = map_positions(pair.truth_AB, B.V, B.F);
  const Eigen::MatrixXd N = face_normals(B.V, B.F);
  const double diag = (B.V.colwise().maxCoeff() - B.V.colwise().minCoeff()).norm();
  a *= diag;
  b *= diag;
  e *= diag;
  const Eigen::Vector3d yc = Y.row(c).transpose(), nc = N.row(pair.truth_AB.elem(c)).transpose();
  const ClosestPoint3 bvh(B.V, B.F);
  BarycentricMap P = pair.truth_AB;
  for (int v = 0; v < P.size(); ++v) {
    const Eigen::Vector3d y = Y.row(v).transpose();
    const Eigen::Vector3d d = (y - yc) - (y - yc).dot(nc) * nc;
    const double r = d.norm();
    if (r <= a || r >= e) continue;
    const double g = r < b ? 2 * a - r : (2 * a - b) + (r - b) * (e - 2 * a + b) / (e - b);
    const ClosestPointResult q = bvh.query(Eigen::Vector3d(y + (g / r - 1) * d));
    P.elem(v) = q.elem;
    P.bary.row(v) = q.bary.head<3>().transpose() / q.bary.head<3>().sum();
  }
  return P;
}

}  // namespace

TEST(RefineSurfaceMaps, WideUntanglingUndoesAMirroredPatchTheLocalOneLeaves) {
  const GeneratedPair pair = make_creature_pair(3, PairKind::NonIsometric, 4000);
  const TriMesh &A = pair.A, &B = pair.B;
  ASSERT_EQ(bad(A, B, pair.truth_AB), 0);
  const BarycentricMap P0 = fold_annulus(pair, A.num_vertices() / 3, 0.05, 0.09, 0.16);
  const BarycentricMap Q0 = invert_surface_map(P0, A, B);
  const int bad0 = bad(A, B, P0);
  ASSERT_GE(bad0, 400) << "the folded annulus is a patch of flipped triangles";
  SurfaceRefinementOptions local, wide;
  local.untangle_passes = wide.untangle_passes = 1;  // one pass of each stage (passes: below)
  local.wide_untangle = false;
  local.sliver_untangle = wide.sliver_untangle = false;  // stages 2 and 3 (stage 4 lowers folds too)
  BarycentricMap P = P0, Q = Q0;
  const SurfaceUntangling u2 = untangle_surface_maps(A, B, P, Q, local);
  EXPECT_FALSE(u2.wide);
  EXPECT_LE(u2.final_AB.bad(), bad0);
  ASSERT_GT(u2.final_AB.bad(), 100) << "stage 2 alone leaves the mirrored patch (" << bad0 << " at the start)";
  P = P0;
  Q = Q0;
  const SurfaceUntangling u3 = untangle_surface_maps(A, B, P, Q, wide);
  EXPECT_TRUE(u3.wide);
  EXPECT_EQ(u3.AB.after.bad(), u2.final_AB.bad());  // stage 2 is the same in both runs
  EXPECT_LT(u3.final_AB.bad(), u2.final_AB.bad() * 2 / 3) << bad0;
  EXPECT_EQ(u3.final_AB.bad(), bad(A, B, P));
  EXPECT_LE(u3.final_BA.bad(), bad(B, A, Q0));
  EXPECT_EQ(u3.final_BA.bad(), bad(B, A, Q));
}

// The stages repeated: on the same folded annulus with stage 2 alone, a second pass (no region
// given up yet, the reverse map updated) lowers the folds the first left; the passes stop as
// soon as one does not lower them, and the counts reported are the maps'.
TEST(RefineSurfaceMaps, PassesRepeatTheStagesWhileTheFoldsFall) {
  const GeneratedPair pair = make_creature_pair(3, PairKind::NonIsometric, 2000);
  const TriMesh &A = pair.A, &B = pair.B;
  const BarycentricMap P0 = fold_annulus(pair, A.num_vertices() / 3, 0.05, 0.09, 0.16);
  const BarycentricMap Q0 = invert_surface_map(P0, A, B);
  auto run = [&](int passes, BarycentricMap& P, BarycentricMap& Q) {
    SurfaceRefinementOptions o;
    o.wide_untangle = o.sliver_untangle = false;
    o.untangle_passes = passes;
    P = P0;
    Q = Q0;
    return untangle_surface_maps(A, B, P, Q, o);
  };
  auto folds = [](const SurfaceUntangling& u) { return u.final_AB.bad() + u.final_BA.bad(); };
  BarycentricMap P1, Q1, P, Q;
  const SurfaceUntangling one = run(1, P1, Q1);
  EXPECT_EQ(one.passes, 1);
  ASSERT_GT(folds(one), 0);
  const SurfaceUntangling many = run(4, P, Q);
  ASSERT_GE(many.passes, 2) << "folds left after the first pass: a second one runs";
  EXPECT_LT(folds(many), folds(one)) << "the second pass lowers the folds the first left";
  EXPECT_EQ(many.AB.before.bad(), one.AB.before.bad());  // the first pass's counts before
  EXPECT_EQ(many.final_AB.bad(), bad(A, B, P));
  EXPECT_EQ(many.final_BA.bad(), bad(B, A, Q));
  EXPECT_EQ(many.AB.after.bad(), many.final_AB.bad());
  validate_map(P, A.num_vertices(), B.num_faces(), 3, "untangled");
  validate_map(Q, B.num_vertices(), A.num_faces(), 3, "untangled");
  // below the cap, the loop ended on a pass that lowered nothing: one pass fewer, same folds
  ASSERT_LT(many.passes, 4) << "the test wants the stop rule to end the passes";
  BarycentricMap Pk, Qk;
  const SurfaceUntangling fewer = run(many.passes - 1, Pk, Qk);
  EXPECT_EQ(folds(fewer), folds(many));
  std::printf("folds: %d at the start, %d after 1 pass, %d after %d (stopped), %d after %d\n",
              bad(A, B, P0) + bad(B, A, Q0), folds(one), folds(many), many.passes, folds(fewer),
              fewer.passes);
}
