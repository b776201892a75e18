#include "shapemap/boundary_chords.h"
#include "shapemap/adjacency.h"

#include <algorithm>
#include <cstdint>
#include <unordered_set>

namespace shapemap {

namespace {

std::uint64_t edge_key(int a, int b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b);
}

// Boundary vertex flags and the set of boundary edges (volume numbering).
void boundary_facts(const TetMesh& mesh, std::vector<char>& on_boundary,
                    std::unordered_set<std::uint64_t>& boundary_edges) {
  const TetBoundary b = boundary_surface(mesh);
  on_boundary.assign(mesh.num_vertices(), 0);
  for (Eigen::Index i = 0; i < b.to_volume.size(); ++i) on_boundary[b.to_volume(i)] = 1;
  const Eigen::MatrixXi& F = b.surface.F;
  boundary_edges.reserve(3 * F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      boundary_edges.insert(edge_key(b.to_volume(F(f, c)), b.to_volume(F(f, (c + 1) % 3))));
}

}  // namespace

std::vector<std::array<int, 2>> boundary_chords(const TetMesh& mesh) {
  std::vector<char> on_boundary;
  std::unordered_set<std::uint64_t> boundary_edges;
  boundary_facts(mesh, on_boundary, boundary_edges);
  std::vector<std::array<int, 2>> chords;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        int a = mesh.T(t, i), b = mesh.T(t, j);
        if (!on_boundary[a] || !on_boundary[b] || boundary_edges.count(edge_key(a, b))) continue;
        chords.push_back({std::min(a, b), std::max(a, b)});
      }
  std::sort(chords.begin(), chords.end());
  chords.erase(std::unique(chords.begin(), chords.end()), chords.end());
  return chords;
}

int boundary_only_tets(const TetMesh& mesh) {
  std::vector<char> on_boundary;
  std::unordered_set<std::uint64_t> boundary_edges;
  boundary_facts(mesh, on_boundary, boundary_edges);
  int k = 0;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    k += on_boundary[mesh.T(t, 0)] && on_boundary[mesh.T(t, 1)] && on_boundary[mesh.T(t, 2)] &&
         on_boundary[mesh.T(t, 3)];
  return k;
}

int split_boundary_chords(TetMesh& mesh) {
  const std::vector<std::array<int, 2>> chords = boundary_chords(mesh);
  if (chords.empty()) return 0;
  require_element_indices(mesh.T, mesh.V.rows(), 4, "split_boundary_chords");
  std::vector<std::array<int, 4>> T(mesh.T.rows());
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    for (int c = 0; c < 4; ++c) T[t][c] = mesh.T(t, c);
  std::vector<std::vector<int>> vt = vertex_elements(mesh.T, mesh.num_vertices());
  std::vector<Eigen::RowVector3d> added;
  const int n0 = mesh.num_vertices();
  for (const auto& [a, b] : chords) {
    // Tets around the chord now (earlier splits may have halved some of them).
    std::vector<int> around;
    for (int t : vt[a])
      if (std::find(T[t].begin(), T[t].end(), b) != T[t].end()) around.push_back(t);
    const int m = n0 + int(added.size());
    const Eigen::RowVector3d pa = a < n0 ? Eigen::RowVector3d(mesh.V.row(a)) : added[a - n0];
    const Eigen::RowVector3d pb = b < n0 ? Eigen::RowVector3d(mesh.V.row(b)) : added[b - n0];
    added.push_back(0.5 * (pa + pb));
    vt.emplace_back();
    for (int t : around) {
      std::array<int, 4> keep_a = T[t], keep_b = T[t];
      for (int c = 0; c < 4; ++c) {
        if (keep_a[c] == b) keep_a[c] = m;
        if (keep_b[c] == a) keep_b[c] = m;
      }
      const int t2 = int(T.size());
      T[t] = keep_a;
      T.push_back(keep_b);
      auto& vb = vt[b];
      vb.erase(std::find(vb.begin(), vb.end(), t));
      for (int v : keep_b) vt[v].push_back(t2);  // b, m and the two others
      vt[m].push_back(t);
    }
  }
  mesh.V.conservativeResize(n0 + Eigen::Index(added.size()), 3);
  for (size_t i = 0; i < added.size(); ++i) mesh.V.row(n0 + Eigen::Index(i)) = added[i];
  mesh.T.resize(Eigen::Index(T.size()), 4);
  for (size_t t = 0; t < T.size(); ++t)
    for (int c = 0; c < 4; ++c) mesh.T(Eigen::Index(t), c) = T[t][c];
  return int(chords.size());
}

}  // namespace shapemap
