// Micro-benchmark of the isovolumetric energy E_I (Eq. 2) and its gradient (Eqs. 8-10),
// the per-iteration cost of the IEM CG (isovolumetric-ball-parameterization.txt, Alg. 1):
// a radially squashed 19^3-cell cube (8000 vertices, 41154 tets, the size class of the
// issue's 7k-vertex / 37k-tet speed target), map = a smooth perturbation of the identity.
// Argument: number of OpenMP threads.
#include "../tests/volume/ball_test_mesh.h"
#include "shapemap/volume/ball_param.h"
#include "shapemap/volume/vsem.h"

#include <benchmark/benchmark.h>
#include <omp.h>

namespace {

using namespace shapemap;

struct BallFixture {
  TetMesh m;
  Eigen::MatrixXd f;
  BallFixture() {
    m = testing_ball::blob_tets(19, Eigen::Vector3d(1.0, 0.8, 0.7), 0.1);
    f = m.V;
    for (Eigen::Index i = 0; i < f.rows(); ++i)
      f.row(i) += 0.02 * Eigen::RowVector3d(std::sin(3 * m.V(i, 1)), std::cos(2 * m.V(i, 2)), std::sin(m.V(i, 0)));
  }
};

void BM_IsovolumetricEnergyGradient(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  static const BallFixture fx;
  const IsovolumetricEnergy E(fx.m.V, fx.m.T);
  Eigen::MatrixXd G;
  for (auto _ : state) {
    const double e = E.energy_and_gradient(fx.f, G);
    benchmark::DoNotOptimize(e);
    benchmark::DoNotOptimize(G.data());
  }
  state.SetItemsProcessed(state.iterations() * fx.m.T.rows());
}
BENCHMARK(BM_IsovolumetricEnergyGradient)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

void BM_IsovolumetricEnergyOnly(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  static const BallFixture fx;
  const IsovolumetricEnergy E(fx.m.V, fx.m.T);
  for (auto _ : state) benchmark::DoNotOptimize(E.energy(fx.f));
  state.SetItemsProcessed(state.iterations() * fx.m.T.rows());
}
BENCHMARK(BM_IsovolumetricEnergyOnly)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// Energy + gradient in the CG variables (f_I, theta, phi) (Eq. 14), with the chain rule.
void BM_SphericalBallEnergyGradient(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  static const BallFixture fx;
  const IsovolumetricEnergy E(fx.m.V, fx.m.T);
  const TetBoundary tb = boundary_surface(fx.m);
  std::vector<int> I;
  for (int i = 0; i < fx.m.num_vertices(); ++i)
    if (tb.to_surface(i) < 0) I.push_back(i);
  const Eigen::VectorXi interior = Eigen::Map<Eigen::VectorXi>(I.data(), Eigen::Index(I.size()));
  SphericalBallEnergy sbe(E, interior, tb.to_volume);
  Eigen::MatrixXd f = fx.f;
  for (Eigen::Index k = 0; k < tb.to_volume.size(); ++k) f.row(tb.to_volume(k)).normalize();
  const Eigen::VectorXd x = sbe.from_map(f);
  Eigen::VectorXd g;
  for (auto _ : state) {
    benchmark::DoNotOptimize(sbe.energy_and_gradient(x, g));
    benchmark::DoNotOptimize(g.data());
  }
  state.SetItemsProcessed(state.iterations() * fx.m.T.rows());
}
BENCHMARK(BM_SphericalBallEnergyGradient)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

}  // namespace
