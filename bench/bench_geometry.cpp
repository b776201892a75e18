// Micro-benchmarks of the geometry operators, sized like their uses in the papers:
//  - signed SVD of 100k 3×3 matrices (per-tet rotations of ARAP-type energies);
//  - tet cotan Laplacian re-assembly on ~30k tets (17^3 cubes × 6 tets, jittered), as in
//    every iteration of the isovolumetric ball parameterization (L_V, Eq. 3c);
//  - heat-method geodesics on a 10242-vertex icosphere: one source, and a batch of 32.
// Argument: number of OpenMP threads.
#include "../tests/geometry/fixtures.h"
#include "shapemap/geometry/geodesics.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/svd3.h"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <random>

namespace {

using namespace shapemap;

void BM_SignedSVD3Batch(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  std::mt19937 rng(1);
  std::normal_distribution<double> N;
  std::vector<Eigen::Matrix3d> A(100000);
  for (auto& m : A)
    for (int i = 0; i < 9; ++i) m(i) = N(rng);
  std::vector<SignedSVD3> out;
  for (auto _ : state) {
    signed_svd3_batch(A, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(A.size()));
}
BENCHMARK(BM_SignedSVD3Batch)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_TetLaplacianAssembly(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  shapemap::testing::tet_grid(17, 0.2, 1, V, T);
  const Eigen::MatrixXd W = tet_cotan_weights(V, T);
  Eigen::SparseMatrix<double> L;
  assemble_tet_laplacian(T, W, int(V.rows()), L);  // pattern built once, outside the loop
  for (auto _ : state) {
    assemble_tet_laplacian(T, W, int(V.rows()), L);
    benchmark::DoNotOptimize(L.valuePtr());
  }
  state.SetItemsProcessed(state.iterations() * T.rows());
}
BENCHMARK(BM_TetLaplacianAssembly)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

void BM_TetCotanWeightsAndAssembly(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  shapemap::testing::tet_grid(17, 0.2, 1, V, T);
  Eigen::SparseMatrix<double> L;
  assemble_tet_laplacian(T, tet_cotan_weights(V, T), int(V.rows()), L);
  for (auto _ : state) {
    assemble_tet_laplacian(T, tet_cotan_weights(V, T), int(V.rows()), L);
    benchmark::DoNotOptimize(L.valuePtr());
  }
  state.SetItemsProcessed(state.iterations() * T.rows());
}
BENCHMARK(BM_TetCotanWeightsAndAssembly)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

const HeatGeodesics& sphere_geodesics() {
  static const HeatGeodesics* geo = [] {
    Eigen::MatrixXd V;
    Eigen::MatrixXi F;
    shapemap::testing::icosphere(5, 1.0, V, F);  // 10242 vertices
    return new HeatGeodesics(V, F);
  }();
  return *geo;
}

void BM_HeatGeodesicsSingleSource(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const HeatGeodesics& geo = sphere_geodesics();
  int s = 0;
  for (auto _ : state) {
    Eigen::VectorXd d = geo.distance(s);
    benchmark::DoNotOptimize(d.data());
    s = (s + 997) % geo.num_vertices();
  }
}
BENCHMARK(BM_HeatGeodesicsSingleSource)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_HeatGeodesicsBatch32(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const HeatGeodesics& geo = sphere_geodesics();
  std::vector<int> sources;
  for (int i = 0; i < 32; ++i) sources.push_back(i * 311);
  for (auto _ : state) {
    Eigen::MatrixXd D = geo.distances(sources);
    benchmark::DoNotOptimize(D.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(sources.size()));
}
BENCHMARK(BM_HeatGeodesicsBatch32)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_HeatGeodesicsPrecompute(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  shapemap::testing::icosphere(5, 1.0, V, F);
  for (auto _ : state) {
    HeatGeodesics geo(V, F);
    benchmark::DoNotOptimize(&geo);
  }
}
BENCHMARK(BM_HeatGeodesicsPrecompute)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
