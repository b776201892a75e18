// Boundary chords (interior edges joining two boundary vertices) and their splitting,
// against brute-force references on Kuhn-subdivided cube grids.
#include "shapemap/boundary_chords.h"
#include "shapemap/mesh.h"
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>

using namespace shapemap;

namespace {

// [0,n]^3 grid of unit cubes, each split into 6 positive tets around its main diagonal.
TetMesh kuhn_grid(int n) {
  TetMesh m;
  const int s = n + 1;
  m.V.resize(s * s * s, 3);
  auto id = [s](int i, int j, int k) { return i + s * (j + s * k); };
  for (int k = 0; k < s; ++k)
    for (int j = 0; j < s; ++j)
      for (int i = 0; i < s; ++i) m.V.row(id(i, j, k)) << i, j, k;
  static const int cyc[6][3] = {{1, 3, 7}, {1, 5, 7}, {2, 3, 7}, {2, 6, 7}, {4, 5, 7}, {4, 6, 7}};
  std::vector<std::array<int, 4>> T;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        auto corner = [&](int c) { return id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)); };
        for (const auto& p : cyc) T.push_back({corner(0), corner(p[0]), corner(p[1]), corner(p[2])});
      }
  m.T.resize(Eigen::Index(T.size()), 4);
  for (size_t t = 0; t < T.size(); ++t) m.T.row(Eigen::Index(t)) << T[t][0], T[t][1], T[t][2], T[t][3];
  const Eigen::VectorXd vol = tet_volumes(m.V, m.T);
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    if (vol(t) < 0) std::swap(m.T(t, 2), m.T(t, 3));
  return m;
}

// How many tets use each face (sorted vertex triple).
std::map<std::array<int, 3>, int> face_counts(const TetMesh& m) {
  std::map<std::array<int, 3>, int> count;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int, 3> f;
      int k = 0;
      for (int c = 0; c < 4; ++c)
        if (c != skip) f[k++] = m.T(t, c);
      std::sort(f.begin(), f.end());
      ++count[f];
    }
  return count;
}

// Brute force: faces used once are boundary; an edge is a chord when both endpoints are on
// some boundary face and no boundary face contains both.
std::set<std::array<int, 2>> chords_brute_force(const TetMesh& m) {
  const std::map<std::array<int, 3>, int> count = face_counts(m);
  std::set<int> bv;
  std::set<std::array<int, 2>> be;
  for (const auto& [f, c] : count)
    if (c == 1) {
      bv.insert(f.begin(), f.end());
      be.insert({f[0], f[1]});
      be.insert({f[1], f[2]});
      be.insert({f[0], f[2]});
    }
  std::set<std::array<int, 2>> chords;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        std::array<int, 2> e{std::min(m.T(t, i), m.T(t, j)), std::max(m.T(t, i), m.T(t, j))};
        if (bv.count(e[0]) && bv.count(e[1]) && !be.count(e)) chords.insert(e);
      }
  return chords;
}

// Boundary triangles as sorted position triples (vertex numbering independent).
std::multiset<std::vector<double>> boundary_triangles(const TetMesh& m) {
  const TetBoundary b = boundary_surface(m);
  std::multiset<std::vector<double>> out;
  for (Eigen::Index f = 0; f < b.surface.F.rows(); ++f) {
    std::vector<std::array<double, 3>> p;
    for (int c = 0; c < 3; ++c) {
      const Eigen::RowVector3d x = b.surface.V.row(b.surface.F(f, c));
      p.push_back({x(0), x(1), x(2)});
    }
    std::sort(p.begin(), p.end());
    out.insert({p[0][0], p[0][1], p[0][2], p[1][0], p[1][1], p[1][2], p[2][0], p[2][1], p[2][2]});
  }
  return out;
}

}  // namespace

TEST(BoundaryChords, SingleCubeHasItsMainDiagonal) {
  TetMesh m = kuhn_grid(1);
  const auto chords = boundary_chords(m);
  ASSERT_EQ(chords.size(), 1u);
  EXPECT_EQ(chords[0], (std::array<int, 2>{0, 7}));  // (0,0,0)-(1,1,1)
  EXPECT_EQ(boundary_only_tets(m), 6);
  EXPECT_EQ(split_boundary_chords(m), 1);
  EXPECT_EQ(m.num_vertices(), 9);
  EXPECT_EQ(m.num_tets(), 12);
  EXPECT_TRUE(m.V.row(8).isApprox(Eigen::RowVector3d(0.5, 0.5, 0.5)));
  EXPECT_EQ(boundary_only_tets(m), 0);
}

TEST(BoundaryChords, MatchesBruteForceAndSplittingKeepsBoundaryAndVolume) {
  for (int n : {2, 3}) {
    TetMesh m = kuhn_grid(n);
    const auto chords = boundary_chords(m);
    const auto ref = chords_brute_force(m);
    ASSERT_EQ(chords.size(), ref.size()) << n;
    EXPECT_TRUE(std::equal(chords.begin(), chords.end(), ref.begin())) << n;
    EXPECT_GT(chords.size(), 0u);
    const TetMesh before = m;
    EXPECT_EQ(split_boundary_chords(m), int(ref.size()));
    EXPECT_EQ(m.num_vertices(), before.num_vertices() + int(ref.size()));
    EXPECT_TRUE(m.V.topRows(before.num_vertices()).isApprox(before.V));
    const Eigen::VectorXd vol = tet_volumes(m.V, m.T);
    EXPECT_GT(vol.minCoeff(), 0) << n;
    EXPECT_NEAR(vol.sum(), double(n * n * n), 1e-9);
    EXPECT_TRUE(chords_brute_force(m).empty());
    EXPECT_TRUE(boundary_chords(m).empty());
    EXPECT_EQ(boundary_only_tets(m), 0);
    EXPECT_EQ(boundary_triangles(m), boundary_triangles(before));
    // Every face is shared by at most two tets (a conforming split).
    for (const auto& [f, c] : face_counts(m)) EXPECT_LE(c, 2);
  }
}

TEST(BoundaryChords, NoChordsNoChange) {
  TetMesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  m.T.resize(1, 4);
  m.T << 0, 1, 2, 3;
  EXPECT_TRUE(boundary_chords(m).empty());
  EXPECT_EQ(boundary_only_tets(m), 1);  // all its edges are boundary edges: nothing to split
  EXPECT_EQ(split_boundary_chords(m), 0);
  EXPECT_EQ(m.num_tets(), 1);
}
