// Micro-benchmarks of the symmetric volume map objective (symmetric-volume-maps.txt),
// sized like the issue-5 target (~30k tets per mesh):
//  - E_ARAP (Eq. 20) with its Eq. 26 gradient on a 17^3 × 6 = 29478-tet jittered grid,
//    mapped by a smooth non-rigid deformation with a few inverted tets (the X-step inner
//    loop: one signed SVD per tet);
//  - the full X-step objective of one direction (DirectionalEnergy, Eq. 25 restricted to
//    X_ij: ARAP + E_R + E_P forward/backward closest points + E_Q), energy + gradient, at a
//    point slightly moved from the previous one (as inside L-BFGS, so closest-point hints
//    from the previous evaluation apply);
//  - one P-step-sized closest-point projection in R^6 onto the 29478 tets (query of all
//    vertices, refit before), without and with the previous answers as hints.
// Argument: number of OpenMP threads.
#include "../tests/geometry/fixtures.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/volume/sarap.h"
#include "shapemap/volume/symmetric_map.h"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <random>

namespace {

using namespace shapemap;

struct VolumeFixture {
  TetMesh A, B;       // B = deform(A)
  Eigen::MatrixXd X;  // A's vertices mapped into B's space, perturbed
  BarycentricMap P12, P21;
};

Eigen::RowVector3d deform(const Eigen::RowVector3d& p) {
  return Eigen::RowVector3d(p(0) + 0.15 * std::sin(3 * p(1)), 1.2 * p(1) + 0.1 * p(2) * p(2),
                            0.9 * p(2) + 0.1 * std::cos(2 * p(0)));
}

// The vertex -> (first incident tet, corner) identity map of a mesh onto a mesh with the
// same connectivity.
BarycentricMap identity_map(const TetMesh& M) {
  BarycentricMap P;
  P.elem.setConstant(M.num_vertices(), -1);
  P.bary.setZero(M.num_vertices(), 4);
  for (int k = 0; k < M.num_tets(); ++k)
    for (int q = 0; q < 4; ++q) {
      int v = M.T(k, q);
      if (P.elem(v) < 0) {
        P.elem(v) = k;
        P.bary(v, q) = 1.0;
      }
    }
  return P;
}

const VolumeFixture& fixture() {
  static const VolumeFixture* f = [] {
    auto* s = new VolumeFixture;
    shapemap::testing::tet_grid(17, 0.2, 1, s->A.V, s->A.T);
    s->B.T = s->A.T;
    s->B.V.resize(s->A.V.rows(), 3);
    for (int v = 0; v < s->A.V.rows(); ++v) s->B.V.row(v) = deform(s->A.V.row(v));
    std::mt19937 rng(2);
    std::normal_distribution<double> N(0.0, 0.01);  // ~ 1/6 of an edge: some inversions
    s->X = s->B.V;
    for (int v = 0; v < s->X.rows(); ++v)
      for (int d = 0; d < 3; ++d) s->X(v, d) += N(rng);
    s->P12 = identity_map(s->A);
    s->P21 = identity_map(s->B);
    return s;
  }();
  return *f;
}

void BM_ArapEnergyGradient(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const VolumeFixture& f = fixture();
  ArapEnergy arap(f.A.V, f.A.T);
  Eigen::MatrixXd G;
  for (auto _ : state) {
    double e = arap.energy(f.X, &G);
    benchmark::DoNotOptimize(e);
    benchmark::DoNotOptimize(G.data());
  }
  state.SetItemsProcessed(state.iterations() * f.A.T.rows());
}
BENCHMARK(BM_ArapEnergyGradient)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_ArapEnergyOnly(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const VolumeFixture& f = fixture();
  ArapEnergy arap(f.A.V, f.A.T);
  for (auto _ : state) {
    double e = arap.energy(f.X);
    benchmark::DoNotOptimize(e);
  }
  state.SetItemsProcessed(state.iterations() * f.A.T.rows());
}
BENCHMARK(BM_ArapEnergyOnly)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_DirectionalEnergyGradient(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const VolumeFixture& f = fixture();
  DirectionalEnergy e(f.A, f.B);
  e.set_weights(0.5, 5.0, 25.0);
  e.set_maps(f.P12, f.P21);
  Eigen::MatrixXd X = f.X, G;
  e.evaluate(X, &G);  // first evaluation builds the mapped-boundary BVH
  int it = 0;
  for (auto _ : state) {
    X.col(it % 3).array() += 1e-4;  // a small move, as between L-BFGS evaluations
    ++it;
    double v = e.evaluate(X, &G);
    benchmark::DoNotOptimize(v);
    benchmark::DoNotOptimize(G.data());
  }
  state.SetItemsProcessed(state.iterations() * f.A.T.rows());
}
BENCHMARK(BM_DirectionalEnergyGradient)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_PStepProjectionR6(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const VolumeFixture& f = fixture();
  const int n = int(f.A.V.rows());
  Eigen::MatrixXd W(n, 6), Q(n, 6);
  const double a = std::sqrt(0.5), b = std::sqrt(5.0);
  W.leftCols(3) = a * f.X;  // [sqrt(a) X_ji, sqrt(b) V_j]
  W.rightCols(3) = b * f.B.V;
  Q.leftCols(3) = a * f.A.V;  // [sqrt(a) V_i, sqrt(b) X_ij]
  Q.rightCols(3) = b * f.X;
  ClosestPoint6 bvh(W, f.B.T);
  std::vector<ClosestPointResult> out;
  for (auto _ : state) {
    bvh.refit(W);
    bvh.query(Q, out, false);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_PStepProjectionR6)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// The same projection with the previous answers as hints, the query points moved by a
// little (as between two outer iterations late in Algorithm 1).
void BM_PStepProjectionR6Hinted(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const VolumeFixture& f = fixture();
  const int n = int(f.A.V.rows());
  Eigen::MatrixXd W(n, 6), Q(n, 6);
  const double a = std::sqrt(0.5), b = std::sqrt(5.0);
  W.leftCols(3) = a * f.X;
  W.rightCols(3) = b * f.B.V;
  Q.leftCols(3) = a * f.A.V;
  Q.rightCols(3) = b * f.X;
  ClosestPoint6 bvh(W, f.B.T);
  std::vector<ClosestPointResult> out;
  bvh.query(Q, out, false);
  int it = 0;
  for (auto _ : state) {
    Q.col(3 + it % 3).array() += (it % 2 ? -1e-3 : 1e-3);
    ++it;
    bvh.refit(W);
    bvh.query(Q, out, true);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_PStepProjectionR6Hinted)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace
