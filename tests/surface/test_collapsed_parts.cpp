// Collapsed parts of a surface map re-extended (surface/collapsed_parts.h): a part of a known map
// collapsed to a point comes back where it was, also when the target is the source rotated and
// scaled (the rigid placement and the ARAP solve against the exact answer); maps without such a
// part, or with a collapsed part smaller than min_area, are returned as they are.
#include "shapemap/generate.h"
#include "shapemap/surface/collapsed_parts.h"
#include "surface_test_util.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

using namespace shapemap;
using shapemap::testing::identity_map;

namespace {

// The vertices of M in the top `share` of its height (y), all sent where P sends `to`.
std::vector<int> collapse_top(const TriMesh& M, double share, int to, BarycentricMap& P) {
  const double top = M.V.col(1).maxCoeff(), h = top - M.V.col(1).minCoeff();
  std::vector<int> part;
  for (int v = 0; v < M.num_vertices(); ++v)
    if (M.V(v, 1) > top - share * h) part.push_back(v);
  for (int v : part) P.elem(v) = P.elem(to), P.bary.row(v) = P.bary.row(to);
  return part;
}

// The vertex just below the top `share` of M's height nearest the vertical axis of the part.
int below_top(const TriMesh& M, double share) {
  const double top = M.V.col(1).maxCoeff(), h = top - M.V.col(1).minCoeff();
  int best = -1;
  double bd = 1e300;
  for (int v = 0; v < M.num_vertices(); ++v) {
    const double d = std::abs(M.V(v, 1) - (top - 1.1 * share * h));
    if (d < bd) bd = d, best = v;
  }
  return best;
}

double largest_error(const BarycentricMap& P, const TriMesh& B, const Eigen::MatrixXd& truth) {
  return (map_positions(P, B.V, B.F) - truth).rowwise().norm().maxCoeff();
}

}  // namespace

TEST(CollapsedParts, CollapsedPartComesBackOnTheSameSurface) {
  const TriMesh A = make_creature(3, 2500);
  BarycentricMap P = identity_map(A);
  const std::vector<int> part = collapse_top(A, 0.15, below_top(A, 0.15), P);
  ASSERT_GT(part.size(), 50u);
  const double diag = bbox_diagonal(A.V);
  ASSERT_GT(largest_error(P, A, A.V), 0.05 * diag);  // the collapse moved the part
  CollapsedPartResult r;
  const BarycentricMap Q = reextend_collapsed_parts(A, A, P, {}, &r);
  EXPECT_EQ(r.regions, 1);
  EXPECT_GE(r.vertices, int(part.size()));
  EXPECT_LT(largest_error(Q, A, A.V), 1e-6 * diag);
}

TEST(CollapsedParts, CollapsedPartComesBackOnARotatedScaledCopy) {
  const TriMesh A = make_creature(5, 2500);
  TriMesh B = A;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const double s = 1.7;
  B.V = (s * A.V * R.transpose()).rowwise() + Eigen::RowVector3d(0.3, -1, 2);
  BarycentricMap P = identity_map(A);  // A's vertex v onto B's vertex v: the true map
  collapse_top(A, 0.12, below_top(A, 0.12), P);
  const double diag = bbox_diagonal(B.V);
  ASSERT_GT(largest_error(P, B, B.V), 0.05 * diag);
  CollapsedPartResult r;
  const BarycentricMap Q = reextend_collapsed_parts(A, B, P, {}, &r);
  EXPECT_EQ(r.regions, 1);
  EXPECT_LT(largest_error(Q, B, B.V), 1e-6 * diag);
}

TEST(CollapsedParts, MapsWithoutLargeCollapsedPartsAreKept) {
  const TriMesh A = make_creature(3, 2500);
  const BarycentricMap I = identity_map(A);
  CollapsedPartResult r;
  BarycentricMap Q = reextend_collapsed_parts(A, A, I, {}, &r);
  EXPECT_EQ(r.regions, 0);
  EXPECT_EQ(r.degenerate_faces, 0);
  EXPECT_TRUE((Q.elem.array() == I.elem.array()).all());
  EXPECT_EQ((Q.bary - I.bary).norm(), 0.0);
  // A collapsed part under min_area is left collapsed.
  BarycentricMap P = I;
  collapse_top(A, 0.15, below_top(A, 0.15), P);
  CollapsedPartOptions o;
  o.min_area = 0.5;
  Q = reextend_collapsed_parts(A, A, P, o, &r);
  EXPECT_EQ(r.regions, 0);
  EXPECT_GT(r.degenerate_faces, 0);
  EXPECT_EQ((Q.bary - P.bary).norm(), 0.0);
}
