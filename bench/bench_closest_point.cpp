// Micro-benchmarks of ClosestPointBVH, sized like the projection steps of the papers:
//  - elastic correspondence P/Q steps: a 5000-vertex triangle mesh (10000 faces) embedded
//    in R^6 as [X, s*Y], 5000 query points near it;
//  - symmetric volume maps P-step: a ~30k-tet mesh (17^3 cubes × 6 tets) embedded in R^6,
//    6000 query points near it.
// Argument: number of OpenMP threads for the batched query.
#include "shapemap/geometry/closest_point.h"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <random>

namespace {

using namespace shapemap;

// Torus grid with nu × nv vertices (2 nu nv triangles), radii 1 and 0.35.
void torus(int nu, int nv, Eigen::MatrixXd& V, Eigen::MatrixXi& F) {
  V.resize(nu * nv, 3);
  F.resize(2 * nu * nv, 3);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      V.row(i * nv + j) << (1 + 0.35 * std::cos(v)) * std::cos(u),
          (1 + 0.35 * std::cos(v)) * std::sin(u), 0.35 * std::sin(v);
      const int a = i * nv + j, b = ((i + 1) % nu) * nv + j, c = ((i + 1) % nu) * nv + (j + 1) % nv,
                d = i * nv + (j + 1) % nv;
      F.row(2 * a) << a, b, c;
      F.row(2 * a + 1) << a, c, d;
    }
}

// [0,1]^3 grid, n cubes per side, 6 tets per cube.
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
        int c[8] = {id(i, j, k),         id(i + 1, j, k),         id(i + 1, j + 1, k),
                    id(i, j + 1, k),     id(i, j, k + 1),         id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)};
        const int q[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                             {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
        for (const auto& r : q) T.row(t++) << c[r[0]], c[r[1]], c[r[2]], c[r[3]];
      }
}

// [X, s*Y] with Y a smooth deformation of X.
Eigen::MatrixXd embed6(const Eigen::MatrixXd& X, double s) {
  Eigen::MatrixXd V(X.rows(), 6);
  for (int i = 0; i < X.rows(); ++i) {
    const double x = X(i, 0), y = X(i, 1), z = X(i, 2);
    V.row(i) << x, y, z, s * (x + 0.3 * std::sin(2 * y)), s * (1.2 * y + 0.2 * z * z),
        s * (z + 0.25 * std::cos(3 * x));
  }
  return V;
}

// Points near the mesh: random points of random elements plus Gaussian noise sigma.
Eigen::MatrixXd points_near(const Eigen::MatrixXd& V, const Eigen::MatrixXi& E, int k,
                            double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, int(E.rows()) - 1);
  std::uniform_real_distribution<double> u(1e-9, 1);
  std::normal_distribution<double> g(0, sigma);
  Eigen::MatrixXd P(k, V.cols());
  for (int i = 0; i < k; ++i) {
    const int e = pick(rng);
    Eigen::VectorXd w(E.cols());
    for (int j = 0; j < E.cols(); ++j) w(j) = -std::log(u(rng));
    w /= w.sum();
    Eigen::RowVectorXd q = Eigen::RowVectorXd::Zero(V.cols());
    for (int j = 0; j < E.cols(); ++j) q += w(j) * V.row(E(e, j));
    for (int d = 0; d < V.cols(); ++d) q(d) += g(rng);
    P.row(i) = q;
  }
  return P;
}

struct TriCase {
  Eigen::MatrixXd V, P;
  Eigen::MatrixXi F;
  TriCase() {
    Eigen::MatrixXd X;
    torus(100, 50, X, F);  // 5000 vertices, 10000 faces
    V = embed6(X, 1.0);
    P = points_near(V, F, 5000, 0.05, 1);
  }
};
struct TetCase {
  Eigen::MatrixXd V, P;
  Eigen::MatrixXi T;
  TetCase() {
    Eigen::MatrixXd X;
    tet_grid(17, X, T);  // 5832 vertices, 29478 tets
    V = embed6(X, 1.0);
    P = points_near(V, T, 6000, 0.05, 2);
  }
};
const TriCase& tri_case() { static TriCase c; return c; }
const TetCase& tet_case() { static TetCase c; return c; }

void BM_Tri6_Query5k(benchmark::State& state) {
  const TriCase& c = tri_case();
  omp_set_num_threads(int(state.range(0)));
  ClosestPoint6 bvh(c.V, c.F);
  std::vector<ClosestPointResult> out;
  for (auto _ : state) {
    bvh.query(c.P, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * c.P.rows());
}
BENCHMARK(BM_Tri6_Query5k)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// Warm start with the previous answers (as in an iterative P/Q step).
void BM_Tri6_Query5kHinted(benchmark::State& state) {
  const TriCase& c = tri_case();
  omp_set_num_threads(int(state.range(0)));
  ClosestPoint6 bvh(c.V, c.F);
  std::vector<ClosestPointResult> out;
  bvh.query(c.P, out);
  for (auto _ : state) {
    bvh.query(c.P, out, true);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * c.P.rows());
}
BENCHMARK(BM_Tri6_Query5kHinted)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_Tri6_BuildAndRefit(benchmark::State& state) {
  const TriCase& c = tri_case();
  omp_set_num_threads(1);
  ClosestPoint6 bvh;
  for (auto _ : state) {
    if (state.range(0) == 0)
      bvh.build(c.V, c.F);
    else {
      state.PauseTiming();
      if (bvh.num_elements() == 0) bvh.build(c.V, c.F);
      state.ResumeTiming();
      bvh.refit(c.V);
    }
  }
}
BENCHMARK(BM_Tri6_BuildAndRefit)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_Tet6_Query6k(benchmark::State& state) {
  const TetCase& c = tet_case();
  omp_set_num_threads(int(state.range(0)));
  ClosestPoint6 bvh(c.V, c.T);
  std::vector<ClosestPointResult> out;
  for (auto _ : state) {
    bvh.query(c.P, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * c.P.rows());
}
BENCHMARK(BM_Tet6_Query6k)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_Tet6_Query6kHinted(benchmark::State& state) {
  const TetCase& c = tet_case();
  omp_set_num_threads(int(state.range(0)));
  ClosestPoint6 bvh(c.V, c.T);
  std::vector<ClosestPointResult> out;
  bvh.query(c.P, out);
  for (auto _ : state) {
    bvh.query(c.P, out, true);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * c.P.rows());
}
BENCHMARK(BM_Tet6_Query6kHinted)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_Tet6_BuildAndRefit(benchmark::State& state) {
  const TetCase& c = tet_case();
  omp_set_num_threads(1);
  ClosestPoint6 bvh;
  for (auto _ : state) {
    if (state.range(0) == 0)
      bvh.build(c.V, c.T);
    else {
      state.PauseTiming();
      if (bvh.num_elements() == 0) bvh.build(c.V, c.T);
      state.ResumeTiming();
      bvh.refit(c.V);
    }
  }
}
BENCHMARK(BM_Tet6_BuildAndRefit)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
