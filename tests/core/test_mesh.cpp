// Mesh measures, normalizations, boundary extraction and adjacency against
// hand-computed references.
#include "shapemap/adjacency.h"
#include "shapemap/mesh.h"
#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

using namespace shapemap;

namespace {
// Unit cube [0,1]^3 split into 6 tets around the diagonal 0-6 (all positive).
TetMesh unit_cube_tets() {
  TetMesh m;
  m.V.resize(8, 3);
  m.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  m.T.resize(6, 4);
  m.T << 0, 1, 2, 6, 0, 2, 3, 6, 0, 3, 7, 6, 0, 7, 4, 6, 0, 4, 5, 6, 0, 5, 1, 6;
  // Orient positively whatever the listing above.
  Eigen::VectorXd vol = tet_volumes(m.V, m.T);
  for (int t = 0; t < 6; ++t)
    if (vol(t) < 0) std::swap(m.T(t, 2), m.T(t, 3));
  return m;
}
TriMesh tetrahedron_surface() {
  TriMesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  m.F.resize(4, 3);
  m.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return m;
}
}  // namespace

TEST(Mesh, CubeVolumeAndBoundary) {
  TetMesh cube = unit_cube_tets();
  Eigen::VectorXd vol = tet_volumes(cube.V, cube.T);
  EXPECT_NEAR(vol.sum(), 1.0, 1e-12);
  for (int t = 0; t < 6; ++t) EXPECT_NEAR(vol(t), 1.0 / 6.0, 1e-12);
  TetBoundary b = boundary_surface(cube);
  EXPECT_EQ(b.surface.num_faces(), 12);      // 6 squares, 2 triangles each
  EXPECT_EQ(b.surface.num_vertices(), 8);
  EXPECT_NEAR(surface_area(b.surface.V, b.surface.F), 6.0, 1e-12);
  EXPECT_NEAR(enclosed_volume(b.surface.V, b.surface.F), 1.0, 1e-12);  // outward
  for (int i = 0; i < b.surface.num_vertices(); ++i) EXPECT_EQ(b.to_surface(b.to_volume(i)), i);
}

TEST(Mesh, TetrahedronSurfaceMeasures) {
  TriMesh m = tetrahedron_surface();
  EXPECT_NEAR(enclosed_volume(m.V, m.F), 1.0 / 6.0, 1e-12);
  EXPECT_NEAR(surface_area(m.V, m.F), 1.5 + std::sqrt(3.0) / 2.0, 1e-12);
  Eigen::MatrixXd N = face_normals(m.V, m.F);
  EXPECT_NEAR(N(0, 2), -1.0, 1e-12);  // bottom face points down (outward)
  Eigen::MatrixXd VN = vertex_normals(m.V, m.F);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(VN.row(i).norm(), 1.0, 1e-12);
}

TEST(Mesh, PositiveOriginCones) {
  // The outward tetrahedron surface, centred: all four cones from the centre are positive;
  // a reversed face or NaN coordinates are not.
  TriMesh m = tetrahedron_surface();
  m.V.rowwise() -= m.V.colwise().mean();
  EXPECT_EQ(positive_origin_cones(m.V, m.F), 4);
  Eigen::MatrixXi F = m.F;
  std::swap(F(1, 1), F(1, 2));
  EXPECT_EQ(positive_origin_cones(m.V, F), 3);
  const Eigen::MatrixXd Vn = Eigen::MatrixXd::Constant(4, 3, std::nan(""));
  EXPECT_EQ(positive_origin_cones(Vn, m.F), 0);
  // Brute force: the sign of the tet (origin, i, j, k) by tet_volumes, on random triangles.
  const Eigen::MatrixXd R = Eigen::MatrixXd::Random(30, 3);
  Eigen::MatrixXi G(40, 3);
  for (int f = 0; f < 40; ++f)
    for (int c = 0; c < 3; ++c) G(f, c) = (7 * f + 11 * c + f * c) % 30;
  Eigen::MatrixXd W(31, 3);
  W << R, Eigen::RowVector3d::Zero();
  Eigen::MatrixXi T(40, 4);
  T << Eigen::VectorXi::Constant(40, 30), G;
  const int ref = int((tet_volumes(W, T).array() > 0).count());
  EXPECT_GT(ref, 5);
  EXPECT_LT(ref, 35);
  EXPECT_EQ(positive_origin_cones(R, G), ref);
}

TEST(Mesh, Normalizations) {
  TriMesh m = tetrahedron_surface();
  m.V *= 3.0;
  Normalization n = unit_area_normalization(m);
  Eigen::MatrixXd W = n.apply(m.V);
  EXPECT_NEAR(surface_area(W, m.F), 1.0, 1e-12);
  EXPECT_LT((n.undo(W) - m.V).norm(), 1e-12);
  TetMesh cube = unit_cube_tets();
  cube.V *= 2.0;
  Normalization nv = unit_volume_normalization(cube);
  EXPECT_NEAR(signed_volume(nv.apply(cube.V), cube.T), 1.0, 1e-12);
  EXPECT_LT(nv.center.norm() - std::sqrt(3.0), 1e-12);  // centre (1,1,1)
}

TEST(Adjacency, EdgesAndComponents) {
  TriMesh m = tetrahedron_surface();
  Eigen::MatrixXi FE;
  Eigen::MatrixXi E = unique_edges(m.F, &FE);
  EXPECT_EQ(E.rows(), 6);
  Eigen::MatrixXi EF = edge_faces(m.F, E, FE);
  for (int e = 0; e < 6; ++e) {
    EXPECT_GE(EF(e, 0), 0);
    EXPECT_GE(EF(e, 2), 0);  // closed: two faces per edge
    // The corner opposite the edge is not one of its endpoints.
    int v = m.F(EF(e, 0), EF(e, 1));
    EXPECT_TRUE(v != E(e, 0) && v != E(e, 1));
  }
  auto nb = vertex_neighbors(m.F, 4);
  for (auto& a : nb) EXPECT_EQ(a.size(), 3u);
  // Two disjoint triangles: two components.
  Eigen::MatrixXi F2(2, 3);
  F2 << 0, 1, 2, 3, 4, 5;
  int nc = 0;
  Eigen::VectorXi c = connected_components(F2, 6, &nc);
  EXPECT_EQ(nc, 2);
  EXPECT_NE(c(0), c(3));
}

// vertex_elements_csr against vertex_elements (lists) and a scan of every element, on the
// cube's tets (6 around the diagonal 0-6) and on triangles with an unused vertex.
TEST(Adjacency, VertexElementsCsrMatchesTheLists) {
  const TetMesh cube = unit_cube_tets();
  Eigen::MatrixXi F(3, 3);
  F << 0, 1, 2, 2, 1, 3, 3, 1, 4;
  for (const auto& [E, n] : {std::pair<Eigen::MatrixXi, int>{cube.T, 8}, {F, 6}}) {
    const VertexElementsCsr c = vertex_elements_csr(E, n);
    const auto lists = vertex_elements(E, n);
    ASSERT_EQ(int(c.start.size()), n + 1);
    EXPECT_EQ(c.start[n], int(E.size()));
    for (int v = 0; v < n; ++v) {
      std::vector<int> scan;  // brute force: every element with corner v, ascending
      for (int t = 0; t < E.rows(); ++t)
        for (int j = 0; j < E.cols(); ++j)
          if (E(t, j) == v) scan.push_back(t);
      const std::vector<int> row(c.elems.begin() + c.start[v], c.elems.begin() + c.start[v + 1]);
      EXPECT_EQ(row, scan) << "vertex " << v;
      std::vector<int> list = lists[v];
      std::sort(list.begin(), list.end());
      EXPECT_EQ(row, list) << "vertex " << v;
    }
  }
  EXPECT_EQ(vertex_elements_csr(cube.T, 8).start[7] - vertex_elements_csr(cube.T, 8).start[6], 6);  // the diagonal's end
}
