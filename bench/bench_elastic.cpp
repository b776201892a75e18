// Micro-benchmarks of elastic correspondence (elastic-correspondence.txt, issue 4), sized
// like the speed target (a ~5,000-vertex generated creature pair):
//  - the thin-shell energy W_def = alpha W_mem + eta W_bnd (Eq. 2, 7, 9), value + exact
//    gradient, with the admissible-edge mask recomputed per evaluation and frozen (as in
//    the Y steps of Algorithm 1), serial and with the OpenMP path forced on 2 threads, and
//    value only; the frozen case also at 25,000 vertices (the SHREC'07 busts' size), where
//    ShellEnergyOptions::parallel_min_faces decides between the two paths;
//  - 10 outer iterations of Algorithm 1 (bijective model, paper defaults, the ground-truth
//    maps as initialization), i.e. the P/Q projections and the Y/Y~ L-BFGS steps.
// Argument: number of OpenMP threads.
#include "shapemap/generate.h"
#include "shapemap/surface/elastic.h"
#include "shapemap/surface/shell_energy.h"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <vector>

namespace {

using namespace shapemap;

const GeneratedPair& pair5k() {
  static const GeneratedPair* p =
      new GeneratedPair(make_creature_pair(1, PairKind::NonIsometric, 5000));
  return *p;
}

// The source of the pair, unit area (as Algorithm 1 sees it), and a smoothly deformed
// copy (stretch plus a deterministic bump field) as the deformed configuration Y, row-major.
struct ShellCase {
  Eigen::MatrixXd X;
  Eigen::MatrixXi F;
  std::vector<double> y;
};
ShellCase make_shell_case(const TriMesh& A) {
  ShellCase c;
  c.X = unit_area_normalization(A).apply(A.V);
  c.F = A.F;
  const int n = int(c.X.rows());
  c.y.resize(3 * size_t(n));
  for (int i = 0; i < n; ++i) {
    const double x = c.X(i, 0), y = c.X(i, 1), z = c.X(i, 2);
    const double bump = 0.02 * std::sin(7 * x + 3 * y) * std::cos(5 * z);
    c.y[3 * i] = 1.2 * x + bump;
    c.y[3 * i + 1] = 0.9 * y - bump;
    c.y[3 * i + 2] = z + 0.5 * bump;
  }
  return c;
}
// large: the 25,000-vertex source instead of the 5,000-vertex one.
const ShellCase& shell_case(bool large = false) {
  if (large) {
    static const ShellCase* c =
        new ShellCase(make_shell_case(make_creature_pair(1, PairKind::NonIsometric, 25000).A));
    return *c;
  }
  static const ShellCase* c = new ShellCase(make_shell_case(pair5k().A));
  return *c;
}

void BM_ShellEnergyValueGrad(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const ShellCase& c = shell_case(state.range(3) != 0);
  ShellEnergyOptions so;  // paper defaults: alpha 20, eta 0.1, lambda = mu = 1
  if (state.range(2) == 1) so.parallel_min_faces = 0;  // force the OpenMP path
  if (state.range(2) == 2) so.parallel_min_faces = 1 << 30;  // force the serial path
  ShellEnergy W(c.X, c.F, so);
  if (state.range(1)) W.freeze_mask(c.y.data());
  std::vector<double> g(c.y.size());
  for (auto _ : state) {
    const double E = W.evaluate(c.y.data(), g.data());
    benchmark::DoNotOptimize(E);
    benchmark::DoNotOptimize(g.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(c.F.rows()));
  state.counters["faces"] = double(c.F.rows());
}
// Args: threads, frozen mask (0/1), path (0: the default, ShellEnergyOptions::
// parallel_min_faces; 1: OpenMP forced; 2: serial forced), mesh (0: 5k vertices, 1: 25k).
BENCHMARK(BM_ShellEnergyValueGrad)
    ->Args({1, 0, 0, 0})->Args({1, 1, 0, 0})->Args({2, 1, 1, 0})
    ->Args({2, 1, 2, 1})->Args({2, 1, 1, 1})->Args({2, 1, 0, 1})
    ->Unit(benchmark::kMicrosecond);

void BM_ShellEnergyValueOnly(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const ShellCase& c = shell_case();
  ShellEnergy W(c.X, c.F);
  W.freeze_mask(c.y.data());
  for (auto _ : state) {
    const double E = W.evaluate(c.y.data(), nullptr);
    benchmark::DoNotOptimize(E);
  }
  state.SetItemsProcessed(state.iterations() * int64_t(c.F.rows()));
}
BENCHMARK(BM_ShellEnergyValueOnly)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

void BM_ElasticOuterIterations10(benchmark::State& state) {
  omp_set_num_threads(int(state.range(0)));
  const GeneratedPair& p = pair5k();
  ElasticOptions o;  // bijective, paper defaults
  o.max_outer_iterations = 10;
  ElasticResult r;
  for (auto _ : state) {
    r = elastic_correspondence(p.A, p.B, p.truth_AB, p.truth_BA, o);
    benchmark::DoNotOptimize(r.Y.data());
  }
  const double K = std::max(1, r.outer_iterations);
  int inner = 0;
  for (const auto& it : r.history) inner += it.inner_iterations;
  state.counters["s_per_outer_projection"] = r.time_projection / K;
  state.counters["s_per_outer_deformation"] = r.time_deformation / K;
  state.counters["lbfgs_per_outer"] = inner / K;
  state.SetItemsProcessed(state.iterations() * int64_t(r.outer_iterations));
}
BENCHMARK(BM_ElasticOuterIterations10)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
