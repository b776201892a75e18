// Issue 20: untangling a surface map on its target (surface/untangle.h): the energy's gradient
// against finite differences, and injected folds on a generated pair come out fold-free.
#include "shapemap/eval/surface_distortion.h"
#include "surface_test_util.h"
#include "shapemap/error.h"
#include "shapemap/generate.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/surface/untangle.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <cmath>
#include <random>
#include <utility>

using namespace shapemap;
using namespace shapemap::testing;

namespace {

// The image of vertex v moved to the point p of T (closest point).
void move_image(BarycentricMap& P, int v, const Eigen::Vector3d& p, const ClosestPoint3& bvh) {
  const ClosestPointResult r = bvh.query(p);
  P.elem(v) = r.elem;
  P.bary.row(v) = r.bary.head<3>().transpose() / r.bary.head<3>().sum();
}

// near (per vertex) grown by `rings` rings of the vertex neighbours nb.
void grow_rings(std::vector<char>& near, const std::vector<std::vector<int>>& nb, int rings) {
  for (int k = 0; k < rings; ++k) {
    std::vector<char> next = near;
    for (size_t x = 0; x < near.size(); ++x)
      if (near[x])
        for (int y : nb[x]) next[y] = 1;
    near.swap(next);
  }
}

// The largest distance from the truth of an image, over the vertices not marked near and over
// all vertices (P's images against truth, both on T).
std::pair<double, double> moves_from_truth(const BarycentricMap& P, const TriMesh& T, const Eigen::MatrixXd& truth,
                                           const std::vector<char>& near) {
  const Eigen::MatrixXd Y = map_positions(P, T.V, T.F);
  double far_moved = 0, err = 0;
  for (int v = 0; v < Y.rows(); ++v) {
    const double d = (Y.row(v) - truth.row(v)).norm();
    if (!near[v]) far_moved = std::max(far_moved, d);
    err = std::max(err, d);
  }
  return {far_moved, err};
}

// Folds injected into the ground-truth map of a generated pair: every n/6-th vertex v from 7 has
// its image moved past its first neighbour's (by `beyond` of their distance: a turn-over) or,
// every third one, onto it (a collapse).
struct InjectedFolds {
  BarycentricMap P;                    // the map with the folds
  int count = 0;                       // vertices moved
  std::vector<char> near;              // the moved vertices and `rings` rings around them
  std::vector<std::vector<int>> nb;    // A's vertex neighbours
};
InjectedFolds inject_folds(const GeneratedPair& pair, double beyond, int rings) {
  const TriMesh &A = pair.A, &B = pair.B;
  const ClosestPoint3 bvh(B.V, B.F);
  const Eigen::MatrixXd truth = map_positions(pair.truth_AB, B.V, B.F);
  const int n = A.num_vertices();
  InjectedFolds in;
  in.P = pair.truth_AB;
  in.near.assign(n, 0);
  in.nb.assign(n, {});
  for (int f = 0; f < A.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) in.nb[A.F(f, j)].push_back(A.F(f, (j + 1) % 3));
  for (int v = 7; v < n; v += n / 6, ++in.count) {
    const int w = in.nb[v][0];
    const Eigen::Vector3d pv = truth.row(v).transpose(), pw = truth.row(w).transpose();
    if (in.count % 3 == 2) move_image(in.P, v, pw, bvh);      // collapse
    else move_image(in.P, v, pw + beyond * (pw - pv), bvh);  // turn over
    in.near[v] = 1;
  }
  grow_rings(in.near, in.nb, rings);
  return in;
}

}  // namespace

// dE/dY of one mapped triangle against central differences: upright, nearly collapsed and
// turned-over triangles, small and large delta.
TEST(Untangle, TriangleEnergyGradientMatchesFiniteDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int checked = 0;
  for (double delta : {1e-3, 1e-2, 0.1, 1.0})
    for (int trial = 0; trial < 20; ++trial) {
      Eigen::Vector3d n(u(rng), u(rng), u(rng));
      n.normalize();
      Eigen::Matrix3d Y;
      for (int j = 0; j < 3; ++j) Y.row(j) << u(rng), u(rng), u(rng);
      if (trial % 4 == 3) Y.row(2) = 0.5 * (Y.row(0) + Y.row(1)) + 1e-3 * Eigen::RowVector3d(u(rng), u(rng), u(rng));
      Eigen::Matrix2d R;
      R << 1 + 0.3 * u(rng), 0.4 * u(rng), 0, 0.8 + 0.3 * u(rng);
      const Eigen::Matrix2d Rinv = R.inverse();
      const double area = 0.5 * R.determinant();
      Eigen::Matrix3d G;
      const double E = untangle_triangle_energy(Y, n, Rinv, area, delta, &G);
      ASSERT_TRUE(std::isfinite(E));
      ASSERT_GT(E, 0);
      double max_err = 0;
      const double h = 1e-7;
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) {
          Eigen::Matrix3d Yp = Y, Ym = Y;
          Yp(j, k) += h;
          Ym(j, k) -= h;
          const double fd = (untangle_triangle_energy(Yp, n, Rinv, area, delta) -
                             untangle_triangle_energy(Ym, n, Rinv, area, delta)) / (2 * h);
          max_err = std::max(max_err, std::abs(fd - G(j, k)));
        }
      EXPECT_LT(max_err, 1e-5 * std::max(1.0, G.cwiseAbs().maxCoeff()))
          << "delta " << delta << " trial " << trial;
      ++checked;
    }
  EXPECT_EQ(checked, 80);
}

// d/dy of the reversibility term against central differences, and its value: zero where the
// reverse map sends y back to x.
TEST(Untangle, ReversibilityTermGradientMatchesFiniteDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Matrix3d C, Qc;
    for (int j = 0; j < 3; ++j) {
      C.row(j) << u(rng), u(rng), u(rng);
      Qc.row(j) << u(rng), u(rng), u(rng);
    }
    const Eigen::Vector3d y(u(rng), u(rng), u(rng)), x(u(rng), u(rng), u(rng));
    Eigen::Vector3d g;
    const double w = 0.5 + trial;
    untangle_reversibility_energy(y, C, Qc, x, w, &g);
    double max_err = 0;
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d yp = y, ym = y;
      yp(k) += h;
      ym(k) -= h;
      const double fd = (untangle_reversibility_energy(yp, C, Qc, x, w) -
                         untangle_reversibility_energy(ym, C, Qc, x, w)) / (2 * h);
      max_err = std::max(max_err, std::abs(fd - g(k)));
    }
    EXPECT_LT(max_err, 1e-6 * std::max(1.0, g.cwiseAbs().maxCoeff())) << "trial " << trial;
  }
  // y at barycentric (0.2, 0.3, 0.5) of the face, lifted off its plane: Q(y) = that blend of Qc
  Eigen::Matrix3d C, Qc;
  C << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  Qc << 1, 2, 3, 4, 5, 6, 7, 8, 10;
  const Eigen::Vector3d y(0.3, 0.5, 0.7);
  const Eigen::Vector3d q = 0.2 * Qc.row(0).transpose() + 0.3 * Qc.row(1).transpose() + 0.5 * Qc.row(2).transpose();
  EXPECT_NEAR(untangle_reversibility_energy(y, C, Qc, q, 3.0), 0.0, 1e-24);
  EXPECT_NEAR(untangle_reversibility_energy(y, C, Qc, q + Eigen::Vector3d(0, 0, 2), 3.0), 12.0, 1e-12);
}

// The energy is the symmetric Dirichlet energy: 4 a at a rotation (small delta), more for a
// stretch, far more once the triangle is turned over.
TEST(Untangle, TriangleEnergyIsSymmetricDirichletWithABarrier) {
  const Eigen::Vector3d n(0, 0, 1);
  Eigen::Matrix3d Y;
  Y << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  const Eigen::Matrix2d Rinv = Eigen::Matrix2d::Identity();
  const double a = 0.5;
  EXPECT_NEAR(untangle_triangle_energy(Y, n, Rinv, a, 1e-6), 4 * a, 1e-9);
  Eigen::Matrix3d S = Y;
  S.row(1) *= 2;
  EXPECT_NEAR(untangle_triangle_energy(S, n, Rinv, a, 1e-6), a * (5 + 5.0 / 4), 1e-9);
  Eigen::Matrix3d M = Y;
  M.row(2) *= -1;  // mirrored
  EXPECT_GT(untangle_triangle_energy(M, n, Rinv, a, 1e-2), 1e6 * a);
}

// A ground-truth map with folds injected (images of scattered vertices reflected through a
// neighbour's image: their triangles turn over; images of others put on a neighbour's: their
// triangles collapse) comes out with no flipped or collapsed triangle, vertices far from the
// folds keep their images, and the repaired images are near the truth.
TEST(Untangle, InjectedFoldsOnAGeneratedPairComeOutFoldFree) {
  const GeneratedPair pair = make_creature_pair(3, PairKind::NonIsometric, 1500);
  const TriMesh &A = pair.A, &B = pair.B;
  ASSERT_EQ(bad(A, B, pair.truth_AB), 0);
  const Eigen::MatrixXd truth = map_positions(pair.truth_AB, B.V, B.F);
  const int n = A.num_vertices();
  // the stage moves at most the corners of bad triangles and 2 + 4 + 8 rings around them
  InjectedFolds in = inject_folds(pair, 1.5, 9);
  BarycentricMap& P = in.P;
  const std::vector<char>& near = in.near;
  const int injected = in.count;
  int far = 0;
  for (int x = 0; x < n; ++x) far += !near[x];
  ASSERT_GT(far, n / 5);
  const int bad0 = bad(A, B, P);
  ASSERT_GE(bad0, 2 * injected);
  const UntangleResult r = untangle_surface_map(A, B, P, UntangleOptions{}, &pair.truth_BA);
  EXPECT_EQ(r.before.bad(), bad0);
  EXPECT_EQ(r.after.bad(), 0);
  EXPECT_EQ(bad(A, B, P), 0);
  validate_map(P, n, B.num_faces(), 3, "untangled");
  const double diag = (B.V.colwise().maxCoeff() - B.V.colwise().minCoeff()).norm();
  const auto [far_moved, err] = moves_from_truth(P, B, truth, near);
  EXPECT_EQ(far_moved, 0.0);
  EXPECT_LT(err, 0.05 * diag);
}

// Nothing to do: a fold-free map is returned unchanged.
TEST(Untangle, FoldFreeMapIsUnchanged) {
  const GeneratedPair pair = make_creature_pair(5, PairKind::NearIsometric, 800);
  BarycentricMap P = pair.truth_AB;
  ASSERT_EQ(bad(pair.A, pair.B, P), 0);
  const UntangleResult r = untangle_surface_map(pair.A, pair.B, P);
  EXPECT_EQ(r.regions, 0);
  EXPECT_EQ(r.vertices_moved, 0);
  EXPECT_EQ(P.elem, pair.truth_AB.elem);
  EXPECT_EQ(P.bary, pair.truth_AB.bary);
}

// Stage 4 (UntangleOptions::slivers): images pushed almost onto the segment between two of their
// neighbours' images squash triangles nearly flat without turning them over; the sliver pass
// leaves none of them (MIPS - 2 above the threshold), adds no fold and moves only vertices near
// them; the fold stages' options (sliver_mips 0) leave such a map as it is.
TEST(Untangle, InjectedSliversAreRelaxedWithoutAddingFolds) {
  const GeneratedPair pair = make_creature_pair(3, PairKind::NonIsometric, 1500);
  const TriMesh &A = pair.A, &B = pair.B;
  const ClosestPoint3 bvh(B.V, B.F);
  const Eigen::MatrixXd truth = map_positions(pair.truth_AB, B.V, B.F);
  const int n = A.num_vertices();
  std::vector<std::vector<int>> nb(n);
  for (int f = 0; f < A.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) nb[A.F(f, j)].push_back(A.F(f, (j + 1) % 3));
  const UntangleOptions opt = UntangleOptions::slivers();
  auto slivers = [&](const BarycentricMap& P) {
    const Eigen::VectorXd mips = conformal_distortion(A.V, map_positions(P, B.V, B.F), A.F);
    int c = 0;
    for (int t = 0; t < A.num_faces(); ++t) c += mips(t) > opt.sliver_mips && std::isfinite(mips(t));
    return c;
  };
  ASSERT_EQ(slivers(pair.truth_AB), 0);
  // a vertex v and the face (v, w, x) of A: v's image goes to 2% of the way from the midpoint of
  // w's and x's images back to its own, so (v, w, x) is squashed but keeps its orientation
  BarycentricMap P = pair.truth_AB;
  std::vector<char> near(n, 0);
  int injected = 0;
  for (int f = 11; f < A.num_faces() && injected < 6; f += A.num_faces() / 6) {
    const int v = A.F(f, 0), w = A.F(f, 1), x = A.F(f, 2);
    if (near[v] || near[w] || near[x]) continue;
    const Eigen::Vector3d mid = 0.5 * (truth.row(w) + truth.row(x)).transpose();
    move_image(P, v, mid + 0.02 * (Eigen::Vector3d(truth.row(v).transpose()) - mid), bvh);
    near[v] = 1;
    ++injected;
  }
  ASSERT_GE(injected, 4);
  const int folds0 = bad(A, B, P), slivers0 = slivers(P);
  ASSERT_EQ(folds0, 0);
  ASSERT_GE(slivers0, injected);
  BarycentricMap unchanged = P;
  const UntangleResult none = untangle_surface_map(A, B, unchanged, UntangleOptions{}, &pair.truth_BA);
  EXPECT_EQ(none.regions, 0);
  EXPECT_EQ(unchanged.elem, P.elem);
  EXPECT_EQ(unchanged.bary, P.bary);
  // the pass moves at most the corners of slivers and 2 + 4 rings around them
  grow_rings(near, nb, 7);
  const UntangleResult r = untangle_surface_map(A, B, P, opt, &pair.truth_BA);
  EXPECT_EQ(r.slivers_before, slivers0);
  EXPECT_EQ(r.slivers_after, slivers(P));
  EXPECT_EQ(slivers(P), 0);
  EXPECT_LE(bad(A, B, P), folds0);
  validate_map(P, n, B.num_faces(), 3, "relaxed");
  const double diag = (B.V.colwise().maxCoeff() - B.V.colwise().minCoeff()).norm();
  const auto [far_moved, err] = moves_from_truth(P, B, truth, near);
  EXPECT_EQ(far_moved, 0.0);
  EXPECT_LT(err, 0.05 * diag);
}

// Stage 6 (UntangleOptions::search): the re-seating search on its own removes injected turn-overs
// and collapses, never has more folds than it started with, moves only vertices near them (two
// sweeps: the folds' corners and their neighbours, twice), and trades no fold for a triangle
// squashed beyond search_max_mips (or the worst there was).
TEST(Untangle, SearchReseatsTheCornersOfFolds) {
  const GeneratedPair pair = make_creature_pair(3, PairKind::NonIsometric, 1500);
  const TriMesh &A = pair.A, &B = pair.B;
  const Eigen::MatrixXd truth = map_positions(pair.truth_AB, B.V, B.F);
  const int n = A.num_vertices();
  InjectedFolds in = inject_folds(pair, 0.8, 4);
  BarycentricMap& P = in.P;
  const std::vector<char>& near = in.near;
  const int injected = in.count;
  const int bad0 = bad(A, B, P);
  ASSERT_GE(bad0, injected);
  auto max_mips = [&](const BarycentricMap& M) {
    const Eigen::VectorXd mips = conformal_distortion(A.V, map_positions(M, B.V, B.F), A.F);
    double m = 0;
    for (int t = 0; t < A.num_faces(); ++t)
      if (std::isfinite(mips(t))) m = std::max(m, mips(t));
    return m;
  };
  const double mips0 = max_mips(P);
  UntangleOptions opt = UntangleOptions::search();
  opt.search_sweeps = 2;
  const UntangleResult r = untangle_surface_map(A, B, P, opt, &pair.truth_BA);
  EXPECT_EQ(r.before.bad(), bad0);
  EXPECT_EQ(r.after.bad(), bad(A, B, P));
  EXPECT_EQ(r.after.bad(), 0);
  EXPECT_GT(r.vertices_moved, 0);
  EXPECT_LE(max_mips(P), std::max(opt.search_max_mips, mips0));
  validate_map(P, n, B.num_faces(), 3, "searched");
  const double diag = (B.V.colwise().maxCoeff() - B.V.colwise().minCoeff()).norm();
  const auto [far_moved, err] = moves_from_truth(P, B, truth, near);
  EXPECT_EQ(far_moved, 0.0);
  EXPECT_LT(err, 0.05 * diag);
}

// UntangleOptions::held (the refinement's anchors): the images of held vertices stay in the
// relaxation, the slivers' stage and the search, while the folds around them are still undone by
// moving their neighbours. Held here: the vertex each injected fold was pushed past or onto.
TEST(Untangle, HeldVerticesKeepTheirImages) {
  const GeneratedPair pair = make_creature_pair(3, PairKind::NonIsometric, 1500);
  const TriMesh &A = pair.A, &B = pair.B;
  const InjectedFolds in = inject_folds(pair, 1.5, 9);
  std::vector<int> held;
  for (int v = 7; v < A.num_vertices() && int(held.size()) < in.count; v += A.num_vertices() / 6)
    held.push_back(in.nb[v][0]);
  ASSERT_GE(held.size(), 4u);
  const int bad0 = bad(A, B, in.P);
  ASSERT_GT(bad0, 0);
  for (UntangleOptions opt : {UntangleOptions{}, UntangleOptions::slivers(), UntangleOptions::search()}) {
    BarycentricMap P = in.P;
    opt.held = held;
    const UntangleResult r = untangle_surface_map(A, B, P, opt, &pair.truth_BA);
    for (int v : held) {
      EXPECT_EQ(P.elem(v), in.P.elem(v));
      EXPECT_EQ(P.bary.row(v), in.P.bary.row(v));
    }
    EXPECT_LE(r.after.bad(), r.before.bad());
    if (opt.sliver_mips == 0) EXPECT_LT(r.after.bad(), bad0);  // the fold stages undo folds still
  }
  BarycentricMap P = in.P;
  UntangleOptions opt;
  opt.held = held;
  untangle_surface_map(A, B, P, opt, &pair.truth_BA);
  EXPECT_EQ(bad(A, B, P), 0);
  // without them held, the relaxation moves some of them
  BarycentricMap free_map = in.P;
  untangle_surface_map(A, B, free_map, UntangleOptions{}, &pair.truth_BA);
  int moved = 0;
  for (int v : held) moved += free_map.elem(v) != in.P.elem(v) || free_map.bary.row(v) != in.P.bary.row(v);
  EXPECT_GT(moved, 0);
  opt.held = {A.num_vertices()};
  EXPECT_THROW(untangle_surface_map(A, B, P, opt), InputError);
}
