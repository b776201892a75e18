// Small structured tet meshes for the ball-parameterization tests (no file I/O).
#pragma once
#include "shapemap/mesh.h"
#include <Eigen/Geometry>
#include <array>
#include <cmath>

namespace shapemap::testing_ball {

// The cube [-1,1]^3 with k cells per side, 6 Kuhn tets per cell, positively oriented.
inline TetMesh cube_tets(int k, const Eigen::Vector3d& offset = Eigen::Vector3d::Zero()) {
  TetMesh m;
  const int s = k + 1;
  m.V.resize(s * s * s, 3);
  auto id = [s](int i, int j, int l) { return (i * s + j) * s + l; };
  for (int i = 0; i < s; ++i)
    for (int j = 0; j < s; ++j)
      for (int l = 0; l < s; ++l)
        m.V.row(id(i, j, l)) = Eigen::RowVector3d(-1 + 2.0 * i / k, -1 + 2.0 * j / k, -1 + 2.0 * l / k) +
                               offset.transpose();
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  m.T.resize(6 * k * k * k, 4);
  int t = 0;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      for (int l = 0; l < k; ++l)
        for (auto& p : perms) {
          std::array<int, 3> c = {i, j, l};
          std::array<int, 4> v;
          v[0] = id(c[0], c[1], c[2]);
          for (int q = 0; q < 3; ++q) {
            ++c[p[q]];
            v[q + 1] = id(c[0], c[1], c[2]);
          }
          const Eigen::Vector3d a = m.V.row(v[0]), b = m.V.row(v[1]), cc = m.V.row(v[2]),
                                d = m.V.row(v[3]);
          if ((b - a).dot((cc - a).cross(d - a)) < 0) std::swap(v[2], v[3]);
          m.T.row(t++) << v[0], v[1], v[2], v[3];
        }
  return m;
}

// A ball-topology blob: the cube mesh squashed radially onto the ellipsoid with the
// given radii, with an optional smooth bump of relative amplitude `bump`.
inline TetMesh blob_tets(int k, const Eigen::Vector3d& radii, double bump = 0.0) {
  TetMesh m = cube_tets(k);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    const Eigen::Vector3d c = m.V.row(i);
    const double x2 = c.x() * c.x(), y2 = c.y() * c.y(), z2 = c.z() * c.z();
    Eigen::Vector3d p(c.x() * std::sqrt(1 - y2 / 2 - z2 / 2 + y2 * z2 / 3),  // smooth cube -> ball
                      c.y() * std::sqrt(1 - z2 / 2 - x2 / 2 + z2 * x2 / 3),
                      c.z() * std::sqrt(1 - x2 / 2 - y2 / 2 + x2 * y2 / 3));
    const double w = 1.0 + bump * std::sin(2.0 * p.x() + 1.0) * std::cos(1.5 * p.y() - 0.5 * p.z());
    m.V.row(i) = (p.cwiseProduct(radii) * w).transpose();
  }
  return m;
}

// Two disjoint cubes (not a ball: two components).
inline TetMesh two_cubes(int k) {
  TetMesh a = cube_tets(k), b = cube_tets(k, Eigen::Vector3d(5, 0, 0));
  TetMesh m;
  m.V.resize(a.V.rows() + b.V.rows(), 3);
  m.V << a.V, b.V;
  m.T.resize(a.T.rows() + b.T.rows(), 4);
  m.T << a.T, (b.T.array() + int(a.V.rows())).matrix();
  return m;
}

// The tets of c whose centroid satisfies keep(centroid), on the vertices they use (renumbered
// in order).
template <class Keep>
TetMesh keep_tets(const TetMesh& c, Keep keep) {
  std::vector<int> kept;
  for (Eigen::Index t = 0; t < c.T.rows(); ++t) {
    Eigen::Vector3d ctr = Eigen::Vector3d::Zero();
    for (int q = 0; q < 4; ++q) ctr += c.V.row(c.T(t, q)).transpose() / 4.0;
    if (keep(ctr)) kept.push_back(int(t));
  }
  TetMesh m;
  m.V = c.V;
  m.T.resize(kept.size(), 4);
  for (size_t i = 0; i < kept.size(); ++i) m.T.row(i) = c.T.row(kept[i]);
  // Drop the vertices no kept tet uses.
  std::vector<int> used(m.V.rows(), -1);
  int n = 0;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int q = 0; q < 4; ++q)
      if (used[m.T(t, q)] < 0) used[m.T(t, q)] = 0;
  for (auto& u : used)
    if (u == 0) u = n++;
  Eigen::MatrixXd V(n, 3);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    if (used[i] >= 0) V.row(used[i]) = m.V.row(i);
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int q = 0; q < 4; ++q) m.T(t, q) = used[m.T(t, q)];
  m.V = V;
  return m;
}

// A cube with a cavity (hollow: two boundary components). k even, >= 4.
inline TetMesh hollow_cube(int k) {
  return keep_tets(cube_tets(k), [&](const Eigen::Vector3d& c) { return c.cwiseAbs().maxCoeff() > 2.0 / k; });
}

}  // namespace shapemap::testing_ball
