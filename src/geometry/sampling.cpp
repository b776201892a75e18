// Farthest-point sampling on heat-method and edge-graph (Dijkstra) distances.
#include "shapemap/geometry/sampling.h"
#include "shapemap/adjacency.h"
#include "shapemap/error.h"
#include "shapemap/geometry/geodesics.h"
#include <algorithm>
#include <functional>
#include <limits>
#include <queue>
#include <string>
#include <utility>

namespace shapemap {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void check_k(int k, int n, int first) {
  if (k > n)
    throw InputError("farthest_point_sampling: " + std::to_string(k) + " samples requested from " +
                     std::to_string(n) + " vertices");
  if (first >= n)
    throw InputError("farthest_point_sampling: first vertex " + std::to_string(first) +
                     " out of range [0," + std::to_string(n) + ")");
}

// The unchosen vertex with the largest d (lowest index on ties); d of chosen vertices is
// ignored.
int argmax_unchosen(const Eigen::VectorXd& d, const std::vector<char>& chosen) {
  int best = -1;
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    if (chosen[i]) continue;
    if (best < 0 || d(i) > d(best)) best = int(i);
  }
  return best;
}

}  // namespace

std::vector<int> farthest_point_sampling(const HeatGeodesics& geo, int k, int first) {
  const int n = geo.num_vertices();
  check_k(k, n, first);
  std::vector<int> samples;
  if (k <= 0) return samples;
  std::vector<char> chosen(n, 0);
  if (first < 0) first = argmax_unchosen(geo.distance(0), chosen);
  Eigen::VectorXd d = geo.distance(first);
  samples.push_back(first);
  chosen[first] = 1;
  while (int(samples.size()) < k) {
    const int next = argmax_unchosen(d, chosen);
    samples.push_back(next);
    chosen[next] = 1;
    if (int(samples.size()) < k) d = d.cwiseMin(geo.distance(next));
  }
  return samples;
}

std::vector<int> farthest_point_sampling_graph(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                               int k, int first) {
  const int n = int(V.rows());
  if (F.cols() != 3) throw InputError("farthest_point_sampling_graph: F must have 3 columns");
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= n))
    throw InputError("farthest_point_sampling_graph: face index out of range");
  check_k(k, n, first);
  std::vector<int> samples;
  if (k <= 0) return samples;
  // Edge graph in CSR form with Euclidean edge lengths.
  const Eigen::MatrixXi E = unique_edges(F);
  std::vector<int> ptr(n + 1, 0), adj(2 * E.rows());
  std::vector<double> len(2 * E.rows());
  for (Eigen::Index e = 0; e < E.rows(); ++e) {
    ++ptr[E(e, 0) + 1];
    ++ptr[E(e, 1) + 1];
  }
  for (int i = 0; i < n; ++i) ptr[i + 1] += ptr[i];
  {
    std::vector<int> fill(ptr.begin(), ptr.end() - 1);
    for (Eigen::Index e = 0; e < E.rows(); ++e) {
      const int a = E(e, 0), b = E(e, 1);
      const double l = (V.row(a) - V.row(b)).norm();
      adj[fill[a]] = b;
      len[fill[a]++] = l;
      adj[fill[b]] = a;
      len[fill[b]++] = l;
    }
  }
  // Dijkstra from `s` that only lowers d (incremental FPS: vertices already closer to an
  // earlier sample are not expanded).
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
  auto relax_from = [&](int s, Eigen::VectorXd& d) {
    d(s) = 0;
    heap.push({0.0, s});
    while (!heap.empty()) {
      const auto [du, u] = heap.top();
      heap.pop();
      if (du > d(u)) continue;
      for (int q = ptr[u]; q < ptr[u + 1]; ++q) {
        const double nd = du + len[q];
        if (nd < d(adj[q])) {
          d(adj[q]) = nd;
          heap.push({nd, adj[q]});
        }
      }
    }
  };
  std::vector<char> chosen(n, 0);
  Eigen::VectorXd d = Eigen::VectorXd::Constant(n, kInf);
  if (first < 0) {
    relax_from(0, d);
    first = argmax_unchosen(d, chosen);
    d.setConstant(kInf);
  }
  samples.push_back(first);
  chosen[first] = 1;
  relax_from(first, d);
  while (int(samples.size()) < k) {
    const int next = argmax_unchosen(d, chosen);
    samples.push_back(next);
    chosen[next] = 1;
    relax_from(next, d);
  }
  return samples;
}

}  // namespace shapemap
