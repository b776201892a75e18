// Regression test of the ball parameterization on a small generated creature volume
// (thin limbs: the hard case for a ball map). Guards the spherical area-preserving
// boundary map (SEM + untangling + Riemannian refinement), the IEM CG and the untangling
// post-step together (isovolumetric-ball-parameterization.txt, Algorithm 1; Table 2).
#include "shapemap/eval/ball_metrics.h"
#include "shapemap/generate.h"
#include "shapemap/volume/ball_param.h"
#include "shapemap/volume/sphere_param.h"
#include "shapemap/volume/tetrahedralize.h"
#include <gtest/gtest.h>
#include <cstdio>

using namespace shapemap;

TEST(BallParamCreature, SmallCreatureNoFoldsLowDistortion) {
  const TriMesh s = make_creature(4, 1200);
  TetrahedralizeOptions to;
  to.target_tets = 8000;
  const TetMesh m = tetrahedralize(s, to);
  ASSERT_GT(m.num_tets(), 1000);
  BallParamOptions opt;
  opt.max_iterations = 500;
  const BallParamResult r = ball_parameterization(m, opt);
  const BallMetrics bm = ball_metrics(m, r.f);
  const BallMetrics bv = ball_metrics(m, r.f_vsem);
  std::printf("creature: %d vertices %d tets, E_I %.4g -> %.4g, mean D_V %.4g -> %.4g, folded %d -> %d (cg %d)\n", m.num_vertices(), m.num_tets(), r.energy_vsem, r.energy_final, bv.dv_mean, bm.dv_mean, bv.folded_tets, bm.folded_tets, r.inverted_cg);
  EXPECT_EQ(bm.folded_tets, 0);
  EXPECT_FALSE(r.fold_retry);  // the post-step alone removes the folds on this seed
  // Measured (Release, this seed, ODT-smoothed tets): 1745 vertices, 7039 tets, E_I 0.517
  // -> 0.018, mean D_V 0.246 -> 0.0435, folded 87 -> 0 (2 after CG, removed by the
  // untangling post-step). Without ODT (7328 tets): mean D_V 0.056, so this threshold also
  // guards the mesh smoothing. The target mean D_V <= 3e-2 is NOT reached on
  // creatures (docs/methods.md); this threshold guards the current level.
  EXPECT_LT(bm.dv_mean, 0.05);
  EXPECT_LE(r.energy_final, 0.5 * r.energy_vsem);   // Sec. 6 target
  EXPECT_LT(bm.dv_mean, bv.dv_mean);
  EXPECT_LE(bm.boundary_sphere_error, 1e-9);
}

// The boundary-layer barrier (BallParamOptions::boundary_barrier, docs/methods.md): E_I
// alone lets the boundary layer of a limbed shape fold over (image tets overlap although
// none is inverted); with the barrier the ball is covered once.
TEST(BallParamCreature, BoundaryBarrierRemovesOverlap) {
  const TriMesh s = make_creature(1, 1200);
  TetrahedralizeOptions to;
  to.target_tets = 8000;
  const TetMesh m = tetrahedralize(s, to);
  BallParamOptions plain, barrier;
  plain.fold_retry_barrier = 0;  // the paper's E_I throughout, whatever the folds
  barrier.boundary_barrier = 0.01;
  const BallParamResult a = ball_parameterization(m, plain), b = ball_parameterization(m, barrier);
  const BallMetrics ma = ball_metrics(m, a.f), mb = ball_metrics(m, b.f);
  std::printf("creature 1: %d tets; plain: overlap %.4f flipped %d folded %d D_V %.4f | barrier: overlap %.4f flipped %d folded %d D_V %.4f\n",
              m.num_tets(), ma.overlap_fraction, ma.flipped_boundary_faces, ma.folded_tets, ma.dv_mean,
              mb.overlap_fraction, mb.flipped_boundary_faces, mb.folded_tets, mb.dv_mean);
  EXPECT_GT(ma.overlap_fraction, 1e-3);
  EXPECT_LT(mb.overlap_fraction, 5e-4);  // measured < 1e-4 (plain: 1.2e-2)
  EXPECT_LE(mb.folded_tets, ma.folded_tets);
  EXPECT_LT(mb.dv_mean, 0.08);
  EXPECT_NEAR(b.energy_final, mb.energy, 1e-9);  // reported E_I is without the barrier
  EXPECT_LE(b.energy_final, 0.5 * b.energy_vsem);
}

// Fold retry (BallParamOptions::fold_retry_barrier): a creature whose plain run keeps an
// inverted tet after the post-step is run again with the boundary barrier, which removes it.
TEST(BallParamCreature, FoldRetryRemovesTheLastInvertedTet) {
  const TriMesh s = make_creature(3, 1200);
  TetrahedralizeOptions to;
  to.target_tets = 8000;
  to.seed = 3;
  const TetMesh m = tetrahedralize(s, to);
  BallParamOptions plain;
  plain.fold_retry_barrier = 0;
  const BallParamResult a = ball_parameterization(m, plain), b = ball_parameterization(m);
  const BallMetrics mb = ball_metrics(m, b.f);
  std::printf("creature 3: %d tets; plain: %d inverted, E_I %.4g | default: retry %d kept %d, %d inverted, E_I %.4g, mean D_V %.4f\n",
              m.num_tets(), a.inverted_final, a.energy_final, int(b.fold_retry), int(b.fold_retry_kept),
              b.inverted_final, b.energy_final, mb.dv_mean);
  // Measured: plain 2 inverted (E_I 0.0286); retry 0 inverted, E_I 0.0343, mean D_V 0.062.
  // (Seed 6 served until the Z-order renumbering of Dec 2026 changed its rounding: chaotic.)
  ASSERT_GT(a.inverted_final, 0);  // the case still needs the retry
  EXPECT_FALSE(a.fold_retry);
  EXPECT_TRUE(b.fold_retry);
  EXPECT_TRUE(b.fold_retry_kept);
  EXPECT_EQ(b.inverted_before_retry, a.inverted_final);
  EXPECT_GT(b.seconds_retry, 0.0);
  // The retry starts from the first run's VSEM result (same boundary map).
  EXPECT_EQ((b.f_vsem - a.f_vsem).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(b.sphere_start, a.sphere_start);
  EXPECT_EQ(b.inverted_final, 0);
  EXPECT_EQ(mb.folded_tets, 0);
  EXPECT_LT(mb.dv_mean, 0.1);
  EXPECT_LE(b.energy_final, 0.5 * b.energy_vsem);
}

TEST(SphereParam, CreatureBoundaryMapIsFoldFreeAndNearlyEquiareal) {
  const TriMesh s = make_creature(2, 800);
  const SphereParamResult r = spherical_area_preserving_map(s);
  EXPECT_EQ(r.folded_faces, 0);
  EXPECT_LT(r.area_distortion_mean, 0.3);  // was ~0.6 when SEM stopped after 2 steps
}

// Regression: on coarse generated creatures the published SEM fixed point (from the CEM
// result) folds many faces (on make_creature(5, 700): 62 folded, mean distortion 1.73;
// the ball then had hundreds of folded tets). The damped SEM / linear-start candidates
// (SphereParamOptions::stretch_fold_allowance, try_linear_start) must fix it.
TEST(SphereParam, CoarseCreatureBoundaryMapFewFolds) {
  const TriMesh s = make_creature(5, 700);
  SphereParamOptions published;
  published.stretch_fold_allowance = 1.0;
  published.try_linear_start = false;
  published.latitude_start_distortion = 0;
  const SphereParamResult a = spherical_area_preserving_map(s, {}, published);
  const SphereParamResult b = spherical_area_preserving_map(s);
  std::printf("coarse creature %d vertices: published SEM folded %d mean D %.3f | with candidates folded %d mean D %.3f (start %d, damped %d) %.2fs\n",
              int(s.V.rows()), a.folded_faces, a.area_distortion_mean, b.folded_faces,
              b.area_distortion_mean, b.start_stage, int(b.stretch_damped), b.seconds);
  EXPECT_GT(a.folded_faces, 20);  // the case is still hard for the published path
  // Measured (Release): 1006 vertices, published 62 folded / mean D 1.727; new 1 / 0.248.
  EXPECT_LE(b.folded_faces, 3);
  EXPECT_LT(b.area_distortion_mean, 0.4);
  EXPECT_LE(b.folded_faces, a.folded_faces);
}

// Regression: the demo's small creature (pair A of seed 1, 1,200 vertices, ~8,000 tets,
// AST applied as in Algorithm 1). Its linear map put 80% of the boundary vertices on a thin
// ring; CEM took no step, SEM stalled, and the kept result had 0 folded faces but a mean
// area distortion of 1.9 (max 170): the old selection (fewest folds first) kept it and the
// ball map failed (42 folded tets, mean D_V 1.43). A collapsed result must lose.
TEST(SphereParam, CollapsedResultLosesToAFewFolds) {
  const GeneratedPair p = make_creature_pair(1, PairKind::NonIsometric, 1200);
  TetrahedralizeOptions to;
  to.target_tets = 8000;
  to.seed = 1;
  TetMesh m = tetrahedralize(p.A, to);
  m.V = anisotropic_scaling(m.V).apply(m.V);
  const TriMesh s = boundary_surface(m).surface;
  SphereParamOptions folds_first;
  folds_first.latitude_start_distortion = 0;
  const SphereParamResult a = spherical_area_preserving_map(s, {}, folds_first);
  const SphereParamResult b = spherical_area_preserving_map(s);
  std::printf("demo creature A (%d boundary vertices): folds first: folded %d mean %.3f max %.3g | default: folded %d mean %.3f max %.3g (start %d)\n",
              int(s.V.rows()), a.folded_faces, a.area_distortion_mean, a.area_distortion_max, b.folded_faces,
              b.area_distortion_mean, b.area_distortion_max, b.start_stage);
  // Measured: folds first 0 folded, mean 1.92, max 171; default 3 folded, mean 0.30, max 3.1.
  EXPECT_GT(a.area_distortion_max, 10.0);  // the case still collapses without the rule
  EXPECT_LT(b.area_distortion_max, 10.0);
  EXPECT_LT(b.area_distortion_mean, 0.5);
  EXPECT_LE(b.folded_faces, 10);
}

// Elongated shapes: a conformal start shrinks a long thin part exponentially (conformal
// factor ~exp(-pi L / w)), so SEM starts from numerically collapsed faces. The
// latitude-longitude start (SphereParamOptions::latitude_start_distortion) grows linearly
// along the long axis.
TEST(SphereParam, ElongatedShapeUsesLatitudeLongitudeStart) {
  TriMesh s = make_sphere(2500);
  s.V.col(2) *= 16.0;  // a 16:1 ellipsoid of revolution
  SphereParamOptions conformal_only;
  conformal_only.latitude_start_distortion = 0;
  const SphereParamResult a = spherical_area_preserving_map(s, {}, conformal_only);
  const SphereParamResult b = spherical_area_preserving_map(s);
  std::printf("16:1 ellipsoid: conformal starts folded %d mean %.3f max %.3g | default folded %d mean %.3f max %.3g (start %d)\n",
              a.folded_faces, a.area_distortion_mean, a.area_distortion_max, b.folded_faces,
              b.area_distortion_mean, b.area_distortion_max, b.start_stage);
  // Measured (2,562 vertices): conformal starts 337 folded, mean |ratio - 1| 2.29, max 694;
  // latitude-longitude start 0 folded, mean 0.005, max 0.026. (At 10:1 the conformal
  // starts still succeed: 0 folded, mean 0.022.)
  EXPECT_GT(a.folded_faces, 100);
  EXPECT_EQ(b.start_stage, 2);
  EXPECT_EQ(b.folded_faces, 0);
  EXPECT_LT(b.area_distortion_mean, 0.05);
  EXPECT_LT(b.area_distortion_max, 0.5);
}

// Stall fallback (BallParamOptions::stall_preconditioner_fallback): on a long bent tube the
// VSEM map is heavily folded, L_V(f^(0)) factors but is nearly singular, and CG with the
// paper's preconditioner stops after a few tiny steps; with L_V(e) it goes on.
TEST(BallParamCreature, StalledCgFallsBackToTheInputLaplacian) {
  TriMesh s = make_sphere(1500);
  // A 30:1 tube (half length 6, radius 0.2) bent through 300 degrees: a horseshoe.
  const double a = 6, t = 0.2, R = a / (150.0 * M_PI / 180.0);
  for (Eigen::Index i = 0; i < s.V.rows(); ++i) {
    const double th = s.V(i, 0) * a / R, y = s.V(i, 1) * t, z = s.V(i, 2) * t;
    s.V.row(i) << (R + y) * std::sin(th), R - (R + y) * std::cos(th), z;
  }
  TetrahedralizeOptions to;
  to.target_tets = 8000;
  const TetMesh m = tetrahedralize(s, to);
  BallParamOptions paper;
  paper.stall_preconditioner_fallback = false;
  paper.fold_retry_barrier = 0;
  BallParamOptions ours = paper;
  ours.stall_preconditioner_fallback = true;
  const BallParamResult p = ball_parameterization(m, paper), q = ball_parameterization(m, ours);
  std::printf("bent tube: %d v, %d tets; E_I after VSEM %.4g; L_V(f0): after CG %.4g, %d CG its, %d folded | "
              "fallback: after CG %.4g, %d folded after CG, %d at the end, E_I final %.4g\n",
              m.num_vertices(), m.num_tets(), p.energy_vsem, p.energy_cg, p.iterations - p.polish_iterations,
              p.inverted_final, q.energy_cg, q.inverted_cg, q.inverted_final, q.energy_final);
  // Measured (1,970 v / 6,860 tets): E_I 11.25 after VSEM, 11.13 after 500 CG iterations,
  // 328 folded at the end; with the fallback 0.580 after CG (387 folded), then the post-step
  // trades E_I for folds: 73 folded, E_I 3.99 (before the Z-order renumbering of Dec 2026,
  // whose rounding changed this chaotic case: 0.350 after CG, 129 folded at the end).
  EXPECT_EQ(p.preconditioner_fallbacks, 0);
  ASSERT_GT(p.energy_cg, 0.5 * p.energy_vsem);  // the case still stalls without it
  EXPECT_EQ(q.preconditioner_fallbacks, 1);
  EXPECT_LT(q.energy_cg, 0.1 * q.energy_vsem);
  EXPECT_LE(q.energy_final, 0.5 * q.energy_vsem);  // the target for E_I
  EXPECT_LE(q.inverted_final, p.inverted_final);
}
