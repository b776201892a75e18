// locate_keeping_positive.h: the last relaxation's interior images located in
// the target; rows whose location turns a tet over go back, and only they.
#include "shapemap/volume/locate_keeping_positive.h"
#include "shapemap/volume/symmetric_map.h"
#include "volume_test_util.h"
#include <gtest/gtest.h>

namespace {

using namespace shapemap;

// A source that is its target (the 4x4x4 box of unit edge 1/4), each vertex located at
// itself: a corner of one of its tets.
struct IdentityBox {
  TetMesh M = test_volume::grid_box(4, 4, 4, 1.0, 1.0, 1.0);
  ArapEnergy arap{M.V, M.T};
  BarycentricMap located;
  std::vector<int> interior;
  IdentityBox() {
    located.elem.resize(M.num_vertices());
    located.bary.setZero(M.num_vertices(), 4);
    for (int k = 0; k < M.num_tets(); ++k)
      for (int c = 0; c < 4; ++c) {
        located.elem(M.T(k, c)) = k;
        located.bary.row(M.T(k, c)).setZero();
        located.bary(M.T(k, c), c) = 1;
      }
    for (int v = 0; v < M.num_vertices(); ++v)
      if ((M.V.row(v).array() > 1e-12).all() && (M.V.row(v).array() < 1 - 1e-12).all()) interior.push_back(v);
  }
  int at(double x, double y, double z) const {
    for (int v = 0; v < M.num_vertices(); ++v)
      if ((M.V.row(v) - Eigen::RowVector3d(x, y, z)).norm() < 1e-12) return v;
    return -1;
  }
};

}  // namespace

// Two interior vertices moved: one a little inside the box (kept), one out through the face
// x = 1, where locating puts it on that face, on top of the boundary vertex there, and turns
// its tets over: it alone goes back. Before, the whole relaxation was undone for it.
TEST(RelocateInterior, PutsBackOnlyTheRowsWhoseLocationTurnsATetOver) {
  IdentityBox box;
  ASSERT_EQ(box.interior.size(), 27u);
  const int kept = box.at(0.25, 0.5, 0.5), out = box.at(0.75, 0.5, 0.5);
  ASSERT_GE(kept, 0);
  ASSERT_GE(out, 0);
  Eigen::MatrixXd X = box.M.V;
  X(kept, 0) += 0.05;
  X(out, 0) = 1.5;
  const Eigen::MatrixXd X_before = box.M.V;
  BarycentricMap located = box.located;
  EXPECT_EQ(relocate_interior(box.arap, box.M, box.interior, X_before, X, located), 1);
  EXPECT_NEAR((X.row(kept) - Eigen::RowVector3d(0.3, 0.5, 0.5)).norm(), 0, 1e-12);
  EXPECT_NEAR((X.row(out) - X_before.row(out)).norm(), 0, 1e-12);
  EXPECT_EQ(located.elem(out), box.located.elem(out));
  const Eigen::VectorXd det = box.arap.determinants(X);
  EXPECT_GT(det.minCoeff(), 0);
  // X is what `located` holds: the map files and the positions agree.
  EXPECT_NEAR((map_positions(located, box.M.V, box.M.T) - X).cwiseAbs().maxCoeff(), 0, 1e-12);
}

// Nothing newly inverted: every interior row takes its located image, none goes back.
TEST(RelocateInterior, KeepsEveryRowWhenNoTetTurnsOver) {
  IdentityBox box;
  Eigen::MatrixXd X = box.M.V;
  for (int v : box.interior) X(v, 1) += 0.03;
  BarycentricMap located = box.located;
  EXPECT_EQ(relocate_interior(box.arap, box.M, box.interior, box.M.V, X, located), 0);
  for (int v : box.interior) EXPECT_NEAR(X(v, 1) - box.M.V(v, 1), 0.03, 1e-12);
}

// With one round only, the round that puts rows back cannot check its result: everything
// stays as it was (X before, the map before).
TEST(RelocateInterior, LeavesTheMapAsItWasWhenTheRoundsRunOut) {
  IdentityBox box;
  const int out = box.at(0.75, 0.5, 0.5);
  Eigen::MatrixXd X = box.M.V;
  X(box.at(0.25, 0.5, 0.5), 0) += 0.05;
  X(out, 0) = 1.5;
  BarycentricMap located = box.located;
  EXPECT_EQ(relocate_interior(box.arap, box.M, box.interior, box.M.V, X, located, 1), -1);
  EXPECT_EQ((X - box.M.V).cwiseAbs().maxCoeff(), 0);
  EXPECT_EQ(located.elem, box.located.elem);
  EXPECT_EQ(located.bary, box.located.bary);
}

// A boundary row moved along the face x = 1 stays when its tets stay positive; moved across
// its neighbour on that face it turns them over and goes back, while an interior row moved
// in the same call stays (take_rows_keeping_positive, as the reconciliation calls it).
TEST(TakeRowsKeepingPositive, PutsBackABoundaryRowThatTurnsItsTetsOver) {
  IdentityBox box;
  const int slide = box.at(1, 0.25, 0.5), cross = box.at(1, 0.5, 0.25), inner = box.at(0.5, 0.5, 0.5);
  ASSERT_GE(slide, 0);
  ASSERT_GE(cross, 0);
  Eigen::MatrixXd Y = box.M.V;
  Y(slide, 1) += 0.05;
  Y(cross, 2) = 0.9;  // past the vertex (1, 0.5, 0.75)
  Y(inner, 0) += 0.02;
  std::vector<char> moved(size_t(box.M.num_vertices()), 0);
  for (int v : {slide, cross, inner}) moved[size_t(v)] = 1;
  Eigen::MatrixXd X = box.M.V;
  BarycentricMap located = box.located;
  EXPECT_EQ(take_rows_keeping_positive(box.arap, box.M, locate_in_tets(box.M, Y), moved, located, X), 1);
  EXPECT_NEAR((X.row(slide) - Y.row(slide)).norm(), 0, 1e-12);
  EXPECT_NEAR((X.row(inner) - Y.row(inner)).norm(), 0, 1e-12);
  EXPECT_NEAR((X.row(cross) - box.M.V.row(cross)).norm(), 0, 1e-12);
  EXPECT_GT(box.arap.determinants(X).minCoeff(), 0);
}
