// Input repairs (shapemap/repair.h) on constructed defects of a generated sphere: each repair
// gives a closed genus-0 surface, and every input vertex keeps a place on it.
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/generate.h"
#include "shapemap/maps.h"
#include "shapemap/repair.h"
#include <gtest/gtest.h>
#include <algorithm>

using namespace shapemap;

namespace {

TriMesh sphere() { return make_sphere(400); }

// The repaired surface passes the genus-0 guard, and the correspondence covers every input
// vertex: its own vertex at the same position, or a point of the surface.
void expect_repaired(const TriMesh& in, const SurfaceRepair& r) {
  EXPECT_TRUE(r.changed());
  TriMesh m = r.mesh;
  EXPECT_NO_THROW(require_genus0_surface(m, "repaired", 10));
  const MeshReport rep = check_surface(r.mesh);
  EXPECT_EQ(rep.non_manifold_edges, 0);
  EXPECT_EQ(rep.non_manifold_vertices, 0);
  EXPECT_TRUE(rep.closed);
  EXPECT_EQ(rep.components, 1);
  EXPECT_GT(enclosed_volume(r.mesh.V, r.mesh.F), 0);
  ASSERT_EQ(r.input_vertex.size(), in.V.rows());
  ASSERT_EQ(r.input_on_repaired.size(), in.V.rows());
  EXPECT_NO_THROW(validate_map(r.input_on_repaired, in.num_vertices(), r.mesh.num_faces(), 3, "input_on_repaired"));
  for (int i = 0; i < in.num_vertices(); ++i)
    if (r.input_vertex(i) >= 0) EXPECT_EQ(r.mesh.V.row(r.input_vertex(i)), in.V.row(i)) << i;
  ASSERT_EQ(r.vertex_from.size(), r.mesh.V.rows());
  for (int v = 0; v < r.mesh.num_vertices(); ++v)
    if (r.vertex_from(v) >= 0) EXPECT_EQ(r.mesh.V.row(v), in.V.row(r.vertex_from(v))) << v;
}

bool has_note(const SurfaceRepair& r, const std::string& what) {
  return std::any_of(r.notes.begin(), r.notes.end(),
                     [&](const std::string& n) { return n.find(what) != std::string::npos; });
}

// Replaces vertex `w` by `u` in every face and removes w (faces renumbered): the two points
// of the sphere are glued.
TriMesh glue(const TriMesh& s, int u, int w) {
  TriMesh m;
  m.V.resize(s.V.rows() - 1, 3);
  for (int i = 0, k = 0; i < s.V.rows(); ++i)
    if (i != w) m.V.row(k++) = s.V.row(i);
  m.F = s.F;
  for (int f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      int& x = m.F(f, c);
      if (x == w) x = u;
      if (x > w) --x;
    }
  return m;
}

// A vertex far from v (largest distance).
int far_vertex(const TriMesh& s, int v) {
  int best = 0;
  for (int i = 0; i < s.V.rows(); ++i)
    if ((s.V.row(i) - s.V.row(v)).squaredNorm() > (s.V.row(best) - s.V.row(v)).squaredNorm()) best = i;
  return best;
}

// A small closed tetrahedron near the point p, appended as a separate piece.
TriMesh with_floating_tet(const TriMesh& s, const Eigen::RowVector3d& p, double size) {
  TriMesh m;
  const int n = int(s.V.rows());
  m.V.resize(n + 4, 3);
  m.V.topRows(n) = s.V;
  m.V.row(n) = p;
  m.V.row(n + 1) = p + Eigen::RowVector3d(size, 0, 0);
  m.V.row(n + 2) = p + Eigen::RowVector3d(0, size, 0);
  m.V.row(n + 3) = p + Eigen::RowVector3d(0, 0, size);
  m.F.resize(s.F.rows() + 4, 3);
  m.F.topRows(s.F.rows()) = s.F;
  m.F.bottomRows(4) << n, n + 2, n + 1, n, n + 1, n + 3, n, n + 3, n + 2, n + 1, n + 2, n + 3;
  return m;
}

}  // namespace

TEST(Repair, CleanSurfaceIsUnchanged) {
  const TriMesh s = sphere();
  const SurfaceRepair r = repair_surface(s, "s.off");
  EXPECT_FALSE(r.changed());
  EXPECT_EQ(r.mesh.V, s.V);
  EXPECT_EQ(r.mesh.F, s.F);
  EXPECT_TRUE(repairable_defects(s).empty());
}

TEST(Repair, NonManifoldEdgeIsSplit) {
  // Two edges of the sphere, far apart, glued into one edge with four faces.
  const TriMesh s = sphere();
  const int u1 = s.F(0, 0), u2 = s.F(0, 1);
  const int w1 = far_vertex(s, u1);
  int w2 = -1;
  for (int f = 0; f < s.F.rows() && w2 < 0; ++f)
    for (int c = 0; c < 3; ++c)
      if (s.F(f, c) == w1) w2 = s.F(f, (c + 1) % 3);
  // Orient the glue so the four faces form two sheets (u1->u2 used once each way per sheet).
  TriMesh m = glue(glue(s, u1, w1), u2 > w1 ? u2 - 1 : u2, w2 > w1 ? w2 - 1 : w2);
  const MeshReport before = check_surface(m);
  ASSERT_GE(before.non_manifold_edges, 1);
  const SurfaceRepair r = repair_surface(m, "edge.off");
  expect_repaired(m, r);
  EXPECT_TRUE(has_note(r, "non-manifold edge")) << r.notes[0];
  EXPECT_EQ(r.mesh.num_faces(), m.num_faces());  // nothing removed, nothing added
  EXPECT_EQ(r.mesh.num_vertices(), m.num_vertices() + 2);  // the glued edge's ends, split
  for (int i = 0; i < m.num_vertices(); ++i) EXPECT_GE(r.input_vertex(i), 0);
}

TEST(Repair, PinchedVertexIsSplit) {
  const TriMesh s = sphere();
  const TriMesh m = glue(s, 0, far_vertex(s, 0));
  ASSERT_EQ(check_surface(m).non_manifold_vertices, 1);
  const SurfaceRepair r = repair_surface(m, "pinch.off");
  expect_repaired(m, r);
  EXPECT_TRUE(has_note(r, "1 non-manifold vertex split"));
  EXPECT_EQ(r.mesh.num_vertices(), m.num_vertices() + 1);
  // Both copies come from vertex 0; vertex 0's row is its first copy, vertex 0 itself.
  int copies = 0;
  for (int v = 0; v < r.mesh.num_vertices(); ++v) copies += r.vertex_from(v) == 0;
  EXPECT_EQ(copies, 2);
  EXPECT_EQ(r.input_vertex(0), 0);
}

TEST(Repair, FloatingPieceIsSetAsideAndMapsToTheNearestPoint) {
  const TriMesh s = sphere();
  const TriMesh m = with_floating_tet(s, Eigen::RowVector3d(1.2, 0, 0), 0.05);
  const SurfaceRepair r = repair_surface(m, "float.off");
  expect_repaired(m, r);
  EXPECT_TRUE(has_note(r, "1 smaller component set aside")) << r.notes[0];
  EXPECT_EQ(r.mesh.num_vertices(), s.num_vertices());
  const Eigen::MatrixXd P = map_positions(r.input_on_repaired, r.mesh.V, r.mesh.F);
  for (int i = s.num_vertices(); i < m.num_vertices(); ++i) {
    EXPECT_EQ(r.input_vertex(i), -1);
    // The nearest point of the sphere (radius 1, faceted) to a point at about (1.2, 0, 0).
    EXPECT_NEAR(P.row(i).norm(), 1.0, 0.02);
    EXPECT_GT(P(i, 0), 0.95);
  }
  // Two large pieces are not a repair: left for the guard.
  TriMesh two = with_floating_tet(s, Eigen::RowVector3d(3, 0, 0), 3.0);
  const SurfaceRepair r2 = repair_surface(two, "two.off");
  EXPECT_EQ(check_surface(r2.mesh).components, 2);
}

TEST(Repair, SmallHoleIsFilled) {
  // The faces around vertex 7 removed: a hole of its valence, vertex 7 left unreferenced.
  const TriMesh s = sphere();
  std::vector<int> keep;
  for (int f = 0; f < s.F.rows(); ++f)
    if (s.F(f, 0) != 7 && s.F(f, 1) != 7 && s.F(f, 2) != 7) keep.push_back(f);
  TriMesh m;
  m.V = s.V;
  m.F.resize(Eigen::Index(keep.size()), 3);
  for (size_t k = 0; k < keep.size(); ++k) m.F.row(Eigen::Index(k)) = s.F.row(keep[k]);
  ASSERT_FALSE(check_surface(m).closed);
  const SurfaceRepair r = repair_surface(m, "hole.off");
  expect_repaired(m, r);
  EXPECT_TRUE(has_note(r, "1 small hole filled"));
  EXPECT_EQ(r.input_vertex(7), -1);  // mapped through the nearest point of the filled hole
  const Eigen::MatrixXd P = map_positions(r.input_on_repaired, r.mesh.V, r.mesh.F);
  EXPECT_LT((P.row(7) - s.V.row(7)).norm(), 0.1);
  for (int f = 0; f < r.mesh.num_faces(); ++f)
    if (r.face_from(f) >= 0) {
      Eigen::RowVector3i a = r.mesh.F.row(f), b = m.F.row(r.face_from(f));
      for (int c = 0; c < 3; ++c)
        EXPECT_TRUE(r.mesh.V.row(a(c)) == m.V.row(b(0)) || r.mesh.V.row(a(c)) == m.V.row(b(1)) ||
                    r.mesh.V.row(a(c)) == m.V.row(b(2)));
    }
  // A large opening is not a small hole: left open for the guard.
  SurfaceRepairOptions o;
  o.max_hole_area = 1e-6;
  EXPECT_FALSE(check_surface(repair_surface(m, "hole.off", o).mesh).closed);
}

TEST(Repair, DuplicateVerticesAreMerged) {
  // A copy of vertex 5 at the same position, used by one of its faces: a crack, merged back.
  const TriMesh s = sphere();
  TriMesh m = s;
  const int n = int(s.V.rows());
  m.V.conservativeResize(n + 1, 3);
  m.V.row(n) = s.V.row(5);
  for (int f = 0; f < m.F.rows(); ++f) {
    bool done = false;
    for (int c = 0; c < 3; ++c)
      if (m.F(f, c) == 5) m.F(f, c) = n, done = true;
    if (done) break;
  }
  ASSERT_EQ(check_surface(m).duplicate_vertices, 1);
  const SurfaceRepair r = repair_surface(m, "dup.off");
  expect_repaired(m, r);
  EXPECT_TRUE(has_note(r, "1 duplicate vertex merged"));
  EXPECT_EQ(r.mesh.num_vertices(), n);
  EXPECT_EQ(r.input_vertex(n), r.input_vertex(5));  // merged duplicates share a row
}

TEST(Repair, DegenerateFacesAreRemoved) {
  const TriMesh s = sphere();
  TriMesh m = s;
  const Eigen::Index k = m.F.rows();
  m.F.conservativeResize(k + 2, 3);
  m.F.row(k) << 3, 3, 4;       // a repeated vertex
  m.F.row(k + 1) = s.F.row(0);  // a repeated face
  const SurfaceRepair r = repair_surface(m, "degenerate.off");
  expect_repaired(m, r);
  EXPECT_TRUE(has_note(r, "2 degenerate faces removed")) << r.notes[0];
  EXPECT_EQ(r.mesh.num_faces(), s.num_faces());
  EXPECT_EQ(r.mesh.num_vertices(), s.num_vertices());
}

TEST(Repair, StrictRefusesNamingTheDefects) {
  const TriMesh s = sphere();
  const TriMesh m = glue(s, 0, far_vertex(s, 0));
  SurfaceRepairOptions o;
  o.strict = true;
  try {
    repair_surface(m, "pinch.off", o);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "pinch.off: 1 non-manifold vertex (--strict: not repaired)");
  }
  EXPECT_NO_THROW(repair_surface(s, "clean.off", o));
}

TEST(Repair, MapsCarryBackToTheUsersNumbering) {
  // A has a duplicate vertex and a floating piece; B a hole. A map between the repaired
  // surfaces (here: each vertex of A to the closest point of B's repaired surface) comes
  // back with one row per input vertex of A, on B's input faces.
  const TriMesh s = sphere();
  TriMesh A = with_floating_tet(s, Eigen::RowVector3d(1.2, 0, 0), 0.05);
  const int n = int(A.V.rows());
  A.V.conservativeResize(n + 1, 3);
  A.V.row(n) = A.V.row(9);
  for (int f = 0; f < A.F.rows(); ++f)
    if (A.F(f, 0) == 9) {
      A.F(f, 0) = n;
      break;
    }
  TriMesh B = s;
  B.V *= 1.5;
  std::vector<int> keep;
  for (int f = 0; f < s.F.rows(); ++f)
    if (s.F(f, 0) != 11 && s.F(f, 1) != 11 && s.F(f, 2) != 11) keep.push_back(f);
  B.F.resize(Eigen::Index(keep.size()), 3);
  for (size_t k = 0; k < keep.size(); ++k) B.F.row(Eigen::Index(k)) = s.F.row(keep[k]);
  const SurfaceRepair rA = repair_surface(A, "A.off"), rB = repair_surface(B, "B.off");
  ASSERT_TRUE(rA.changed() && rB.changed());
  // The scaling map x -> 1.5 x, located on repaired B through B's own vertices.
  BarycentricMap M;
  M.elem.resize(rA.mesh.num_vertices());
  M.bary.resize(rA.mesh.num_vertices(), 3);
  for (int v = 0; v < rA.mesh.num_vertices(); ++v) {
    const int w = rA.vertex_from(v);  // A's first n vertices are s's
    const int target = repaired_vertex(rB, w < s.num_vertices() ? w : 0);  // B's vertex 11: nearest
    ASSERT_GE(target, 0);
    for (int f = 0; f < rB.mesh.num_faces(); ++f)
      for (int c = 0; c < 3; ++c)
        if (rB.mesh.F(f, c) == target) {
          M.elem(v) = f;
          M.bary.row(v) = Eigen::RowVector3d::Unit(c);
        }
  }
  const BarycentricMap U = map_to_inputs(M, rA, rB, B);
  ASSERT_EQ(U.size(), A.num_vertices());
  EXPECT_NO_THROW(validate_map(U, A.num_vertices(), B.num_faces(), 3, "U"));
  const Eigen::MatrixXd X = map_positions(U, B.V, B.F);
  for (int i = 0; i < s.num_vertices(); ++i)
    if (i != 11) EXPECT_LT((X.row(i) - 1.5 * s.V.row(i)).norm(), 1e-9) << i;
  EXPECT_LT((X.row(n) - X.row(9)).norm(), 1e-12);  // the duplicate shares vertex 9's row
  for (int i = s.num_vertices(); i < n; ++i) EXPECT_NEAR(X.row(i).norm(), 1.5, 0.05);  // the floating piece
  // And back: the user's map on the repaired surfaces.
  const BarycentricMap Rm = map_to_repaired(U, rA, rB, B);
  ASSERT_EQ(Rm.size(), rA.mesh.num_vertices());
  EXPECT_NO_THROW(validate_map(Rm, rA.mesh.num_vertices(), rB.mesh.num_faces(), 3, "Rm"));
  const Eigen::MatrixXd Y = map_positions(Rm, rB.mesh.V, rB.mesh.F);
  for (int v = 0; v < rA.mesh.num_vertices(); ++v) EXPECT_LT((Y.row(v) - X.row(rA.vertex_from(v))).norm(), 1e-9);
}
