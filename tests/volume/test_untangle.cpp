// untangle_tets (untangle.h) with a feasible set: the landing's use, positions kept in the
// target (here the unit cube, the closest point of a box being a clamp).
#include "shapemap/volume/untangle.h"
#include "shapemap/geometry/tet_volume.h"
#include "../geometry/fixtures.h"
#include <gtest/gtest.h>
#include <vector>

namespace {

int folded(const Eigen::MatrixXi& T, const Eigen::MatrixXd& f, std::vector<char>* in_folded = nullptr) {
  int k = 0;
  for (int t = 0; t < T.rows(); ++t) {
    if (shapemap::signed_tet_volume(f.row(T(t, 0)), f.row(T(t, 1)), f.row(T(t, 2)), f.row(T(t, 3))) > 0) continue;
    ++k;
    if (in_folded)
      for (int c = 0; c < 4; ++c) (*in_folded)[T(t, c)] = 1;
  }
  return k;
}

}  // namespace

// Folds made by moving interior vertices past their neighbours and boundary vertices along
// the cube's faces: untangled with every position in the cube, and only vertices of folded
// tets moved (a move never adds a folded tet to the star it is judged on).
TEST(UntangleTets, UnfoldsInsideTheFeasibleSetAndMovesOnlyFoldedVertices) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  const int n = 5;
  shapemap::testing::tet_grid(n, 0.1, 7, V, T);
  auto on_boundary = [&](int i) {
    return (V.row(i).array() < 1e-12).any() || (V.row(i).array() > 1 - 1e-12).any();
  };
  auto id = [&](int i, int j, int k) { return (k * (n + 1) + j) * (n + 1) + i; };
  Eigen::MatrixXd f = V;
  const double h = 1.0 / n;
  f.row(id(2, 2, 2)) += Eigen::RowVector3d(1.6 * h, 0.3 * h, 0.0);   // past its +x neighbour
  f.row(id(3, 1, 3)) += Eigen::RowVector3d(-0.2 * h, 1.5 * h, -0.4 * h);
  f.row(id(2, 0, 2)) += Eigen::RowVector3d(1.4 * h, 0.0, 0.2 * h);    // along the face y = 0
  f.row(id(0, 3, 3)) += Eigen::RowVector3d(0.0, -1.3 * h, 1.2 * h);   // along the face x = 0
  std::vector<char> moved_ok(V.rows(), 0);
  const int before = folded(T, f, &moved_ok);
  ASSERT_GE(before, 8);

  shapemap::UntangleRules rules;
  rules.boundary = on_boundary;
  rules.place = [](int, Eigen::RowVector3d& y) { y = y.cwiseMax(0.0).cwiseMin(1.0); };
  const Eigen::MatrixXd f0 = f;
  const int left = shapemap::untangle_tets(T, rules, 50, f);

  EXPECT_EQ(left, 0);
  EXPECT_EQ(folded(T, f), 0);
  EXPECT_GE(f.minCoeff(), 0.0);
  EXPECT_LE(f.maxCoeff(), 1.0);
  for (int i = 0; i < f.rows(); ++i)
    if (!moved_ok[i]) EXPECT_EQ(f.row(i), f0.row(i)) << "vertex " << i << " of no folded tet moved";
}

// Without room (every position clamped to where it is), nothing moves and the folds stay.
TEST(UntangleTets, KeepsPositionsWhenTheFeasibleSetLeavesNoRoom) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  shapemap::testing::tet_grid(3, 0.0, 1, V, T);
  Eigen::MatrixXd f = V;
  f.row(21) += Eigen::RowVector3d(0.5, 0.1, 0.0);  // interior vertex (1,1,1) of the 4^3 grid
  const Eigen::MatrixXd f0 = f;
  const int before = folded(T, f);
  ASSERT_GT(before, 0);
  shapemap::UntangleRules rules;
  rules.boundary = [](int) { return false; };
  rules.place = [&](int i, Eigen::RowVector3d& y) { y = f0.row(i); };
  EXPECT_EQ(shapemap::untangle_tets(T, rules, 10, f), before);
  EXPECT_EQ(f, f0);
}
