// Validity reports and input guards on meshes with known topology.
#include "io_test_util.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include <gtest/gtest.h>

using namespace shapemap;
using namespace shapemap::testing;

namespace {

TriMesh concat(const TriMesh& a, const TriMesh& b) {
  TriMesh m;
  m.V.resize(a.V.rows() + b.V.rows(), 3);
  m.V << a.V, b.V;
  m.F.resize(a.F.rows() + b.F.rows(), 3);
  m.F << a.F, (b.F.array() + int(a.V.rows())).matrix();
  return m;
}

TetMesh remove_tets(const TetMesh& m, const std::vector<int>& drop) {
  std::vector<char> gone(m.T.rows(), 0);
  for (int t : drop) gone[t] = 1;
  TetMesh r;
  r.V = m.V;
  r.T.resize(m.T.rows() - Eigen::Index(drop.size()), 4);
  int k = 0;
  for (int t = 0; t < m.T.rows(); ++t)
    if (!gone[t]) r.T.row(k++) = m.T.row(t);
  return r;
}


}  // namespace

TEST(Checks, SphereIsValidGenus0) {
  MeshReport r = check_surface(uv_sphere());
  EXPECT_TRUE(r.ok()) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_TRUE(r.closed);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.euler_characteristic, 2);
  EXPECT_EQ(r.components, 1);
  EXPECT_EQ(r.boundary_components, 0);
}

TEST(Checks, TorusHasGenus1) {
  TriMesh t = torus();
  MeshReport r = check_surface(t);
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.euler_characteristic, 0);
  EXPECT_EQ(r.genus, 1);
  EXPECT_EQ(message_of([&] { require_genus0_surface(t, "A.obj", 10); }),
            "A.obj: genus 1 (Euler characteristic 0); a genus-0 surface is needed");
}

TEST(Checks, TwoDisjointSpheresHaveTwoComponents) {
  TriMesh m = concat(uv_sphere(), uv_sphere(5, 8, 0.5, {3, 0, 0}));
  MeshReport r = check_surface(m);
  EXPECT_EQ(r.components, 2);
  EXPECT_EQ(r.euler_characteristic, 4);
  EXPECT_EQ(r.genus, -1);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(message_of([&] { require_genus0_surface(m, "two.off", 10); }),
            "two.off: 2 connected components; one closed surface is needed");
}

TEST(Checks, FlippedFaceIsInconsistentAndGetsFixed) {
  TriMesh m = uv_sphere();
  std::swap(m.F(7, 1), m.F(7, 2));
  MeshReport r = check_surface(m);
  EXPECT_FALSE(r.consistently_oriented);
  EXPECT_EQ(r.genus, 0);  // topology unaffected
  EXPECT_FALSE(r.ok());
  require_genus0_surface(m, "s.obj", 10);
  EXPECT_TRUE(check_surface(m).consistently_oriented);
  EXPECT_GT(enclosed_volume(m.V, m.F), 0);
  EXPECT_TRUE(m.F.row(7) == uv_sphere().F.row(7));
}

TEST(Checks, InwardSurfaceIsTurnedOutward) {
  TriMesh m = uv_sphere();
  TriMesh ref = m;
  m.F.col(1).swap(m.F.col(2));
  EXPECT_LT(enclosed_volume(m.V, m.F), 0);
  EXPECT_TRUE(check_surface(m).consistently_oriented);
  require_genus0_surface(m, "s.obj", 10);
  EXPECT_TRUE(m.F == ref.F);
}

TEST(Checks, NonManifoldEdgeAndVertex) {
  TriMesh m = octahedron();
  // A fin on edge (0,2): third face on that edge.
  m.V.conservativeResize(7, 3);
  m.V.row(6) << 2, 2, 0;
  m.F.conservativeResize(9, 3);
  m.F.row(8) << 0, 2, 6;
  MeshReport r = check_surface(m);
  EXPECT_EQ(r.non_manifold_edges, 1);
  EXPECT_GE(r.non_manifold_vertices, 2);  // both ends of the fin edge
  EXPECT_EQ(r.genus, -1);
  EXPECT_FALSE(r.ok());
  // Two octahedra touching at one vertex (a bow tie): manifold edges, one bad vertex.
  TriMesh a = octahedron(), b = octahedron();
  b.V.rowwise() += Eigen::RowVector3d(2.2, 0, 0);  // b's vertex 1 (-1.1,0,0) lands on a's vertex 0
  TriMesh bow = concat(a, b);
  for (int f = 0; f < bow.F.rows(); ++f)
    for (int j = 0; j < 3; ++j)
      if (bow.F(f, j) == 6 + 1) bow.F(f, j) = 0;
  MeshReport q = check_surface(bow);
  EXPECT_EQ(q.non_manifold_edges, 0);
  EXPECT_EQ(q.non_manifold_vertices, 1);
  EXPECT_EQ(q.unreferenced_vertices, 1);
}

TEST(Checks, OpenSurfaceAndDegenerateFaces) {
  TriMesh m = uv_sphere();
  m.F.conservativeResize(m.F.rows() - 1, 3);
  MeshReport r = check_surface(m);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.boundary_edges, 3);
  EXPECT_EQ(r.boundary_components, 1);
  EXPECT_EQ(r.euler_characteristic, 1);
  TriMesh d = octahedron();
  d.F(0, 2) = d.F(0, 1);
  EXPECT_EQ(check_surface(d).degenerate_elements, 1);
  TriMesh nan = octahedron();
  nan.V(2, 1) = std::nan("");
  EXPECT_FALSE(check_surface(nan).finite);
  TriMesh bad = octahedron();
  bad.F(3, 0) = 99;
  MeshReport b = check_surface(bad);
  EXPECT_FALSE(b.indices_in_range);
  EXPECT_FALSE(b.ok());
  EXPECT_EQ(message_of([&] { require_genus0_surface(bad, "b.obj"); }), "b.obj: face indices out of range");
  TriMesh small = octahedron();
  EXPECT_EQ(message_of([&] { require_genus0_surface(small, "o.obj"); }), "o.obj: only 6 vertices (need at least 100)");
}

TEST(Checks, TetGridIsABall) {
  TetMesh g = grid_tets();
  MeshReport r = check_volume(g);
  EXPECT_TRUE(r.ok()) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_EQ(r.boundary_components, 1);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.euler_characteristic, 2);
  EXPECT_TRUE(r.closed);
  EXPECT_EQ(r.components, 1);
  EXPECT_NO_THROW(require_valid_volume(g, "g.vtk"));
  EXPECT_NO_THROW(require_ball_topology(g, "g.vtk"));
}

TEST(Checks, InvertedTetIsReported) {
  TetMesh g = grid_tets();
  std::swap(g.T(5, 0), g.T(5, 1));
  MeshReport r = check_volume(g);
  EXPECT_EQ(r.inverted_elements, 1);
  EXPECT_EQ(r.degenerate_elements, 0);
  EXPECT_FALSE(r.consistently_oriented);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.problems[0], "1 inverted tetrahedron (negative volume)");
  EXPECT_NO_THROW(require_valid_volume(g, "g.vtk", 0.01));  // 1 of 162
  EXPECT_THROW(require_valid_volume(g, "g.vtk", 0.001), InputError);
  TetMesh flat = cube_tets();
  flat.V.row(6) = flat.V.row(0);  // every tet collapses
  EXPECT_EQ(check_volume(flat).degenerate_elements, 6);
}

TEST(Checks, RepeatedTetAndExtremeScalesAreRejected) {
  TetMesh g = grid_tets();
  g.T.conservativeResize(g.T.rows() + 1, 4);
  g.T.row(g.T.rows() - 1) = g.T.row(0);  // listed twice
  EXPECT_EQ(message_of([&] { require_valid_volume(g, "g.vtk", 1.0); }), "g.vtk: 1 repeated tetrahedron");
  // Volumes that overflow or underflow a double (every other check passes).
  for (double s : {1e120, 1e-120}) {
    TetMesh h = grid_tets();
    h.V *= s;
    const std::string msg = message_of([&] { require_valid_volume(h, "h.vtk"); });
    EXPECT_EQ(msg.rfind("h.vtk: coordinates too ", 0), 0u) << msg;
  }
}

TEST(Checks, SolidTorusAndTwoBlocksAreNotBalls) {
  TetMesh g = grid_tets();
  // Remove the central column of cubes (i = j = 1): a solid torus.
  std::vector<int> drop;
  for (int k = 0; k < 3; ++k)
    for (int q = 0; q < 6; ++q) drop.push_back(((1 * 3 + 1) * 3 + k) * 6 + q);
  TetMesh ring = remove_tets(g, drop);
  MeshReport r = check_volume(ring);
  EXPECT_TRUE(r.ok()) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_EQ(r.genus, 1);
  EXPECT_EQ(r.boundary_components, 1);
  EXPECT_EQ(message_of([&] { require_ball_topology(ring, "ring.vtk"); }),
            "ring.vtk: boundary has genus 1 (Euler characteristic 0); a ball's boundary is a sphere");
  // Two separate cubes.
  TetMesh a = cube_tets(), two;
  two.V.resize(16, 3);
  two.V << a.V, (a.V.rowwise() + Eigen::RowVector3d(5, 0, 0));
  two.T.resize(12, 4);
  two.T << a.T, (a.T.array() + 8).matrix();
  MeshReport t = check_volume(two);
  EXPECT_EQ(t.components, 2);
  EXPECT_EQ(t.boundary_components, 2);
  EXPECT_THROW(require_valid_volume(two, "two.vtk"), InputError);
}

TEST(Checks, OrientOutwardPerComponent) {
  TriMesh m = concat(uv_sphere(), uv_sphere(4, 7, 0.5, {3, 0, 0}));
  for (int f = 0; f < m.F.rows(); f += 3) std::swap(m.F(f, 1), m.F(f, 2));  // scramble
  orient_outward(m);
  MeshReport r = check_surface(m);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_GT(enclosed_volume(m.V, m.F), 0);
}
