// Issue 20: the flipped-triangle count of surface maps (fold_counts, used by `evaluate surface`
// and the elastic collapse guard). The identity map must count no flipped triangle, whichever
// incident face each vertex is assigned to (the old count, one face per corner, flagged
// triangles at creases and on thin parts); a map with one triangle mirrored counts exactly it.
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/generate.h"
#include "shapemap/mesh.h"
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <vector>

using namespace shapemap;

namespace {

// The identity map of M with each vertex assigned to the incident face whose normal is the
// most opposed to the vertex's area-weighted normal (the worst choice for a one-face count).
BarycentricMap adversarial_identity(const TriMesh& M) {
  const Eigen::MatrixXd N = face_normals(M.V, M.F);
  const int n = M.num_vertices();
  Eigen::MatrixXd vn = Eigen::MatrixXd::Zero(n, 3);
  for (int f = 0; f < M.num_faces(); ++f) {
    const Eigen::RowVector3d a = M.V.row(M.F(f, 0)), b = M.V.row(M.F(f, 1)), c = M.V.row(M.F(f, 2));
    const Eigen::RowVector3d w = (b - a).cross(c - a);
    for (int j = 0; j < 3; ++j) vn.row(M.F(f, j)) += w;
  }
  BarycentricMap P;
  P.elem = Eigen::VectorXi::Constant(n, -1);
  P.bary = Eigen::MatrixXd::Zero(n, 3);
  std::vector<double> best(n, 2.0);
  for (int f = 0; f < M.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      const int v = M.F(f, j);
      const double d = N.row(f).dot(vn.row(v).normalized());
      if (d < best[v]) {
        best[v] = d;
        P.elem(v) = f;
        P.bary.row(v).setZero();
        P.bary(v, j) = 1.0;
      }
    }
  return P;
}

FoldCounts folds(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                 std::vector<unsigned char>* faces = nullptr) {
  return fold_counts(S.V, S.F, map_positions(P, T.V, T.F), face_normals(T.V, T.F), T.F, P, 1e-12, faces);
}

// The former count: flipped when the mapped normal opposes the sum of the normals of the
// one face each corner is assigned to.
int one_face_flipped(const TriMesh& M, const BarycentricMap& P) {
  const Eigen::MatrixXd N = face_normals(M.V, M.F), Y = map_positions(P, M.V, M.F);
  int c = 0;
  for (int f = 0; f < M.num_faces(); ++f) {
    const Eigen::Vector3d y0 = Y.row(M.F(f, 0)), y1 = Y.row(M.F(f, 1)), y2 = Y.row(M.F(f, 2));
    Eigen::Vector3d nt = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j) nt += N.row(P.elem(M.F(f, j))).transpose();
    if ((y1 - y0).cross(y2 - y0).dot(nt) < 0) ++c;
  }
  return c;
}

}  // namespace

TEST(FoldCounts, IdentityMapHasNoFlippedTriangles) {
  // a creature (thin legs, neck, tail) and a flat blade-like ellipsoid whose rim is a crease
  // of almost 180 degrees
  int old_total = 0;
  for (const TriMesh& M : {make_creature(3, 1500), make_ellipsoid(800, Eigen::Vector3d(1.0, 1.0, 0.01))}) {
    const BarycentricMap P = adversarial_identity(M);
    old_total += one_face_flipped(M, P);
    const FoldCounts c = folds(M, M, P);
    EXPECT_EQ(c.flipped, 0);
    EXPECT_EQ(c.degenerate, 0);
    // and through surface_distortion (unit-area copies), as `evaluate surface` reports it
    const SurfaceDistortion d = surface_distortion(M, M, P);
    EXPECT_EQ(d.flipped, 0);
    EXPECT_EQ(d.degenerate, 0);
  }
  EXPECT_GT(old_total, 0);  // the construction does defeat the one-face count
}

TEST(FoldCounts, OneMirroredTriangleIsExactlyTheFlippedOne) {
  const TriMesh M = make_sphere(600);
  BarycentricMap P = adversarial_identity(M);
  // face f = (v, a, b); g across the edge ab. Move v's image into g, just past ab: f turns
  // over, its neighbours around v keep their orientation.
  const int f = 17;
  const int v = M.F(f, 0), a = M.F(f, 1), b = M.F(f, 2);
  int g = -1, kg = -1;
  for (int t = 0; t < M.num_faces() && g < 0; ++t) {
    if (t == f) continue;
    int has = 0, other = -1;
    for (int j = 0; j < 3; ++j) {
      if (M.F(t, j) == a || M.F(t, j) == b) ++has;
      else other = j;
    }
    if (has == 2) g = t, kg = other;
  }
  ASSERT_GE(g, 0);
  P.elem(v) = g;
  P.bary.row(v).setConstant(0.45);
  P.bary(v, kg) = 0.1;
  std::vector<unsigned char> flags;
  const FoldCounts c = folds(M, M, P, &flags);
  EXPECT_EQ(c.flipped, 1);
  EXPECT_EQ(c.degenerate, 0);
  EXPECT_EQ(flags[f], 1);
  EXPECT_EQ(surface_distortion(M, M, P).flipped, 1);
}
