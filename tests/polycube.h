// Test shapes made of unit cubes (polycubes), for surfaces that touch themselves.
#pragma once
#include "shapemap/mesh.h"
#include <algorithm>
#include <array>
#include <map>
#include <vector>

namespace shapemap::testing {

// Boundary of a union of unit cubes, each cube face split into k x k squares of two
// triangles, outward oriented; vertices shared by position.
inline TriMesh polycube_surface(const std::vector<std::array<int, 3>>& cells, int k) {
  std::map<std::array<int, 3>, int> id;
  std::vector<std::array<int, 3>> pos;
  std::vector<std::array<int, 3>> tris;
  auto vid = [&](const std::array<int, 3>& p) {
    auto it = id.find(p);
    if (it != id.end()) return it->second;
    id[p] = int(pos.size());
    pos.push_back(p);
    return int(pos.size()) - 1;
  };
  auto has = [&](std::array<int, 3> c) { return std::find(cells.begin(), cells.end(), c) != cells.end(); };
  for (const auto& c : cells)
    for (int ax = 0; ax < 3; ++ax)
      for (int s = 0; s < 2; ++s) {
        std::array<int, 3> n = c;
        n[ax] += s ? 1 : -1;
        if (has(n)) continue;  // an inner face
        const int a = (ax + 1) % 3, b = (ax + 2) % 3;  // (a, b, ax) right-handed
        for (int i = 0; i < k; ++i)
          for (int j = 0; j < k; ++j) {
            auto P = [&](int u, int v) {
              std::array<int, 3> p{};
              p[ax] = (c[ax] + s) * k;
              p[a] = c[a] * k + u;
              p[b] = c[b] * k + v;
              return vid(p);
            };
            std::array<int, 4> q{P(i, j), P(i + 1, j), P(i + 1, j + 1), P(i, j + 1)};
            if (!s) std::swap(q[1], q[3]);  // normal along -ax
            tris.push_back({q[0], q[1], q[2]});
            tris.push_back({q[0], q[2], q[3]});
          }
      }
  TriMesh m;
  m.V.resize(pos.size(), 3);
  for (size_t i = 0; i < pos.size(); ++i)
    for (int d = 0; d < 3; ++d) m.V(i, d) = double(pos[i][d]) / k;
  m.F.resize(tris.size(), 3);
  for (size_t f = 0; f < tris.size(); ++f)
    for (int d = 0; d < 3; ++d) m.F(f, d) = tris[f][d];
  return m;
}

// Two cubes that touch only along an edge, joined through a layer of three cubes above them.
inline TriMesh touching_polycube(int k = 4) {
  return polycube_surface({{0, 0, 0}, {1, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}}, k);
}

}  // namespace shapemap::testing
