// Small tet meshes for the symmetric-volume-map tests (no CGAL, deterministic).
#pragma once
#include "shapemap/mesh.h"
#include <Eigen/Core>

namespace shapemap::test_volume {

// A box [0,sx]×[0,sy]×[0,sz] cut into nx×ny×nz cubes of 6 positively oriented tets each.
inline TetMesh grid_box(int nx, int ny, int nz, double sx, double sy, double sz) {
  TetMesh m;
  auto id = [&](int i, int j, int k) { return (k * (ny + 1) + j) * (nx + 1) + i; };
  m.V.resize((nx + 1) * (ny + 1) * (nz + 1), 3);
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i)
        m.V.row(id(i, j, k)) << sx * i / nx, sy * j / ny, sz * k / nz;
  m.T.resize(6 * nx * ny * nz, 4);
  int t = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        int c[8] = {id(i, j, k),         id(i + 1, j, k),         id(i + 1, j + 1, k),
                    id(i, j + 1, k),     id(i, j, k + 1),         id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)};
        int tets[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                          {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
        for (auto& q : tets) {
          m.T.row(t) << c[q[0]], c[q[1]], c[q[2]], c[q[3]];
          ++t;
        }
      }
  Eigen::VectorXd vol = tet_volumes(m.V, m.T);
  for (int k = 0; k < m.T.rows(); ++k)
    if (vol(k) < 0) std::swap(m.T(k, 2), m.T(k, 3));
  return m;
}

}  // namespace shapemap::test_volume
