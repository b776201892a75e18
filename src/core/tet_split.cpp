// Splitting tet-mesh vertices where parts of the volume touch only along an edge or at a
// vertex (shapemap/repair.h): the boundary surface becomes manifold there, as the ball map
// and the boundary's surface map need.
#include "shapemap/repair.h"

#include <algorithm>
#include <array>
#include <numeric>
#include <vector>

namespace shapemap {

int split_pinched_tet_vertices(TetMesh& mesh) {
  const int n = mesh.num_vertices(), m = mesh.num_tets();
  std::vector<std::vector<int>> inc(static_cast<size_t>(n));
  for (int t = 0; t < m; ++t)
    for (int j = 0; j < 4; ++j) inc[size_t(mesh.T(t, j))].push_back(t);
  std::vector<Eigen::RowVector3d> added;
  std::vector<int> parent;
  std::vector<std::pair<std::array<int, 2>, int>> keys;  // (other two vertices of a face at v, local tet)
  for (int v = 0; v < n; ++v) {
    const std::vector<int>& ts = inc[size_t(v)];
    if (ts.size() < 2) continue;
    parent.resize(ts.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int x) {
      while (parent[size_t(x)] != x) x = parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
      return x;
    };
    keys.clear();
    for (size_t k = 0; k < ts.size(); ++k) {
      int o[3], c = 0;
      for (int j = 0; j < 4; ++j)
        if (mesh.T(ts[k], j) != v) o[c++] = mesh.T(ts[k], j);
      for (int a = 0; a < 3; ++a) {
        std::array<int, 2> e = {o[a], o[(a + 1) % 3]};
        if (e[0] > e[1]) std::swap(e[0], e[1]);
        keys.push_back({e, int(k)});
      }
    }
    std::sort(keys.begin(), keys.end());
    for (size_t k = 1; k < keys.size(); ++k)
      if (keys[k].first == keys[k - 1].first) {
        const int a = find(keys[k].second), b = find(keys[k - 1].second);
        if (a != b) parent[size_t(std::max(a, b))] = std::min(a, b);
      }
    // The group of the first tet keeps v; each other group gets a copy, in order of first tet.
    std::vector<int> copy_of_root(ts.size(), -1);
    const int keep = find(0);
    for (size_t k = 0; k < ts.size(); ++k) {
      const int r = find(int(k));
      if (r == keep) continue;
      if (copy_of_root[size_t(r)] < 0) {
        copy_of_root[size_t(r)] = n + int(added.size());
        added.push_back(mesh.V.row(v));
      }
      for (int j = 0; j < 4; ++j)
        if (mesh.T(ts[k], j) == v) mesh.T(ts[k], j) = copy_of_root[size_t(r)];
    }
  }
  if (added.empty()) return 0;
  mesh.V.conservativeResize(n + Eigen::Index(added.size()), 3);
  for (size_t k = 0; k < added.size(); ++k) mesh.V.row(n + Eigen::Index(k)) = added[k];
  return int(added.size());
}

}  // namespace shapemap
