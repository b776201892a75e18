// ClosestPointBVH / closest_point_on_simplex / TetLocator against brute-force references:
//  - the simplex routine against an independent active-set enumeration (least squares on
//    the affine hull of every vertex subset, keep the feasible ones);
//  - the BVH against a loop over all elements, for triangles in R^3 and R^6 and tets in
//    R^6 (embedding [X, s*Y] of a tet mesh), before and after refit().
#include "shapemap/geometry/closest_point.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <map>
#include <random>

using namespace shapemap;

namespace {

// Icosphere: icosahedron subdivided `levels` times, projected to the unit sphere.
void icosphere(int levels, Eigen::MatrixXd& V, Eigen::MatrixXi& F) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> P = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Eigen::Vector3i> T = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : P) p.normalize();
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      P.push_back((P[a] + P[b]).normalized());
      mid[key] = int(P.size()) - 1;
      return int(P.size()) - 1;
    };
    std::vector<Eigen::Vector3i> T2;
    for (const auto& f : T) {
      int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      T2.push_back({f[0], a, c});
      T2.push_back({f[1], b, a});
      T2.push_back({f[2], c, b});
      T2.push_back({a, b, c});
    }
    T = T2;
  }
  V.resize(P.size(), 3);
  for (size_t i = 0; i < P.size(); ++i) V.row(i) = P[i].transpose();
  F.resize(T.size(), 3);
  for (size_t i = 0; i < T.size(); ++i) F.row(i) = T[i].transpose();
}

// Structured tet grid of [0,1]^3 with n cubes per side, 6 tets per cube (around the
// main diagonal; conforming across cubes).
void tet_grid(int n, Eigen::MatrixXd& V, Eigen::MatrixXi& T) {
  auto id = [n](int i, int j, int k) { return i + (n + 1) * (j + (n + 1) * k); };
  V.resize((n + 1) * (n + 1) * (n + 1), 3);
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) V.row(id(i, j, k)) << double(i) / n, double(j) / n, double(k) / n;
  T.resize(6 * n * n * n, 4);
  int t = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        int c[8] = {id(i, j, k),         id(i + 1, j, k),     id(i + 1, j + 1, k),
                    id(i, j + 1, k),     id(i, j, k + 1),     id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)};
        const int tets[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
        for (const auto& q : tets) T.row(t++) << c[q[0]], c[q[1]], c[q[2]], c[q[3]];
      }
}

// A smooth deformation of R^3 (for the second half of the R^6 embeddings).
Eigen::MatrixXd deform(const Eigen::MatrixXd& X) {
  Eigen::MatrixXd Y(X.rows(), 3);
  for (int i = 0; i < X.rows(); ++i) {
    const double x = X(i, 0), y = X(i, 1), z = X(i, 2);
    Y.row(i) << x + 0.3 * std::sin(2 * y), 1.2 * y + 0.2 * z * z, z + 0.25 * std::cos(3 * x);
  }
  return Y;
}

Eigen::MatrixXd embed6(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, double s) {
  Eigen::MatrixXd V(X.rows(), 6);
  V << X, s * Y;
  return V;
}

// Independent reference: enumerate the non-empty vertex subsets, least squares on the
// affine hull of each (complete orthogonal decomposition, so degenerate subsets work),
// keep the feasible ones, take the closest.
template <int D>
double reference_sqdist(const Eigen::Matrix<double, D, 1>& p,
                        const std::vector<Eigen::Matrix<double, D, 1>>& v) {
  const int n = int(v.size());
  double best = std::numeric_limits<double>::infinity();
  for (int mask = 1; mask < (1 << n); ++mask) {
    std::vector<int> idx;
    for (int j = 0; j < n; ++j)
      if (mask & (1 << j)) idx.push_back(j);
    const int k = int(idx.size());
    Eigen::VectorXd w(k);
    if (k == 1) {
      w(0) = 1;
    } else {
      Eigen::MatrixXd A(D, k - 1);
      for (int j = 1; j < k; ++j) A.col(j - 1) = v[idx[j]] - v[idx[0]];
      Eigen::VectorXd x = A.completeOrthogonalDecomposition().solve(p - v[idx[0]]);
      w(0) = 1 - x.sum();
      w.tail(k - 1) = x;
    }
    if (w.minCoeff() < -1e-12) continue;
    Eigen::Matrix<double, D, 1> q = Eigen::Matrix<double, D, 1>::Zero();
    for (int j = 0; j < k; ++j) q += w(j) * v[idx[j]];
    best = std::min(best, (p - q).squaredNorm());
  }
  return best;
}

// Checks a result's barycentric coordinates and that they reproduce sqdist.
template <int D>
void check_result(const Eigen::Matrix<double, D, 1>& p, const ClosestPointResult& r,
                  const Eigen::MatrixXd& V, const Eigen::MatrixXi& E) {
  ASSERT_GE(r.elem, 0);
  const int a = int(E.cols());
  double sum = 0;
  Eigen::Matrix<double, D, 1> q = Eigen::Matrix<double, D, 1>::Zero();
  for (int j = 0; j < a; ++j) {
    EXPECT_GE(r.bary(j), 0.0);
    sum += r.bary(j);
    q += r.bary(j) * V.row(E(r.elem, j)).transpose();
  }
  for (int j = a; j < 4; ++j) EXPECT_EQ(r.bary(j), 0.0);
  EXPECT_NEAR(sum, 1.0, 1e-12);
  EXPECT_NEAR((p - q).squaredNorm(), r.sqdist, 1e-10 * (1 + r.sqdist));
}

template <int D>
ClosestPointResult brute_force(const Eigen::Matrix<double, D, 1>& p, const Eigen::MatrixXd& V,
                               const Eigen::MatrixXi& E) {
  ClosestPointResult best;
  best.sqdist = std::numeric_limits<double>::infinity();
  Eigen::Matrix<double, D, 1> verts[4];
  for (int e = 0; e < E.rows(); ++e) {
    for (int j = 0; j < E.cols(); ++j) verts[j] = V.row(E(e, j)).transpose();
    ClosestPointResult r = closest_point_on_simplex<D>(p, verts, int(E.cols()));
    if (r.sqdist < best.sqdist) {
      best = r;
      best.elem = e;
    }
  }
  return best;
}

// BVH (single and batched queries) against brute force over all elements.
template <int D>
void compare_with_brute_force(const ClosestPointBVH<D>& bvh, const Eigen::MatrixXd& V,
                              const Eigen::MatrixXi& E, const Eigen::MatrixXd& P) {
  std::vector<ClosestPointResult> batch = bvh.query(P);
  ASSERT_EQ(int(batch.size()), int(P.rows()));
  for (int i = 0; i < P.rows(); ++i) {
    const Eigen::Matrix<double, D, 1> p = P.row(i).transpose();
    ClosestPointResult ref = brute_force<D>(p, V, E);
    ClosestPointResult r = bvh.query(p);
    EXPECT_NEAR(r.sqdist, ref.sqdist, 1e-12 * (1 + ref.sqdist)) << "point " << i;
    EXPECT_EQ(batch[i].elem, r.elem);
    EXPECT_EQ(batch[i].sqdist, r.sqdist);
    check_result<D>(p, r, V, E);
  }
}

// Query points near the mesh: random points on random elements plus Gaussian noise.
Eigen::MatrixXd points_near(const Eigen::MatrixXd& V, const Eigen::MatrixXi& E, int k,
                            double sigma, std::mt19937& rng) {
  std::uniform_int_distribution<int> pick(0, int(E.rows()) - 1);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, sigma);
  Eigen::MatrixXd P(k, V.cols());
  for (int i = 0; i < k; ++i) {
    const int e = pick(rng);
    Eigen::VectorXd w(E.cols());
    for (int j = 0; j < E.cols(); ++j) w(j) = -std::log(u(rng) + 1e-300);
    w /= w.sum();
    Eigen::RowVectorXd q = Eigen::RowVectorXd::Zero(V.cols());
    for (int j = 0; j < E.cols(); ++j) q += w(j) * V.row(E(e, j));
    for (int d = 0; d < V.cols(); ++d) q(d) += g(rng);
    P.row(i) = q;
  }
  return P;
}

}  // namespace

TEST(ClosestPoint, TriangleRegionsR3) {
  using P3 = Eigen::Vector3d;
  const P3 v[3] = {P3(0, 0, 0), P3(1, 0, 0), P3(0, 1, 0)};
  // Above the interior.
  ClosestPointResult r = closest_point_on_simplex<3>(P3(0.25, 0.25, 2), v, 3);
  EXPECT_NEAR(r.sqdist, 4.0, 1e-14);
  EXPECT_NEAR(r.bary(0), 0.5, 1e-14);
  EXPECT_NEAR(r.bary(1), 0.25, 1e-14);
  EXPECT_NEAR(r.bary(2), 0.25, 1e-14);
  // Beyond vertex 1.
  r = closest_point_on_simplex<3>(P3(2, -1, 1), v, 3);
  EXPECT_NEAR(r.sqdist, 3.0, 1e-14);
  EXPECT_NEAR(r.bary(1), 1.0, 1e-14);
  // Beyond the hypotenuse.
  r = closest_point_on_simplex<3>(P3(1, 1, 0), v, 3);
  EXPECT_NEAR(r.sqdist, 0.5, 1e-14);
  EXPECT_NEAR(r.bary(1), 0.5, 1e-14);
  EXPECT_NEAR(r.bary(2), 0.5, 1e-14);
  // In the plane, inside: distance 0.
  r = closest_point_on_simplex<3>(P3(0.1, 0.2, 0), v, 3);
  EXPECT_NEAR(r.sqdist, 0.0, 1e-15);
}

TEST(ClosestPoint, SimplexAgainstActiveSetReference) {
  std::mt19937 rng(1);
  std::normal_distribution<double> g(0, 1);
  using P6 = Eigen::Matrix<double, 6, 1>;
  auto rnd6 = [&] { P6 x; for (int d = 0; d < 6; ++d) x(d) = g(rng); return x; };
  for (int nv = 3; nv <= 4; ++nv) {
    for (int trial = 0; trial < 2000; ++trial) {
      std::vector<P6> v(nv);
      for (auto& x : v) x = rnd6();
      // Some degenerate simplices: collinear / coplanar / coincident vertices.
      const int kind = trial % 5;
      if (kind == 1) v[2] = v[0] + 0.3 * (v[1] - v[0]);                  // collinear
      if (kind == 2) v[1] = v[0];                                          // repeated vertex
      if (kind == 3) for (auto& x : v) x = v[0];                           // a point
      if (kind == 4 && nv == 4) v[3] = 0.2 * v[0] + 0.5 * v[1] + 0.3 * v[2];  // flat tet
      const P6 p = (trial % 2) ? rnd6() : P6(0.5 * (v[0] + v[1]) + 0.01 * rnd6());
      ClosestPointResult r = closest_point_on_simplex<6>(p, v.data(), nv);
      const double ref = reference_sqdist<6>(p, v);
      EXPECT_NEAR(r.sqdist, ref, 1e-10 * (1 + ref)) << "nv " << nv << " trial " << trial;
      double sum = 0;
      P6 q = P6::Zero();
      for (int j = 0; j < nv; ++j) {
        EXPECT_GE(r.bary(j), 0.0);
        sum += r.bary(j);
        q += r.bary(j) * v[j];
      }
      EXPECT_NEAR(sum, 1.0, 1e-12);
      EXPECT_NEAR((p - q).squaredNorm(), r.sqdist, 1e-10 * (1 + ref));
    }
  }
}

TEST(ClosestPoint, TetInteriorR3) {
  using P3 = Eigen::Vector3d;
  const P3 v[4] = {P3(0, 0, 0), P3(1, 0, 0), P3(0, 1, 0), P3(0, 0, 1)};
  ClosestPointResult r = closest_point_on_simplex<3>(P3(0.1, 0.2, 0.3), v, 4);
  EXPECT_EQ(r.sqdist, 0.0);
  EXPECT_NEAR(r.bary(0), 0.4, 1e-14);
  EXPECT_NEAR(r.bary(3), 0.3, 1e-14);
  r = closest_point_on_simplex<3>(P3(1, 1, 1), v, 4);  // beyond the slanted face
  EXPECT_NEAR(r.sqdist, 4.0 / 3.0, 1e-14);
}

TEST(ClosestPointBVH, TrianglesR3) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  icosphere(3, V, F);  // 642 vertices, 1280 faces
  V.col(0) *= 1.5;     // an ellipsoid
  ClosestPoint3 bvh(V, F);
  EXPECT_EQ(bvh.arity(), 3);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-2, 2);
  Eigen::MatrixXd P(300, 3);
  for (int i = 0; i < 200; ++i) P.row(i) << u(rng), u(rng), u(rng);  // anywhere
  P.bottomRows(100) = points_near(V, F, 100, 0.02, rng);             // near the surface
  compare_with_brute_force<3>(bvh, V, F, P);
  // A vertex is its own closest point.
  ClosestPointResult r = bvh.query(Eigen::Vector3d(V.row(7).transpose()));
  EXPECT_NEAR(r.sqdist, 0.0, 1e-24);
}

TEST(ClosestPointBVH, TrianglesR6AndRefit) {
  Eigen::MatrixXd X, V;
  Eigen::MatrixXi F;
  icosphere(3, X, F);
  V = embed6(X, deform(X), 0.7);
  ClosestPoint6 bvh(V, F);
  std::mt19937 rng(3);
  Eigen::MatrixXd P = points_near(V, F, 200, 0.1, rng);
  compare_with_brute_force<6>(bvh, V, F, P);
  // Move the vertices (the second half changes as in the P/Q steps) and refit.
  Eigen::MatrixXd V2 = embed6(X, deform(1.3 * X) + 0.05 * Eigen::MatrixXd::Random(X.rows(), 3), 1.1);
  bvh.refit(V2);
  Eigen::MatrixXd P2 = points_near(V2, F, 200, 0.1, rng);
  compare_with_brute_force<6>(bvh, V2, F, P2);
  compare_with_brute_force<6>(bvh, V2, F, P);  // old queries, far from the new mesh
  EXPECT_THROW(bvh.refit(V2.topRows(10)), std::runtime_error);
}

TEST(ClosestPointBVH, TetsR6AndRefit) {
  Eigen::MatrixXd X, V;
  Eigen::MatrixXi T;
  tet_grid(4, X, T);  // 384 tets
  V = embed6(X, deform(X), 0.5);
  ClosestPoint6 bvh(V, T);
  EXPECT_EQ(bvh.arity(), 4);
  std::mt19937 rng(4);
  Eigen::MatrixXd P = points_near(V, T, 200, 0.15, rng);
  compare_with_brute_force<6>(bvh, V, T, P);
  Eigen::MatrixXd V2 = embed6(X, deform(X.array().square().matrix()), 2.0);
  bvh.refit(V2);
  compare_with_brute_force<6>(bvh, V2, T, points_near(V2, T, 200, 0.15, rng));
  // A point of the (embedded) mesh is at distance 0 from it.
  const Eigen::Matrix<double, 6, 1> q = (0.25 * (V2.row(T(5, 0)) + V2.row(T(5, 1)) +
                                                  V2.row(T(5, 2)) + V2.row(T(5, 3))))
                                            .transpose();
  EXPECT_NEAR(bvh.query(q).sqdist, 0.0, 1e-20);
}

TEST(ClosestPointBVH, HintsAndPreallocatedBatch) {
  Eigen::MatrixXd X, V;
  Eigen::MatrixXi F;
  icosphere(3, X, F);
  V = embed6(X, deform(X), 1.0);
  ClosestPoint6 bvh(V, F);
  std::mt19937 rng(5);
  Eigen::MatrixXd P = points_near(V, F, 300, 0.05, rng);
  std::vector<ClosestPointResult> out;
  bvh.query(P, out);
  std::vector<ClosestPointResult> hinted = out;
  for (size_t i = 0; i < hinted.size(); i += 2) hinted[i].elem = int(i % F.rows());  // bad hints
  bvh.query(P, hinted, /*use_hints=*/true);
  for (int i = 0; i < P.rows(); ++i) {
    EXPECT_EQ(hinted[i].sqdist, out[i].sqdist);
    const Eigen::Matrix<double, 6, 1> p = P.row(i).transpose();
    EXPECT_EQ(bvh.query(p, out[i].elem).sqdist, out[i].sqdist);
  }
  // Skipped rows are left as they were; the others get the answers of the full batch.
  std::vector<char> skip(P.rows(), 0);
  for (size_t i = 0; i < skip.size(); i += 3) skip[i] = 1;
  std::vector<ClosestPointResult> part(P.rows());
  for (auto& r : part) r.elem = -7;
  bvh.query(P, part, false, &skip);
  for (int i = 0; i < P.rows(); ++i) {
    if (skip[i]) {
      EXPECT_EQ(part[i].elem, -7);
    } else {
      EXPECT_EQ(part[i].elem, out[i].elem);
      EXPECT_EQ(part[i].sqdist, out[i].sqdist);
    }
  }
  skip.pop_back();
  EXPECT_THROW(bvh.query(P, part, false, &skip), std::exception);
}

TEST(ClosestPointBVH, TrianglesR2) {
  // A planar triangulation (the flattened icosphere's upper half) and points around it.
  Eigen::MatrixXd X;
  Eigen::MatrixXi F;
  icosphere(2, X, F);
  Eigen::MatrixXd V = X.leftCols(2);
  ClosestPointBVH<2> bvh(V, F);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  Eigen::MatrixXd P(200, 2);
  for (int i = 0; i < 200; ++i) P.row(i) << u(rng), u(rng);
  compare_with_brute_force<2>(bvh, V, F, P);
}

TEST(ClosestPointBVH, SmallAndEmpty) {
  Eigen::MatrixXd V(3, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  Eigen::MatrixXi F(1, 3);
  F << 0, 1, 2;
  ClosestPoint3 bvh(V, F);
  ClosestPointResult r = bvh.query(Eigen::Vector3d(0.2, 0.2, 1));
  EXPECT_EQ(r.elem, 0);
  EXPECT_NEAR(r.sqdist, 1.0, 1e-14);
  ClosestPoint3 empty(V, Eigen::MatrixXi(0, 3));
  EXPECT_EQ(empty.query(Eigen::Vector3d(0, 0, 0)).elem, -1);
  Eigen::MatrixXi bad(1, 3);
  bad << 0, 1, 3;
  EXPECT_THROW(ClosestPoint3(V, bad), std::runtime_error);
  EXPECT_THROW(ClosestPoint6(V, F), std::runtime_error);  // wrong dimension
}

TEST(TetLocator, InsideAndOutside) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  tet_grid(5, V, T);
  V = deform(V);  // curved, still a valid tet mesh
  TetLocator loc(V, T);
  std::mt19937 rng(6);
  std::uniform_int_distribution<int> pick(0, int(T.rows()) - 1);
  std::uniform_real_distribution<double> u(0.01, 1);
  Eigen::MatrixXd P(300, 3);
  for (int i = 0; i < 300; ++i) {
    const int t = pick(rng);
    Eigen::Vector4d w(u(rng), u(rng), u(rng), u(rng));
    w /= w.sum();
    P.row(i) = w(0) * V.row(T(t, 0)) + w(1) * V.row(T(t, 1)) + w(2) * V.row(T(t, 2)) +
               w(3) * V.row(T(t, 3));
  }
  std::vector<ClosestPointResult> res = loc.locate(P);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p = P.row(i).transpose();
    EXPECT_EQ(res[i].sqdist, 0.0) << i;
    check_result<3>(p, res[i], V, T);
    Eigen::Vector3d q = Eigen::Vector3d::Zero();
    for (int j = 0; j < 4; ++j) q += res[i].bary(j) * V.row(T(res[i].elem, j)).transpose();
    EXPECT_NEAR((q - p).norm(), 0.0, 1e-12);
  }
  // Outside the mesh: the closest tet, as brute force.
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p(2.5 * u(rng) - 0.7, 2.5 * u(rng) - 0.7, 2.5 * u(rng) + 1.3);
    ClosestPointResult r = loc.locate(p);
    ClosestPointResult ref = brute_force<3>(p, V, T);
    EXPECT_NEAR(r.sqdist, ref.sqdist, 1e-12 * (1 + ref.sqdist));
    EXPECT_GT(r.sqdist, 0.0);
    // Warm-started from any tet (near, far, none): the same distance as brute force.
    for (int hint : {r.elem, pick(rng), -1}) {
      const ClosestPointResult h = loc.locate(p, hint);
      EXPECT_NEAR(h.sqdist, ref.sqdist, 1e-12 * (1 + ref.sqdist)) << hint;
    }
  }
  // Inside, from the containing tet, from a random one: still contained (distance 0), in a tet
  // that contains the point.
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p = P.row(i).transpose();
    for (int hint : {res[i].elem, pick(rng)}) {
      const ClosestPointResult h = loc.locate(p, hint);
      EXPECT_EQ(h.sqdist, 0.0) << i;
      check_result<3>(p, h, V, T);
    }
  }
}
