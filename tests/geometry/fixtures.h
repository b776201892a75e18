// Small generated meshes for the geometry tests (tests must not read /work/shared).
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <utility>
#include <vector>

namespace shapemap::testing {

// A rotation drawn uniformly from SO(3) (a normalized Gaussian quaternion).
inline Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> N(0, 1);
  Eigen::Quaterniond q(N(rng), N(rng), N(rng), N(rng));
  return q.normalized().toRotationMatrix();
}

// Icosphere of radius r: the icosahedron subdivided `levels` times, vertices projected to
// the sphere; outward oriented. 10 * 4^levels + 2 vertices.
inline void icosphere(int levels, double r, Eigen::MatrixXd& V, Eigen::MatrixXi& F) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> P = {{-1, t, 0}, {1, t, 0},  {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t},  {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : P) p.normalize();
  std::vector<std::array<int, 3>> T = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      P.push_back((P[a] + P[b]).normalized());
      return mid[key] = int(P.size()) - 1;
    };
    std::vector<std::array<int, 3>> T2;
    for (auto& f : T) {
      int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      T2.push_back({f[0], a, c});
      T2.push_back({f[1], b, a});
      T2.push_back({f[2], c, b});
      T2.push_back({a, b, c});
    }
    T = T2;
  }
  V.resize(P.size(), 3);
  for (size_t i = 0; i < P.size(); ++i) V.row(i) = r * P[i].transpose();
  F.resize(T.size(), 3);
  for (size_t i = 0; i < T.size(); ++i) F.row(i) << T[i][0], T[i][1], T[i][2];
}

// Flat (z = 0) grid on [0,1]^2 with nx × ny cells split into triangles (alternating
// diagonals), interior vertices jittered by up to `jitter` cell sizes. Counter-clockwise.
inline void flat_grid(int nx, int ny, double jitter, unsigned seed, Eigen::MatrixXd& V,
                      Eigen::MatrixXi& F, std::vector<int>* interior = nullptr) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-jitter, jitter);
  V.resize((nx + 1) * (ny + 1), 3);
  auto id = [&](int i, int j) { return j * (nx + 1) + i; };
  if (interior) interior->clear();
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      double x = double(i) / nx, y = double(j) / ny;
      const bool inner = i > 0 && i < nx && j > 0 && j < ny;
      if (inner) {
        x += U(rng) / nx;
        y += U(rng) / ny;
        if (interior) interior->push_back(id(i, j));
      }
      V.row(id(i, j)) << x, y, 0.0;
    }
  F.resize(2 * nx * ny, 3);
  int f = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if ((i + j) % 2 == 0) {
        F.row(f++) << a, b, c;
        F.row(f++) << a, c, d;
      } else {
        F.row(f++) << a, b, d;
        F.row(f++) << b, c, d;
      }
    }
}

// Structured tet grid of [0,1]^3 with n^3 cubes, each split into 6 tets around the main
// diagonal (Kuhn/Freudenthal, conforming), positively oriented; interior vertices jittered
// by up to `jitter` cell sizes.
inline void tet_grid(int n, double jitter, unsigned seed, Eigen::MatrixXd& V, Eigen::MatrixXi& T,
                     std::vector<int>* interior = nullptr) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-jitter, jitter);
  auto id = [&](int i, int j, int k) { return (k * (n + 1) + j) * (n + 1) + i; };
  V.resize((n + 1) * (n + 1) * (n + 1), 3);
  if (interior) interior->clear();
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        Eigen::RowVector3d p(double(i) / n, double(j) / n, double(k) / n);
        if (i > 0 && i < n && j > 0 && j < n && k > 0 && k < n) {
          p += Eigen::RowVector3d(U(rng), U(rng), U(rng)) / n;
          if (interior) interior->push_back(id(i, j, k));
        }
        V.row(id(i, j, k)) = p;
      }
  // The 6 monotone paths from corner 000 to 111.
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  T.resize(6 * n * n * n, 4);
  int t = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (auto& p : perms) {
          int c[3] = {i, j, k};
          int v[4];
          v[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            v[s + 1] = id(c[0], c[1], c[2]);
          }
          Eigen::Vector3d e1 = (V.row(v[1]) - V.row(v[0])).transpose(),
                          e2 = (V.row(v[2]) - V.row(v[0])).transpose(),
                          e3 = (V.row(v[3]) - V.row(v[0])).transpose();
          if (e1.dot(e2.cross(e3)) < 0) std::swap(v[2], v[3]);
          T.row(t++) << v[0], v[1], v[2], v[3];
        }
}

// A closed tube (a thin limb) with a non-Delaunay triangulation, as real meshes have: `rings`
// rings of k vertices, radius r, spaced dz along z from z = 0, ring i turned by i * 0.3 of
// the angular step and each quad split along its LONG diagonal (the two angles opposite it
// sum to about 280 degrees: negative cotan weights on every such edge); each end closed by
// a fan to a pole vertex on the axis at distance h beyond the end ring. Outward oriented.
// Vertices: rings * k + 2 (the bottom pole is rings * k, the top one rings * k + 1). The
// geodesic distance from the bottom pole to a tube vertex at height z is
// sqrt(r^2 + h^2) + z.
inline void sheared_tube(int rings, int k, double r, double dz, double h, Eigen::MatrixXd& V,
                         Eigen::MatrixXi& F) {
  const int n = rings * k;
  V.resize(n + 2, 3);
  const double step = 2 * M_PI / k;
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < k; ++j) {
      const double a = (j + 0.3 * i) * step;
      V.row(i * k + j) << r * std::cos(a), r * std::sin(a), i * dz;
    }
  V.row(n) << 0, 0, -h;
  V.row(n + 1) << 0, 0, (rings - 1) * dz + h;
  std::vector<std::array<int, 3>> f;
  for (int i = 0; i + 1 < rings; ++i)
    for (int j = 0; j < k; ++j) {
      const int a0 = i * k + j, a1 = i * k + (j + 1) % k, b0 = (i + 1) * k + j, b1 = (i + 1) * k + (j + 1) % k;
      // Ring i+1 is turned forward, so a0-b1 is the long diagonal of quad a0 a1 b1 b0.
      f.push_back({a0, a1, b1});
      f.push_back({a0, b1, b0});
    }
  for (int j = 0; j < k; ++j) {
    f.push_back({n, (j + 1) % k, j});
    f.push_back({n + 1, (rings - 1) * k + j, (rings - 1) * k + (j + 1) % k});
  }
  F.resize(int(f.size()), 3);
  for (size_t t = 0; t < f.size(); ++t) F.row(int(t)) << f[t][0], f[t][1], f[t][2];
}

}  // namespace shapemap::testing
