// return_to_boundary (return_to_boundary.h): the landing's last step, boundary vertices left
// inside the target put back on its boundary or toward it, as the caller's rule allows.
#include "shapemap/volume/return_to_boundary.h"
#include "volume_test_util.h"
#include <gtest/gtest.h>

namespace {

using namespace shapemap;

struct TargetBox {
  TetMesh M = test_volume::grid_box(4, 4, 4, 1.0, 1.0, 1.0);
  TetBoundary b = boundary_surface(M);
  ClosestPoint3 surface{b.surface.V, b.surface.F};
  std::vector<double> insets{0.0, 0.02, 0.05, 0.1, 0.2, 0.4};
  // The vertex at (0.5, 0.5, 0) (a vertex of the face z = 0), its row in M.
  int bottom_centre() const {
    for (int v = 0; v < M.num_vertices(); ++v)
      if ((M.V.row(v) - Eigen::RowVector3d(0.5, 0.5, 0)).norm() < 1e-12) return v;
    return -1;
  }
};

}  // namespace

// Rows on the boundary stay and are listed; a row 0.1 deep under the face z = 0 goes to
// its closest point there when the rule accepts it; when the rule refuses points on the
// boundary it goes to the first inset the rule accepts (the shallowest), above where it was;
// when the rule refuses all, it stays.
TEST(ReturnToBoundary, PutsDeepRowsBackOnTheBoundaryOrAsNearAsTheRuleAllows) {
  const TargetBox box;
  const int v = box.bottom_centre();
  ASSERT_GE(v, 0);
  std::vector<int> rows(box.b.to_volume.data(), box.b.to_volume.data() + box.b.to_volume.size());
  Eigen::MatrixXd X = box.M.V;
  X.row(v) << 0.52, 0.49, 0.1;
  std::vector<int> on;
  auto anywhere = [&](int r, const Eigen::RowVector3d& q) {
    X.row(r) = q;
    return true;
  };
  EXPECT_EQ(return_to_boundary(X, rows, box.M, box.b, box.surface, box.insets, 1e-12, anywhere, on), 1);
  EXPECT_LT((X.row(v) - Eigen::RowVector3d(0.52, 0.49, 0)).norm(), 1e-12);
  EXPECT_EQ(on.size(), rows.size());  // every row on the boundary, v too
  EXPECT_TRUE(std::is_sorted(on.begin(), on.end()));

  X.row(v) << 0.52, 0.49, 0.1;
  auto inside_only = [&](int r, const Eigen::RowVector3d& q) {
    if (q(2) < 1e-9) return false;
    X.row(r) = q;
    return true;
  };
  EXPECT_EQ(return_to_boundary(X, rows, box.M, box.b, box.surface, box.insets, 1e-12, inside_only, on), 1);
  // Inset 0.02 toward the inner corner of the grid tet behind (0.52, 0.49, 0): a point of
  // that tet, 0.02 of its height (0.25) above the face.
  EXPECT_NEAR(X(v, 2), 0.02 * 0.25, 1e-12);
  EXPECT_EQ(on.size(), rows.size() - 1);
  EXPECT_FALSE(std::binary_search(on.begin(), on.end(), v));

  X.row(v) << 0.52, 0.49, 0.1;
  const Eigen::MatrixXd X0 = X;
  EXPECT_EQ(return_to_boundary(X, rows, box.M, box.b, box.surface, box.insets, 1e-12,
                               [](int, const Eigen::RowVector3d&) { return false; }, on),
            0);
  EXPECT_EQ(X, X0);
}

// A row nearer to the boundary than every inset goes only to the boundary itself: an inset
// deeper than where it is would move it away.
TEST(ReturnToBoundary, NeverMovesARowDeeper) {
  const TargetBox box;
  const int v = box.bottom_centre();
  std::vector<int> rows{v};
  Eigen::MatrixXd X = box.M.V;
  X.row(v) << 0.5, 0.5, 0.001;  // shallower than inset 0.02 (0.005 deep)
  std::vector<int> on;
  int tried = 0;
  EXPECT_EQ(return_to_boundary(X, rows, box.M, box.b, box.surface, box.insets, 1e-12,
                               [&](int, const Eigen::RowVector3d& q) {
                                 ++tried;
                                 EXPECT_LT(q(2), 1e-12);
                                 return false;
                               },
                               on),
            0);
  EXPECT_EQ(tried, 1);
  EXPECT_DOUBLE_EQ(X(v, 2), 0.001);
}
