// reconcile_boundary_step (reconcile_boundary.h) and TargetCoverage (target_coverage.h):
// the landing's last step, the two maps' boundaries made mutually inverse without
// uncovering the target.
#include "shapemap/geometry/closest_point.h"
#include "shapemap/volume/reconcile_boundary.h"
#include "shapemap/volume/target_coverage.h"
#include "volume_test_util.h"
#include <gtest/gtest.h>
#include <cmath>

namespace {

using namespace shapemap;

// Round trip of the boundary: each boundary vertex v of the first side through X (onto the
// second side's boundary), then through the second side's boundary map (piecewise linear on
// its triangles); largest distance from v.
double boundary_round_trip(const BoundaryMapSide& s, const BoundaryMapSide& other, const ClosestPoint3& on_other) {
  double worst = 0;
  for (Eigen::Index b = 0; b < s.b.to_volume.size(); ++b) {
    const int v = s.b.to_volume(b);
    const ClosestPointResult h = on_other.query(Eigen::Vector3d(s.X.row(v).transpose()));
    Eigen::RowVector3d back = Eigen::RowVector3d::Zero();
    for (int c = 0; c < 3; ++c) back += h.bary(c) * other.X.row(other.b.to_volume(other.b.surface.F(h.elem, c)));
    worst = std::max(worst, (back - s.V.row(v)).norm());
  }
  return worst;
}

Eigen::RowVector3d closest_on(const ClosestPoint3& surface, const Eigen::RowVector3d& x) {
  const ClosestPointResult h = surface.query(Eigen::Vector3d(x.transpose()));
  Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
  for (int c = 0; c < 3; ++c) p += h.bary(c) * surface.vertices().row(surface.elements()(h.elem, c));
  return p;
}

}  // namespace

// Two copies of a box; X_12 slides the bottom face's vertices along it by a smooth field e
// (0.02 of the box at most), X_21 is the identity: the round trip misses by up to |e|. One
// symmetric step moves each map halfway, and the round trip then misses by O(|e|^2) in both
// directions (here below a fifth of before); every proposed point lies on the other box.
TEST(ReconcileBoundary, MidpointStepCancelsTheRoundTripErrorToFirstOrder) {
  const TetMesh M = test_volume::grid_box(8, 8, 8, 1.0, 1.0, 1.0);
  const TetBoundary b = boundary_surface(M);
  Eigen::MatrixXd X12 = M.V, X21 = M.V;
  for (int v = 0; v < M.num_vertices(); ++v) {
    const double x = M.V(v, 0), y = M.V(v, 1);
    if (M.V(v, 2) == 0) X12(v, 0) += 0.02 * std::sin(M_PI * x) * std::sin(M_PI * y);
  }
  std::vector<char> on(M.num_vertices(), 0);
  for (Eigen::Index s = 0; s < b.to_volume.size(); ++s) on[b.to_volume(s)] = 1;
  const ClosestPoint3 surface(b.surface.V, b.surface.F);
  auto project = [&](const Eigen::RowVector3d& x) { return closest_on(surface, x); };
  const BoundaryMapSide s1{M.V, b, X12, on}, s2{M.V, b, X21, on};
  const double before12 = boundary_round_trip(s1, s2, surface), before21 = boundary_round_trip(s2, s1, surface);
  ASSERT_GT(before12, 0.015);
  std::vector<std::pair<int, Eigen::RowVector3d>> m12, m21;
  reconcile_boundary_step(s1, s2, project, project, m12, m21);
  EXPECT_EQ(m12.size(), size_t(b.to_volume.size()));
  EXPECT_EQ(m21.size(), size_t(b.to_volume.size()));
  for (const auto* moves : {&m12, &m21})
    for (const auto& [v, p] : *moves) EXPECT_LT(std::sqrt(surface.query(Eigen::Vector3d(p.transpose())).sqdist), 1e-12);
  for (const auto& [v, p] : m12) X12.row(v) = p;
  for (const auto& [v, p] : m21) X21.row(v) = p;
  const double after12 = boundary_round_trip(s1, s2, surface), after21 = boundary_round_trip(s2, s1, surface);
  std::printf("boundary round trip: 1->2->1 %.3g -> %.3g, 2->1->2 %.3g -> %.3g\n", before12, after12, before21,
              after21);
  EXPECT_LT(after12, 0.2 * before12);
  EXPECT_LT(after21, 0.2 * before21);
}

// Maps that are already inverse are left where they are.
TEST(ReconcileBoundary, InverseMapsStay) {
  const TetMesh M = test_volume::grid_box(4, 3, 3, 1.0, 0.8, 0.6);
  const TetBoundary b = boundary_surface(M);
  std::vector<char> on(M.num_vertices(), 1);
  const ClosestPoint3 surface(b.surface.V, b.surface.F);
  auto project = [&](const Eigen::RowVector3d& x) { return closest_on(surface, x); };
  const BoundaryMapSide s{M.V, b, M.V, on};
  std::vector<std::pair<int, Eigen::RowVector3d>> m12, m21;
  reconcile_boundary_step(s, s, project, project, m12, m21);
  for (const auto& [v, p] : m12) EXPECT_LT((p - M.V.row(v)).norm(), 1e-12);
}

namespace {

Eigen::MatrixXi pyramid_faces() {
  Eigen::MatrixXi F(6, 3);
  F << 0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4, 0, 2, 1, 0, 3, 2;
  return F;
}

Eigen::MatrixXd pyramid_vertices() {
  Eigen::MatrixXd V(5, 3);
  V << 1, -1, 0, 1, 1, 0, -1, 1, 0, -1, -1, 0, 0, 0, 1;
  return V;
}

}  // namespace

// The image of a square pyramid equal to the target covers it (every distance 0). Sliding
// the image's apex down a side face (x + z = 1, still on the target) uncovers the target's
// apex: refused unless the allowed distance exceeds the gap it opens; kept, the distances
// follow. A move the caller's rule refuses is not made.
TEST(TargetCoverage, RefusesMovesThatUncoverTheTarget) {
  const Eigen::MatrixXi F = pyramid_faces();
  const Eigen::MatrixXd Vj = pyramid_vertices();
  Eigen::MatrixXd X = Vj;
  const std::vector<int> rows{0, 1, 2, 3, 4};
  TargetCoverage c(X, F, rows, Vj);
  for (double d : c.distances()) EXPECT_LT(d, 1e-12);
  const Eigen::RowVector3d down(0.3, 0, 0.7);
  auto slide = [&](int r) {
    X.row(r) = down;
    return true;
  };
  EXPECT_EQ(c.surface_vertex(4), 4);
  EXPECT_FALSE(c.move(X, 4, slide, 0.01));
  EXPECT_EQ(X.row(4), Vj.row(4));
  EXPECT_FALSE(c.move(X, 4, [](int) { return false; }, 10.0));
  EXPECT_TRUE(c.move(X, 4, slide, 10.0));
  EXPECT_EQ(X.row(4), down);
  EXPECT_GT(c.distances()[4], 0.1);
  // Back to the apex: the gap closes, a move that uncovers nothing.
  EXPECT_TRUE(c.move(X, 4, [&](int r) {
    X.row(r) = Vj.row(4);
    return true;
  }, 0.0));
  EXPECT_LT(c.distances()[4], 1e-12);
}

// The landing's local gamma round (mark_uncovered): with the image's apex slid down a side
// face, the target's apex is the one vertex farther from the image than a threshold below
// its gap; it is marked with `rings` rings of the target, and of the image only the vertices
// within `reach` of it (the slid apex, 0.42 away; the base corners are 1.7 away). Above the
// gap nothing is marked.
TEST(TargetCoverage, MarksWhereTheImageDoesNotCoverTheTarget) {
  const Eigen::MatrixXi F = pyramid_faces();
  const Eigen::MatrixXd Vj = pyramid_vertices();
  Eigen::MatrixXd X = Vj;
  X.row(4) = Eigen::RowVector3d(0.3, 0, 0.7);
  const std::vector<int> rows{0, 1, 2, 3, 4};
  const double gap = TargetCoverage(X, F, rows, Vj).distances()[4];
  ASSERT_GT(gap, 0.1);
  std::vector<char> mi, mj;
  EXPECT_EQ(mark_uncovered(X, F, rows, Vj, F, 0.5 * gap, 0, 0.5, mi, mj), 1);
  EXPECT_EQ(mj, (std::vector<char>{0, 0, 0, 0, 1}));
  EXPECT_EQ(mi, (std::vector<char>{0, 0, 0, 0, 1}));
  EXPECT_EQ(mark_uncovered(X, F, rows, Vj, F, 0.5 * gap, 1, 2.0, mi, mj), 1);
  EXPECT_EQ(mj, (std::vector<char>{1, 1, 1, 1, 1}));
  EXPECT_EQ(mi, (std::vector<char>{1, 1, 1, 1, 1}));
  EXPECT_EQ(mark_uncovered(X, F, rows, Vj, F, 2.0 * gap, 2, 2.0, mi, mj), 0);
  EXPECT_EQ(mj, (std::vector<char>(5, 0)));
  EXPECT_EQ(mi, (std::vector<char>(5, 0)));
}
