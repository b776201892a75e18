// Latitude-longitude map of a genus-0 surface onto the sphere (Brechbuehler, Gerig,
// Kuebler 1995); see the header.
#include "shapemap/volume/latitude_longitude.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>
#include <vector>

namespace shapemap {

namespace {

using Adjacency = std::vector<std::vector<std::pair<int, double>>>;

// Harmonic solves over the vertices other than the poles a, b: (L x)_i = rhs_i, the poles
// either Dirichlet values (`fixed`, n-vector) or left out with their edges (fixed empty; the
// free constant is then pinned at unknown `gauge`). Unknown numbering idx: -1 at the poles.
struct HarmonicWithoutPoles {
  const Adjacency& adj;
  std::vector<int> idx;
  int nu = 0;
  size_t wcount = 0;
  HarmonicWithoutPoles(const Adjacency& adjacency, Eigen::Index a, Eigen::Index b)
      : adj(adjacency), idx(adjacency.size(), -1) {
    for (const auto& nb : adj) wcount += nb.size();
    for (size_t i = 0; i < adj.size(); ++i)
      if (Eigen::Index(i) != a && Eigen::Index(i) != b) idx[i] = nu++;
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& rhs, const Eigen::VectorXd& fixed, int gauge) const {
    const Eigen::Index n = Eigen::Index(adj.size());
    const bool dirichlet = fixed.size() == n;
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(size_t(wcount) + size_t(n));
    Eigen::VectorXd r = Eigen::VectorXd::Zero(nu);
    for (Eigen::Index i = 0; i < n; ++i) {
      if (idx[i] < 0) continue;
      r(idx[i]) += rhs(i);
      double diag = 0;
      for (const auto& [j, w] : adj[i]) {
        if (idx[j] >= 0)
          trip.emplace_back(idx[i], idx[j], -w);
        else if (dirichlet)
          r(idx[i]) += w * fixed(j);
        else
          continue;
        diag += w;
      }
      trip.emplace_back(idx[i], idx[i], diag);
    }
    if (gauge >= 0) trip.emplace_back(gauge, gauge, 1.0);  // pins the free constant
    Eigen::SparseMatrix<double> A(nu, nu);
    A.setFromTriplets(trip.begin(), trip.end());
    SparseCholesky chol;
    chol.compute(A);
    const Eigen::VectorXd x = chol.solve(r);
    Eigen::VectorXd out = dirichlet ? fixed : Eigen::VectorXd::Zero(n);
    for (Eigen::Index i = 0; i < n; ++i)
      if (idx[i] >= 0) out(i) = x(idx[i]);
    return out;
  }
};

// The map for given poles a, b (see the header); adj: positive edge weights, target: face
// area shares. Empty S when the construction fails.
LatitudeLongitudeMap map_with_poles(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                    const Adjacency& adj, const Eigen::VectorXd& target,
                                    Eigen::Index a, Eigen::Index b) {
  const Eigen::Index n = V.rows(), m = F.rows();
  LatitudeLongitudeMap out;
  if (a == b) return out;
  const HarmonicWithoutPoles harmonic(adj, a, b);
  const std::vector<int>& idx = harmonic.idx;
  auto solve = [&](const Eigen::VectorXd& rhs, const Eigen::VectorXd& fixed, int gauge) {
    return harmonic.solve(rhs, fixed, gauge);
  };
  Eigen::VectorXd fixed = Eigen::VectorXd::Zero(n);
  fixed(b) = 1;
  const Eigen::VectorXd u = solve(Eigen::VectorXd::Zero(n), fixed, -1);

  // Date line: steepest ascent of u from a to b.
  std::vector<int> path = {int(a)};
  while (path.back() != b) {
    const int v = path.back();
    int next = -1;
    double best = u(v);
    for (const auto& [j, w] : adj[v])
      if (u(j) > best) {
        best = u(j);
        next = j;
      }
    if (next < 0 || int(path.size()) > n) return out;
    path.push_back(next);
  }
  // Counter-clockwise successor in each one-ring: face (i, j, k) turns j into k around i.
  std::vector<std::vector<std::pair<int, int>>> succ(n);
  for (Eigen::Index f = 0; f < m; ++f)
    for (int c = 0; c < 3; ++c) succ[F(f, c)].emplace_back(F(f, (c + 1) % 3), F(f, (c + 2) % 3));
  auto successor = [&](int i, int j) {
    for (const auto& [x, y] : succ[i])
      if (x == j) return y;
    return -1;
  };
  // left[i]: the neighbours of path vertex i strictly between its successor and its
  // predecessor on the path, counter-clockwise (the left side of the walk a -> b).
  std::vector<std::vector<int>> left(n);
  for (size_t k = 1; k + 1 < path.size(); ++k) {
    const int p = path[k], prev = path[k - 1], nxt = path[k + 1];
    int j = successor(p, nxt);
    for (size_t guard = 0; j >= 0 && j != prev && guard < adj[p].size(); ++guard) {
      left[p].push_back(j);
      j = successor(p, j);
    }
    if (j != prev) return out;  // not a manifold one-ring
  }
  auto is_left = [&](int p, int q) {
    return std::find(left[p].begin(), left[p].end(), q) != left[p].end() ? 1.0 : 0.0;
  };
  // Walking south from a, the left is east, where the longitude grows: the left copy of a
  // path vertex is its right value minus 2 pi, i.e. the minimizer of
  // sum_e w_e (phi_i - phi_j - 2 pi (l_i(e) - l_j(e)))^2 (positive orientation of (theta, phi)).
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (const auto& [j, w] : adj[i]) rhs(i) += w * 2 * M_PI * (is_left(int(i), j) - is_left(j, int(i)));
  int gauge = -1;
  for (Eigen::Index i = 0; i < n && gauge < 0; ++i)
    if (idx[i] >= 0 && left[i].empty()) gauge = idx[i];
  const Eigen::VectorXd phi = solve(rhs, Eigen::VectorXd(), gauge);

  // Polar angle by area: 1 - cos(theta_i) = 2 * (target share of the vertices below).
  Eigen::VectorXd vw = Eigen::VectorXd::Zero(n);
  for (Eigen::Index f = 0; f < m; ++f)
    for (int c = 0; c < 3; ++c) vw(F(f, c)) += target(f) / 3;
  std::vector<int> order(n);
  for (Eigen::Index i = 0; i < n; ++i) order[i] = int(i);
  std::sort(order.begin(), order.end(), [&](int x, int y) { return u(x) < u(y); });
  const double total = vw.sum();
  Eigen::MatrixXd S(n, 3);
  double below = 0;
  for (int i : order) {
    const double share = i == a ? 0 : i == b ? 1 : std::clamp((below + 0.5 * vw(i)) / total, 0.0, 1.0);
    below += vw(i);
    const double ct = 1 - 2 * share, st = std::sqrt(std::max(0.0, 1 - ct * ct));
    S.row(i) << st * std::cos(phi(i)), st * std::sin(phi(i)), ct;
  }
  if (positive_origin_cones(S, F) < m - m / 2) {  // safety net: mirror if mostly inverted
    S.col(1) *= -1;
    out.longitude = -phi;
  } else {
    out.longitude = phi;
  }
  out.S = std::move(S);
  out.pole_a = int(a);
  out.pole_b = int(b);
  out.latitude = u;
  out.date_line = std::move(path);
  return out;
}

// Farthest-point double sweep with the distance d(from) (n-vector): (a, b).
template <class Distance>
std::pair<Eigen::Index, Eigen::Index> double_sweep(const Distance& d) {
  Eigen::Index a = 0, b = 0;
  d(0).maxCoeff(&a);
  d(a).maxCoeff(&b);
  return {a, b};
}

}  // namespace

LatitudeLongitudeMap latitude_longitude_map(const TriMesh& surface,
                                           const Eigen::SparseMatrix<double>& laplacian,
                                           const Eigen::VectorXd& face_shares) {
  const Eigen::MatrixXd& V = surface.V;
  const Eigen::MatrixXi& F = surface.F;
  const Eigen::Index n = V.rows(), m = F.rows();
  LatitudeLongitudeMap out;
  if (n < 4 || m < 4) return out;
  const Eigen::SparseMatrix<double> Lc = laplacian.rows() == n ? laplacian : cotan_laplacian(V, F);
  Eigen::VectorXd target = face_shares.size() == m ? face_shares : triangle_areas(V, F);
  // Positive edge weights: the cotangent weights, clamped from below.
  Adjacency adj(n);
  long wcount = 0;
  for (Eigen::Index c = 0; c < Lc.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(Lc, c); it; ++it)
      if (it.row() != c) {
        adj[it.row()].emplace_back(int(c), -it.value());
        ++wcount;
      }
  if (wcount == 0) return out;
  // Floor at 1% of the median magnitude (a mean would let one sliver's huge cotangent lift
  // the floor above every other weight); NaN weights become the floor too.
  std::vector<double> mags;
  mags.reserve(size_t(wcount));
  for (const auto& nb : adj)
    for (const auto& [j, w] : nb)
      if (std::isfinite(w)) mags.push_back(std::abs(w));
  if (mags.empty()) return out;
  std::nth_element(mags.begin(), mags.begin() + long(mags.size() / 2), mags.end());
  const double wfloor = 0.01 * mags[mags.size() / 2];
  if (!(wfloor > 0)) return out;
  for (auto& nb : adj)
    for (auto& [j, w] : nb)
      if (!(w >= wfloor)) w = wfloor;

  // Poles: two candidates, the double sweeps of Euclidean distances and of edge-path
  // lengths; the map with fewer folded faces on the sphere is kept. Edge paths find the
  // ends of curved parts (the arm tips of glasses: the other choice leaves an arm as a
  // dead end, collapsed in latitude) but zigzag on stretched triangulations (a 16:1
  // ellipsoid of an icosphere: poles far from the tips); heat-method geodesics fail there too.
  auto euclidean = [&](Eigen::Index from) {
    return Eigen::VectorXd((V.rowwise() - V.row(from)).rowwise().squaredNorm());
  };
  auto edge_paths = [&](Eigen::Index from) {
    Eigen::VectorXd d = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
    using Item = std::pair<double, int>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
    d(from) = 0;
    q.emplace(0.0, int(from));
    while (!q.empty()) {
      const auto [dv, v] = q.top();
      q.pop();
      if (dv > d(v)) continue;
      for (const auto& [j, w] : adj[v]) {
        const double nd = dv + (V.row(v) - V.row(j)).norm();
        if (nd < d(j)) {
          d(j) = nd;
          q.emplace(nd, j);
        }
      }
    }
    for (Eigen::Index i = 0; i < n; ++i)
      if (!std::isfinite(d(i))) d(i) = -1;  // unreachable: never a pole
    return d;
  };
  int best_folded = -1;
  for (const auto& [a, b] : {double_sweep(euclidean), double_sweep(edge_paths)}) {
    if (out.S.rows() == n && std::minmax(a, b) == std::minmax<Eigen::Index>(out.pole_a, out.pole_b))
      continue;  // the same poles (either order) again
    LatitudeLongitudeMap c;
    try {
      c = map_with_poles(V, F, adj, target, a, b);
    } catch (const Error&) {  // a singular system (e.g. a surface that falls apart): no map
      continue;
    }
    if (c.S.rows() != n) continue;
    const int folded = int(m) - positive_origin_cones(c.S, F);
    if (best_folded < 0 || folded < best_folded) {
      best_folded = folded;
      out = std::move(c);
    }
  }
  return out;
}

}  // namespace shapemap
