// Blended Intrinsic Maps (Kim, Lipman, Funkhouser 2011). See bim.h for the pipeline and
// docs/methods.md ("Blended Intrinsic Maps") for every deviation from the paper.
#include "shapemap/surface/bim.h"
#include "shapemap/splitmix.h"
#include "shapemap/timing.h"
#include "shapemap/adjacency.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/geometry/geodesics.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/geometry/sampling.h"
#include "shapemap/surface/shell_energy.h"
#include <Spectra/MatOp/SparseSymMatProd.h>
#include <Spectra/SymEigsSolver.h>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <queue>
#include <unordered_map>

namespace shapemap {

namespace {

// Vertices within geodesic radius r of s along mesh edges (Dijkstra), with distances.
void dijkstra_ball(const std::vector<std::vector<std::pair<int, double>>>& adj, int s, double r,
                   std::vector<double>& dist, std::vector<int>& touched) {
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> pq;
  touched.clear();
  dist[s] = 0;
  touched.push_back(s);
  pq.push({0, s});
  while (!pq.empty()) {
    auto [d, v] = pq.top();
    pq.pop();
    if (d > dist[v]) continue;
    for (auto [u, w] : adj[v]) {
      double nd = d + w;
      if (nd < dist[u] && nd <= r) {
        if (!std::isfinite(dist[u])) touched.push_back(u);
        dist[u] = nd;
        pq.push({nd, u});
      }
    }
  }
}

// AGD local maxima at scale r (Sec. 4), strongest first.
std::vector<int> agd_maxima(const TriMesh& mesh, const Eigen::VectorXd& agd, double r, int max_count) {
  const int n = mesh.num_vertices();
  auto nb = vertex_neighbors(mesh.F, n);
  auto greater = [&](int a, int b) { return agd(a) > agd(b) || (agd(a) == agd(b) && a < b); };
  std::vector<int> cand;
  for (int v = 0; v < n; ++v) {
    bool is_max = true;
    for (int u : nb[v])
      if (greater(u, v)) {
        is_max = false;
        break;
      }
    if (is_max) cand.push_back(v);
  }
  std::vector<std::vector<std::pair<int, double>>> adj(n);
  for (int v = 0; v < n; ++v)
    for (int u : nb[v]) adj[v].push_back({u, (mesh.V.row(u) - mesh.V.row(v)).norm()});
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  std::vector<int> touched, out;
  for (int v : cand) {
    dijkstra_ball(adj, v, r, dist, touched);
    bool is_max = true;
    for (int u : touched)
      if (greater(u, v)) is_max = false;
    for (int u : touched) dist[u] = std::numeric_limits<double>::infinity();
    if (is_max) out.push_back(v);
  }
  std::sort(out.begin(), out.end(), greater);
  if (int(out.size()) > max_count) out.resize(max_count);
  return out;
}

// Interpolation weights from the k samples P_even to all n vertices (Sec. 5): Gaussian in
// the geodesic distance dist (n×k) with width rho, cut at 3 rho, rows normalized; a vertex
// with no sample within 3 rho takes its nearest sample.
Eigen::SparseMatrix<double, Eigen::RowMajor> gaussian_interpolation(const Eigen::MatrixXd& dist, double rho) {
  const int n = int(dist.rows()), k = int(dist.cols());
  std::vector<std::vector<std::pair<int, double>>> rows(n);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < n; ++v) {
    double sum = 0;
    int nearest = 0;
    for (int j = 0; j < k; ++j) {
      double d = dist(v, j);
      if (d < dist(v, nearest)) nearest = j;
      if (d < 3 * rho) {
        double w = std::exp(-d * d / (2 * rho * rho));
        rows[v].push_back({j, w});
        sum += w;
      }
    }
    if (rows[v].empty() || !(sum > 0)) {
      rows[v].assign(1, {nearest, 1.0});
      sum = 1;
    }
    for (auto& e : rows[v]) e.second /= sum;
  }
  std::vector<Eigen::Triplet<double>> trip;
  for (int v = 0; v < n; ++v)
    for (auto& e : rows[v]) trip.emplace_back(v, e.first, e.second);
  Eigen::SparseMatrix<double, Eigen::RowMajor> W(n, k);
  W.setFromTriplets(trip.begin(), trip.end());
  return W;
}

// Greedy nearest-neighbour tour over the samples `even` (vertex ids) from sample 0, by the
// geodesic distances dist (n×k).
std::vector<int> nearest_neighbour_tour(const std::vector<int>& even, const Eigen::MatrixXd& dist) {
  const int k = int(dist.cols());
  std::vector<char> used(k, 0);
  std::vector<int> chain;
  int cur = 0;
  for (int it = 0; it < k; ++it) {
    chain.push_back(cur);
    used[cur] = 1;
    int best = -1;
    for (int j = 0; j < k; ++j)
      if (!used[j] && (best < 0 || dist(even[j], cur) < dist(even[best], cur))) best = j;
    if (best < 0) break;
    cur = best;
  }
  return chain;
}

// Breadth-first order of the n vertices of F (every component, roots in index order) and
// each vertex's BFS parent (-1 at a root).
void breadth_first_order(const Eigen::MatrixXi& F, int n, std::vector<int>& order, std::vector<int>& parent) {
  auto nb = vertex_neighbors(F, n);
  order.clear();
  parent.assign(n, -2);
  for (int root = 0; root < n; ++root) {
    if (parent[root] != -2) continue;
    parent[root] = -1;
    size_t head = order.size();
    order.push_back(root);
    while (head < order.size()) {
      int v = order[head++];
      for (int u : nb[v])
        if (parent[u] == -2) {
          parent[u] = v;
          order.push_back(u);
        }
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------
// P_even (Sec. 5): farthest-point samples from a random vertex, heat geodesics from them; the
// AGD (Sec. 4; each P_even point stands for area 1/k of the unit-area surface) and its maxima,
// the feature points (or the landmarks when given).
void bim_sample_features(const TriMesh& mesh, const BIMOptions& opt, const std::vector<int>& landmarks,
                         std::vector<int>& even, Eigen::MatrixXd& even_dist, Eigen::VectorXd& agd,
                         std::vector<int>& features, Eigen::MatrixXd* feature_dist) {
  const int n = mesh.num_vertices();
  HeatGeodesics geo(mesh.V, mesh.F, opt.heat_t_factor);
  std::uint64_t rs = opt.seed ^ 0x5bd1e995ULL ^ std::uint64_t(n);
  const int first = int(splitmix64(rs) % std::uint64_t(n));
  even = farthest_point_sampling_graph(mesh.V, mesh.F, std::min(opt.num_even, n), first);
  even_dist = geo.distances(even);
  agd = even_dist.rowwise().mean();
  if (!landmarks.empty()) {
    features = landmarks;
    if (bim_landmark_guided(opt, int(landmarks.size()))) {
      // "Landmarks among the feature points": the AGD maxima away from every landmark join them.
      Eigen::MatrixXd dl = geo.distances(landmarks);
      std::vector<int> extra;
      for (int v : agd_maxima(mesh, agd, opt.feature_radius, opt.max_features))
        if (dl.row(v).minCoeff() > opt.feature_radius) extra.push_back(v);
      features.insert(features.end(), extra.begin(), extra.end());
      if (feature_dist) {
        feature_dist->resize(n, features.size());
        feature_dist->leftCols(dl.cols()) = dl;
        if (!extra.empty()) feature_dist->rightCols(extra.size()) = geo.distances(extra);
      }
      return;
    }
  } else {
    features = agd_maxima(mesh, agd, opt.feature_radius, opt.max_features);
    // Too few maxima (nearly symmetric blobs): add spread samples (FPS order).
    for (int v : even) {
      if (int(features.size()) >= opt.min_features) break;
      if (std::find(features.begin(), features.end(), v) == features.end()) features.push_back(v);
    }
  }
  if (feature_dist) *feature_dist = geo.distances(features);
}

// ---------------------------------------------------------------------------------------
BIMSurface bim_prepare(const TriMesh& input, const std::string& name, const BIMOptions& opt,
                       const std::vector<int>& landmarks, const ProgressCallback& progress) {
  BIMSurface s;
  auto t0 = Clock::now();
  TriMesh m = input;
  require_genus0_surface(m, name, opt.min_vertices);
  if (m.num_faces() != input.num_faces() || m.num_vertices() != input.num_vertices())
    throw Error(name + ": the input check changed the mesh size");
  s.V_input = input.V;
  s.F_input = input.F;
  s.normalization = unit_area_normalization(m);
  s.mesh.V = s.normalization.apply(m.V);
  s.mesh.F = m.F;
  const int n = m.num_vertices();
  for (int v : landmarks)
    if (v < 0 || v >= n) throw InputError(name + ": landmark vertex " + std::to_string(v) + " out of range");
  s.mass = lumped_mass(s.mesh.V, s.mesh.F);
  s.mass /= s.mass.sum();
  s.timings.push_back({"checks_normalize", seconds_since(t0)});
  report(progress, "bim/prepare " + name, 0.1);

  t0 = Clock::now();
  bim_sample_features(s.mesh, opt, landmarks, s.even, s.even_dist, s.agd, s.features, &s.feature_dist);
  s.timings.push_back({"sampling_geodesics", seconds_since(t0)});  // and the AGD features
  report(progress, "bim/prepare " + name, 0.5);
  t0 = Clock::now();
  const int k = int(s.even.size());
  // Gaussian interpolation weights from P_even to all vertices (Sec. 5).
  const double rho = opt.interpolation_sigma > 0 ? opt.interpolation_sigma : 1.0 / std::sqrt(double(k));
  s.interp = gaussian_interpolation(s.even_dist, rho);
  // Visiting order of P_even: greedy nearest-neighbour tour (coherent walks).
  s.even_chain = nearest_neighbour_tour(s.even, s.even_dist);
  s.timings.push_back({"features", seconds_since(t0)});
  report(progress, "bim/prepare " + name, 0.6);

  // Conformal flattening (Sec. 4), punctured at a face of the AGD minimum (the middle of
  // the body, away from the features).
  t0 = Clock::now();
  ConformalFlatteningOptions fo;
  {
    int vmin = 0;
    s.agd.minCoeff(&vmin);
    for (int f = 0; f < s.mesh.num_faces() && fo.pole_face < 0; ++f)
      for (int c = 0; c < 3; ++c)
        if (s.mesh.F(f, c) == vmin) fo.pole_face = f;
  }
  s.flat = conformal_flattening(s.mesh.V, s.mesh.F, fo);
  s.hom.resize(n);
  for (int v = 0; v < n; ++v) s.hom[v] = plane_from_sphere(s.flat.sphere.row(v).transpose());
  s.locator = std::make_shared<SphereLocator>(s.flat.sphere, s.mesh.F);
  s.timings.push_back({"flattening", seconds_since(t0)});
  report(progress, "bim/prepare " + name, 0.9);

  t0 = Clock::now();
  s.closest = std::make_shared<ClosestPoint3>(s.mesh.V, s.mesh.F);
  // BFS order (walk starts from the parent's answer).
  breadth_first_order(s.mesh.F, n, s.bfs_order, s.bfs_parent);
  s.timings.push_back({"closest_point_tree", seconds_since(t0)});
  report(progress, "bim/prepare " + name, 1.0);
  return s;
}

// ---------------------------------------------------------------------------------------
namespace {
long long choose3(long long n) { return n < 3 ? 0 : n * (n - 1) * (n - 2) / 6; }

// The r-th triple a < b < c of {0..n-1} in lexicographic order (the order of three nested
// loops), 0 <= r < choose3(n).
std::array<int, 3> unrank_triple(long long r, int n) {
  int a = 0;
  for (;; ++a) {  // triples starting with a: C(n-a-1, 2)
    const long long m = n - a - 1, count = m * (m - 1) / 2;
    if (r < count) break;
    r -= count;
  }
  int b = a + 1;
  for (;; ++b) {  // pairs (b, c) with c > b: n - b - 1
    const long long count = n - b - 1;
    if (r < count) break;
    r -= count;
  }
  return {a, b, int(b + 1 + r)};
}

// Target-surface area factor at a located point.
double located_area_factor(const BIMSurface& dst, const SphereLocator::Location& loc) {
  double mu = 0;
  for (int k = 0; k < 3; ++k) mu += loc.bary(k) * dst.flat.area_factor(dst.mesh.F(loc.face, k));
  return mu;
}

// Eq. 2: c = 2 / (r + 1/r) with r the area ratio.
inline double confidence_from_ratio(double r) {
  if (!(r > 0) || !std::isfinite(r)) return 0.0;
  return 2.0 / (r + 1.0 / r);
}

// Confidence of m at the P_even points of src (into out, in P_even order, when out is not null),
// walking in chain order; returns their sum.
double confidence_at_even(const BIMSurface& src, const BIMSurface& dst, const Mobius& m, double* out) {
  int face = -1;
  double sum = 0;
  for (int j : src.even_chain) {
    const int v = src.even[j];
    Homogeneous w = m(src.hom[v]);
    auto loc = dst.locator->locate(sphere_from_plane(w), face);
    face = loc.face;
    double r = src.flat.area_factor(v) * m.sphere_area_factor(src.hom[v]) / located_area_factor(dst, loc);
    const double c = confidence_from_ratio(r);
    if (out) out[j] = c;
    sum += c;
  }
  return sum;
}

// BIMOptions::candidate_pool: keeps the `keep` candidates of highest mean confidence (Eq. 2 at
// P_even), in their original order (ties to the earlier candidate).
void most_confident(const BIMSurface& src, const BIMSurface& dst, int keep, std::vector<BIMCandidate>& cand) {
  const int n = int(cand.size());
  std::vector<double> score(n);
  #pragma omp parallel for schedule(dynamic, 64)
  for (int i = 0; i < n; ++i)
    score[i] = confidence_at_even(src, dst, cand[i].mobius, nullptr);
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  auto better = [&](int a, int b) { return score[a] > score[b] || (score[a] == score[b] && a < b); };
  std::nth_element(order.begin(), order.begin() + keep, order.end(), better);
  order.resize(keep);
  std::sort(order.begin(), order.end());
  std::vector<BIMCandidate> kept;
  kept.reserve(order.size());
  for (int i : order) kept.push_back(cand[i]);
  cand = std::move(kept);
}

// Sec. 4: the Möbius map taking src's vertices vs to dst's vertices vt (false when the points
// coincide numerically on the sphere: no map).
bool mobius_through(const BIMSurface& src, const BIMSurface& dst, const std::array<int, 3>& vs,
                    const std::array<int, 3>& vt, Mobius& m) {
  Homogeneous z[3], w[3];
  for (int k = 0; k < 3; ++k) {
    z[k] = src.hom[vs[k]];
    w[k] = dst.hom[vt[k]];
  }
  try {
    m = Mobius::from_three_points(z, w);
  } catch (const Error&) {
    return false;
  }
  return true;
}

// Sec. 4: the Möbius map of a candidate's three correspondences.
bool candidate_mobius(const BIMSurface& src, const BIMSurface& dst, BIMCandidate& cd) {
  std::array<int, 3> vs, vt;
  for (int k = 0; k < 3; ++k) {
    vs[k] = src.features[cd.source[k]];
    vt[k] = dst.features[cd.target[k]];
  }
  return mobius_through(src, dst, vs, vt, cd.mobius);
}

// Triples of "Landmarks among the feature points" that are not landmark triples: a triple
// with k landmarks (k = 0, 1, 2) and 3 - k AGD maxima, matched to the k partners and to an
// ordered choice of 3 - k distinct target maxima; m1, m2 the maxima on each side.
long long mixed_triples(long long L, long long m1, long long m2) {
  auto c = [](long long n, int r) { return r == 0 ? 1 : r == 1 ? n : r == 2 ? n * (n - 1) / 2 : choose3(n); };
  auto p = [](long long n, int r) { return r == 0 ? 1 : r == 1 ? n : r == 2 ? n * (n - 1) : n * (n - 1) * (n - 2); };
  long long sum = 0;
  for (int k = 0; k < 3; ++k) sum += c(L, k) * c(m1, 3 - k) * std::max(0LL, p(m2, 3 - k));
  return sum;
}

// The largest geodesic distance (unit-area target) from a landmark's image under m to its
// partner; features 0..L-1 are the landmarks on both surfaces. Stops above `limit`.
double landmark_disagreement(const BIMSurface& src, const BIMSurface& dst, const Mobius& m, int L, double limit) {
  double worst = 0;
  for (int k = 0; k < L && worst <= limit; ++k) {
    auto loc = dst.locator->locate(sphere_from_plane(m(src.hom[src.features[k]])));
    double d = 0;
    for (int j = 0; j < 3; ++j) d += loc.bary(j) * dst.feature_dist(dst.mesh.F(loc.face, j), k);
    worst = std::max(worst, d);
  }
  return worst;
}

// "Landmarks among the feature points" (BIMOptions::landmark_feature_points): every source
// triple, its landmarks sent to their partners and its AGD maxima to every ordered choice of
// distinct target maxima; the landmark triples kept, the others when they agree with every
// landmark; the most confident max_candidates of them.
std::vector<BIMCandidate> guided_candidates(const BIMSurface& src, const BIMSurface& dst, const BIMOptions& opt,
                                            long long* total) {
  const int L = int(opt.landmarks_A.size()), n1 = int(src.features.size()), n2 = int(dst.features.size());
  std::vector<BIMCandidate> all;
  for (long long r = 0; r < choose3(n1); ++r) {
    BIMCandidate cd;
    cd.source = unrank_triple(r, n1);
    std::vector<int> open;  // slots holding a source AGD maximum
    for (int k = 0; k < 3; ++k) {
      if (cd.source[k] < L) cd.target[k] = cd.source[k];
      else open.push_back(k);
    }
    // Ordered distinct target maxima for the open slots (nested loops, at most three deep).
    std::function<void(size_t)> fill = [&](size_t i) {
      if (i == open.size()) return all.push_back(cd);
      for (int t = L; t < n2; ++t) {
        bool used = false;
        for (size_t j = 0; j < i; ++j) used |= cd.target[open[j]] == t;
        if (used) continue;
        cd.target[open[i]] = t;
        fill(i + 1);
      }
    };
    fill(0);
  }
  if (total) *total = (long long)all.size();
  std::vector<char> keep(all.size(), 0);
#pragma omp parallel for schedule(dynamic, 256)
  for (long long i = 0; i < (long long)all.size(); ++i) {
    BIMCandidate& cd = all[i];
    if (!candidate_mobius(src, dst, cd)) continue;
    const bool landmark_triple = cd.source[0] < L && cd.source[1] < L && cd.source[2] < L;
    keep[i] = landmark_triple ||
              landmark_disagreement(src, dst, cd.mobius, L, opt.landmark_agreement) <= opt.landmark_agreement;
  }
  std::vector<BIMCandidate> valid;
  for (size_t i = 0; i < all.size(); ++i)
    if (keep[i]) valid.push_back(all[i]);
  if (opt.max_candidates > 0 && int(valid.size()) > opt.max_candidates)
    most_confident(src, dst, opt.max_candidates, valid);
  return valid;
}
}  // namespace

bool bim_landmark_guided(const BIMOptions& opt, int num_landmarks) {
  return num_landmarks >= 3 && opt.landmark_feature_points;
}

std::vector<BIMCandidate> bim_candidates(const BIMSurface& src, const BIMSurface& dst,
                                         const BIMOptions& opt, long long* total) {
  const bool fixed = !opt.landmarks_A.empty();
  if (fixed && bim_landmark_guided(opt, int(opt.landmarks_A.size()))) return guided_candidates(src, dst, opt, total);
  // With landmarks they are the first features (any after them are unused here).
  const int n1 = int(fixed ? opt.landmarks_A.size() : src.features.size());
  const int n2 = int(fixed ? opt.landmarks_B.size() : dst.features.size());
  if (fixed && (n1 != n2 || int(src.features.size()) < n1 || int(dst.features.size()) < n2))
    throw InputError("landmarks: the two lists have different lengths");
  // Candidate i in the order of the nested loops: with landmarks, the i-th triple of
  // corresponding landmarks; else (i / 6) = rank of the source triple * C(n2, 3) + rank of the
  // target triple, and i % 6 the permutation of the target triple.
  static const int perms[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  const long long T1 = choose3(n1), T2 = choose3(n2);
  const long long N = fixed ? T1 : T1 * T2 * 6;  // at most ~1e18 for the feature counts used
  auto candidate = [&](long long i) {
    BIMCandidate cd;
    if (fixed) {
      cd.source = cd.target = unrank_triple(i, n1);
    } else {
      const int* p = perms[i % 6];
      const long long q = i / 6;
      cd.source = unrank_triple(q / T2, n1);
      const std::array<int, 3> t = unrank_triple(q % T2, n2);
      cd.target = {t[p[0]], t[p[1]], t[p[2]]};
    }
    return cd;
  };
  if (total) *total = N;
  // Landmark triples are all correct correspondences: Sec. 6.2's random removal alone.
  const bool ranked = !fixed && opt.max_candidates > 0 && opt.candidate_pool > opt.max_candidates;
  const int keep = ranked ? opt.candidate_pool : opt.max_candidates;
  std::vector<BIMCandidate> all;
  if (keep > 0 && N > keep) {
    // Sec. 6.2: random removal down to `keep` (seeded, order kept): a partial
    // Fisher-Yates shuffle of the indices 0..N-1 with the swaps kept in a map, so the
    // candidates are never all built (C(k,3) landmark triples grow fast: 642 landmarks are
    // 44 million).
    std::unordered_map<long long, long long> swapped;
    auto at = [&](long long i) {
      auto it = swapped.find(i);
      return it == swapped.end() ? i : it->second;
    };
    std::vector<long long> idx(keep);
    std::uint64_t rs = opt.seed * 0x2545F4914F6CDD1DULL + 17;
    for (int i = 0; i < keep; ++i) {
      const long long j = i + (long long)(splitmix64(rs) % std::uint64_t(N - i));
      const long long vi = at(i), vj = at(j);
      swapped[j] = vi;
      idx[i] = vj;
    }
    std::sort(idx.begin(), idx.end());
    all.reserve(idx.size());
    for (long long i : idx) all.push_back(candidate(i));
  } else {
    all.reserve(size_t(N));
    for (long long i = 0; i < N; ++i) all.push_back(candidate(i));
  }
  std::vector<BIMCandidate> valid;
  valid.reserve(all.size());
  for (auto& cd : all)
    if (candidate_mobius(src, dst, cd)) valid.push_back(cd);
  if (ranked && int(valid.size()) > opt.max_candidates) most_confident(src, dst, opt.max_candidates, valid);
  return valid;
}

// ---------------------------------------------------------------------------------------
namespace {

// Per-vertex confidence of a map given by mapped positions X (n×3) of the source mesh:
// Eq. 2 with N_p the one-ring.
Eigen::VectorXd map_confidence(const TriMesh& src, const Eigen::MatrixXd& X) {
  Eigen::VectorXd a0 = triangle_areas(src.V, src.F), a1 = triangle_areas(X, src.F);
  Eigen::VectorXd s0 = Eigen::VectorXd::Zero(src.num_vertices()), s1 = s0;
  for (int f = 0; f < src.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      s0(src.F(f, k)) += a0(f);
      s1(src.F(f, k)) += a1(f);
    }
  Eigen::VectorXd c(src.num_vertices());
  for (int v = 0; v < src.num_vertices(); ++v) c(v) = s0(v) > 0 ? confidence_from_ratio(s1(v) / s0(v)) : 0.0;
  return c;
}

// Bary coordinates w.r.t. the oriented face -> w.r.t. the input face (same vertices).
void to_input_faces(const Eigen::MatrixXi& Fo, const Eigen::MatrixXi& Fi, BarycentricMap& map) {
  for (int i = 0; i < map.size(); ++i) {
    int f = map.elem(i);
    Eigen::RowVector3d b = map.bary.row(i), out = Eigen::RowVector3d::Zero();
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j)
        if (Fi(f, j) == Fo(f, k)) out(j) = b(k);
    map.bary.row(i) = out;
  }
}

}  // namespace

Eigen::MatrixXd bim_apply(const BIMSurface& src, const BIMSurface& dst, const Mobius& m,
                          Eigen::VectorXi* face_out, Eigen::MatrixXd* bary_out) {
  const int n = src.mesh.num_vertices();
  Eigen::MatrixXd P(n, 3);
  std::vector<int> face(n, -1);
  if (face_out) face_out->resize(n);
  if (bary_out) bary_out->resize(n, 3);
  for (int v : src.bfs_order) {
    int start = src.bfs_parent[v] >= 0 ? face[src.bfs_parent[v]] : -1;
    auto loc = dst.locator->locate(sphere_from_plane(m(src.hom[v])), start);
    face[v] = loc.face;
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int k = 0; k < 3; ++k) p += loc.bary(k) * dst.mesh.V.row(dst.mesh.F(loc.face, k));
    P.row(v) = p;
    if (face_out) (*face_out)(v) = loc.face;
    if (bary_out) bary_out->row(v) = loc.bary.transpose();
  }
  return P;
}

Eigen::VectorXd bim_confidence(const BIMSurface& src, const BIMSurface& dst, const Mobius& m) {
  Eigen::VectorXd c(src.even.size());
  confidence_at_even(src, dst, m, c.data());
  return c;
}

// With implied_radius > 0, a target feature claimed by two source features goes to the nearer,
// and never against the generating triple.
std::vector<std::pair<int, int>> bim_correspondences(const BIMSurface& src, const BIMSurface& dst,
                                                     const BIMCandidate& c, const BIMOptions& opt) {
  std::vector<std::pair<int, int>> out;
  for (int k = 0; k < 3; ++k) out.push_back({c.source[k], c.target[k]});
  if (!(opt.implied_radius > 0)) return out;
  const int n1 = int(src.features.size()), n2 = int(dst.features.size());
  if (dst.feature_dist.rows() != dst.mesh.num_vertices() || dst.feature_dist.cols() != n2)
    throw Error("BIM: the target surface has no feature distances (bim_prepare computes them)");
  std::vector<double> claim(n2, opt.implied_radius);  // distance of the nearest claim so far
  std::vector<int> by(n2, -1);
  for (int k = 0; k < 3; ++k) claim[c.target[k]] = -1;  // taken by the triple
  for (int a = 0; a < n1; ++a) {
    if (a == c.source[0] || a == c.source[1] || a == c.source[2]) continue;
    auto loc = dst.locator->locate(sphere_from_plane(c.mobius(src.hom[src.features[a]])));
    int best = -1;
    double best_d = 0;
    for (int b = 0; b < n2; ++b) {
      double d = 0;
      for (int k = 0; k < 3; ++k) d += loc.bary(k) * dst.feature_dist(dst.mesh.F(loc.face, k), b);
      if (best < 0 || d < best_d) best = b, best_d = d;
    }
    if (best >= 0 && best_d < claim[best]) claim[best] = best_d, by[best] = a;
  }
  for (int b = 0; b < n2; ++b)
    if (by[b] >= 0) out.push_back({by[b], b});
  return out;
}

bool bim_correspondences_conflict(const std::vector<std::pair<int, int>>& x,
                                  const std::vector<std::pair<int, int>>& y) {
  for (const auto& [a, b] : x)
    for (const auto& [c, d] : y)
      if ((a == c) != (b == d)) return true;
  return false;
}

// ---------------------------------------------------------------------------------------
namespace {

// One direction of BIM (src -> dst), a method per stage of the paper; the stages share the
// candidates, their confidences, the blending matrix and the groups.
struct BimDirection {
  const BIMSurface& src;
  const BIMSurface& dst;
  const BIMOptions& opt;
  const ProgressCallback& progress;
  const int ne;  // |P_even|
  BIMDirectionResult R;
  std::vector<BIMCandidate> cand;
  int K = 0;  // candidates
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> C;  // K x ne confidences
  Eigen::VectorXd cand_conf;                                                 // mean of each row of C
  Eigen::SparseMatrix<double> S;                                             // K x K blending matrix
  std::vector<std::vector<int>> groups;

  BimDirection(const BIMSurface& s, const BIMSurface& d, const BIMOptions& o, const ProgressCallback& p)
      : src(s), dst(d), opt(o), progress(p), ne(int(s.even.size())) {}

  // Sec. 4: the candidate Mobius maps from triplets of feature correspondences.
  void candidates() {
    // Sec. 4: candidates.
    auto t0 = Clock::now();
    cand = bim_candidates(src, dst, opt, &R.num_candidates_total);
    K = int(cand.size());
    R.num_candidates = K;
    if (K == 0)
      throw NoCandidateMaps("BIM: no candidate map: every triplet of the " + std::to_string(src.features.size()) +
                            " / " + std::to_string(dst.features.size()) +
                            " feature points coincides numerically on the flattened sphere");
    R.timings.push_back({"candidates", seconds_since(t0)});
  }

  // Sec. 5: each candidate's confidence at P_even (C, K x ne).
  void confidence() {
    // Sec. 5: confidence at P_even, K × ne (row per map).
    auto t0 = Clock::now();
    C.resize(K, ne);
    {
      int done = 0;
  #pragma omp parallel for schedule(dynamic, 16)
      for (int i = 0; i < K; ++i) {
        confidence_at_even(src, dst, cand[i].mobius, C.row(i).data());
        int d;
  #pragma omp atomic capture
        d = ++done;
        if ((d & 255) == 0) report(progress, "bim/confidence", double(d) / K);
      }
    }
    report(progress, "bim/confidence", 1.0);
    cand_conf = C.rowwise().mean();
    R.best_candidate_confidence = cand_conf.maxCoeff();
    R.timings.push_back({"confidence", seconds_since(t0)});
  }

  // Sec. 6.2: the blending matrix S over pairs of candidates sharing two correspondences.
  void consistency_matrix() {
    // Sec. 6.2: blending matrix over pairs sharing two correspondences, no conflicts.
    auto t0 = Clock::now();
    const long long n2 = (long long)dst.features.size();
    auto corr_key = [&](int i, int k) { return (long long)cand[i].source[k] * n2 + cand[i].target[k]; };
    std::vector<std::pair<long long, int>> keyed;  // (pair-of-correspondences key, map)
    keyed.reserve(size_t(3) * K);
    const long long nc = (long long)src.features.size() * n2;
    for (int i = 0; i < K; ++i)
      for (int a = 0; a < 3; ++a)
        for (int b = a + 1; b < 3; ++b) {
          long long ka = corr_key(i, a), kb = corr_key(i, b);
          if (ka > kb) std::swap(ka, kb);
          keyed.push_back({ka * nc + kb, i});
        }
    std::sort(keyed.begin(), keyed.end());
    std::vector<std::pair<int, int>> pairs;
    auto third = [&](int i, long long key) {
      long long ka = key / nc, kb = key % nc;
      for (int k = 0; k < 3; ++k) {
        long long c = corr_key(i, k);
        if (c != ka && c != kb) return std::make_pair(cand[i].source[k], cand[i].target[k]);
      }
      return std::make_pair(-1, -1);
    };
    for (size_t s = 0; s < keyed.size();) {
      size_t e = s;
      while (e < keyed.size() && keyed[e].first == keyed[s].first) ++e;
      for (size_t x = s; x < e; ++x)
        for (size_t y = x + 1; y < e; ++y) {
          int i = keyed[x].second, j = keyed[y].second;
          auto ci = third(i, keyed[s].first), cj = third(j, keyed[s].first);
          bool conflict = (ci.first == cj.first) != (ci.second == cj.second);
          if (!conflict) pairs.push_back({std::min(i, j), std::max(i, j)});
        }
      s = e;
    }
    R.num_consistent_pairs = (long long)pairs.size();
    std::vector<double> pair_val(pairs.size(), 0.0);
    const double inv_s2 = 1.0 / (opt.sigma * opt.sigma);
    {
      long long done = 0;
      const long long np = (long long)pairs.size();
  #pragma omp parallel for schedule(dynamic, 64)
      for (long long q = 0; q < np; ++q) {
        int i = pairs[q].first, j = pairs[q].second;
        Mobius Mij = cand[j].mobius.inverse() * cand[i].mobius;  // m_j^{-1} ∘ m_i (source plane)
        Mobius Mji = cand[i].mobius.inverse() * cand[j].mobius;
        double sum = 0;
        for (int sidx = 0; sidx < ne; ++sidx) {
          double w = C(i, sidx) * C(j, sidx);
          if (w < opt.consistency_skip) continue;
          int v = src.even[sidx];
          double sij = 0;
          int passes = opt.symmetrize_consistency ? 2 : 1;
          for (int pass = 0; pass < passes; ++pass) {
            const Mobius& M = pass == 0 ? Mij : Mji;
            auto loc = src.locator->locate(sphere_from_plane(M(src.hom[v])), src.locator->vertex_face(v));
            double d = 0;
            for (int k = 0; k < 3; ++k) d += loc.bary(k) * src.even_dist(src.mesh.F(loc.face, k), sidx);
            sij += std::exp(-std::max(d, 0.0) * inv_s2);  // Eq. 5
          }
          sum += w * sij / passes;
        }
        pair_val[q] = sum / ne;  // A_i = area/256 (Sec. 6.2)
        long long d;
  #pragma omp atomic capture
        d = ++done;
        if ((d & 1023) == 0) report(progress, "bim/consistency", double(d) / np);
      }
    }
    report(progress, "bim/consistency", 1.0);
    S.resize(K, K);
    {
      std::vector<Eigen::Triplet<double>> trip;
      trip.reserve(K + 2 * pairs.size());
      for (int i = 0; i < K; ++i) trip.emplace_back(i, i, C.row(i).squaredNorm() / ne);
      for (size_t q = 0; q < pairs.size(); ++q) {
        if (pair_val[q] == 0) continue;
        trip.emplace_back(pairs[q].first, pairs[q].second, pair_val[q]);
        trip.emplace_back(pairs[q].second, pairs[q].first, pair_val[q]);
      }
      S.setFromTriplets(trip.begin(), trip.end());
    }
    R.timings.push_back({"consistency_matrix", seconds_since(t0)});
  }

  // Sec. 6.2: top eigenvectors of S and the consistent groups they give.
  void eigenvector_groups() {
    // Top eigenvectors (Spectra; dense for small K).
    auto t0 = Clock::now();
    std::vector<double> evals;
    std::vector<Eigen::VectorXd> evecs;
    const int nev = std::max(1, std::min(opt.num_eigenvectors, K - 1));
    if (K <= 400) {
      Eigen::MatrixXd Sd = Eigen::MatrixXd(S);
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Sd);
      for (int e = 0; e < std::min(nev, K); ++e) {
        evals.push_back(es.eigenvalues()(K - 1 - e));
        evecs.push_back(es.eigenvectors().col(K - 1 - e));
      }
    } else {
      Spectra::SparseSymMatProd<double> op(S);
      int ncv = std::min(K, std::max(2 * nev + 1, 24));
      Spectra::SymEigsSolver<Spectra::SparseSymMatProd<double>> es(op, nev, ncv);
      es.init();
      es.compute(Spectra::SortRule::LargestAlge, 1000, 1e-10);
      if (es.info() != Spectra::CompInfo::Successful) throw Error("BIM: eigen-solver did not converge");
      Eigen::VectorXd ev = es.eigenvalues();
      Eigen::MatrixXd V = es.eigenvectors();
      for (int e = 0; e < int(ev.size()); ++e) {
        evals.push_back(ev(e));
        evecs.push_back(V.col(e));
      }
    }
    R.eigenvalues = evals;
    // Sec. 6.2: eigenvalues within the fraction of the top one; consistent groups.
    std::vector<char> assigned(K, 0);
    std::vector<std::vector<std::pair<int, int>>> corr(K);  // filled for the maps considered
    auto consistent = [&](int i, const std::vector<int>& g) {
      for (int j : g)
        if (bim_correspondences_conflict(corr[i], corr[j])) return false;
      return true;
    };
    R.num_eigenvectors_used = 0;
    for (size_t e = 0; e < evecs.size(); ++e) {
      if (evals[e] < opt.eigenvalue_fraction * evals[0]) break;
      ++R.num_eigenvectors_used;
      const Eigen::VectorXd& w = evecs[e];
      std::vector<int> order(K);
      std::iota(order.begin(), order.end(), 0);
      std::stable_sort(order.begin(), order.end(),
                       [&](int a, int b) { return std::abs(w(a)) > std::abs(w(b)); });
      double wmax = std::abs(w(order[0]));
      for (int i : order) {
        if (std::abs(w(i)) < opt.entry_fraction * wmax) break;
        if (assigned[i]) continue;
        assigned[i] = 1;
        corr[i] = bim_correspondences(src, dst, cand[i], opt);
        bool placed = false;
        for (auto& g : groups)
          if (consistent(i, g)) {
            g.push_back(i);
            placed = true;
            break;
          }
        if (!placed) groups.push_back({i});
      }
    }
    if (groups.empty()) {  // degenerate spectrum: the most confident map alone
      int best = 0;
      cand_conf.maxCoeff(&best);
      groups.push_back({best});
    }
    // Larger groups first (Fig. 3 orders blocks by size); keep the first max_groups.
    std::stable_sort(groups.begin(), groups.end(),
                     [](const std::vector<int>& a, const std::vector<int>& b) { return a.size() > b.size(); });
    if (opt.max_groups > 0 && int(groups.size()) > opt.max_groups) groups.resize(opt.max_groups);
    R.timings.push_back({"eigenvectors_groups", seconds_since(t0)});
  }

  // Sec. 7: the blend of the maps G (binary weights): the confidence-weighted centroid of
  // their images P[a] (bim_apply of G[a]), moved to its closest point on the target, with
  // its integrated confidence (Sec. 6.2), the criterion blends are compared by. hints: a
  // previous blend's closest points, to start the queries from.
  struct Blended {
    std::vector<ClosestPointResult> cp;
    Eigen::VectorXd conf;
    double ic = -1;
  };
  Blended blend_maps(const std::vector<int>& G, const std::vector<const Eigen::MatrixXd*>& P,
                     const std::vector<ClosestPointResult>* hints = nullptr) const {
    const int n = src.mesh.num_vertices();
    const int ng = int(G.size());
    Eigen::MatrixXd Ceven(ne, ng);
    for (int a = 0; a < ng; ++a) Ceven.col(a) = C.row(G[a]).transpose();
    Eigen::MatrixXd Cv = src.interp * Ceven;  // n × ng, b_i(p) = c_i(p) w_i, w binary
    Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, 3);
    Eigen::VectorXd wsum = Eigen::VectorXd::Zero(n);
    for (int a = 0; a < ng; ++a) {
      X += Cv.col(a).asDiagonal() * *P[a];
      wsum += Cv.col(a);
    }
    for (int v = 0; v < n; ++v) {
      if (wsum(v) > 1e-12) {
        X.row(v) /= wsum(v);
      } else {
        Eigen::RowVector3d m = Eigen::RowVector3d::Zero();
        for (int a = 0; a < ng; ++a) m += P[a]->row(v);
        X.row(v) = m / ng;
      }
    }
    // Closest point on the target to the weighted Euclidean centroid.
    Blended b;
    if (hints) b.cp = *hints;
    dst.closest->query(X, b.cp, hints != nullptr);
    for (int v = 0; v < n; ++v) {
      Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
      for (int k = 0; k < 3; ++k) p += b.cp[v].bary(k) * dst.mesh.V.row(dst.mesh.F(b.cp[v].elem, k));
      X.row(v) = p;
    }
    b.conf = map_confidence(src.mesh, X);
    b.ic = b.conf.dot(src.mass);  // ∫ c_f dA on the unit-area source
    return b;
  }

  // The images of the candidates G at every source vertex, in parallel.
  std::vector<Eigen::MatrixXd> images_of(const std::vector<int>& G) const {
    std::vector<Eigen::MatrixXd> P(G.size());
#pragma omp parallel for schedule(dynamic, 1)
    for (int a = 0; a < int(G.size()); ++a) P[a] = bim_apply(src, dst, cand[G[a]].mobius);
    return P;
  }

  // Sec. 7: each group's blended map; the one with the best integrated confidence is R.map
  // (after the matching search, when it finds a better one).
  void blend() {
    auto t0 = Clock::now();
    Blended best;
    for (size_t g = 0; g < groups.size(); ++g) {
      std::vector<Eigen::MatrixXd> P = images_of(groups[g]);
      std::vector<const Eigen::MatrixXd*> ptr;
      for (const auto& m : P) ptr.push_back(&m);
      Blended b = blend_maps(groups[g], ptr);
      R.group_confidence.push_back(b.ic);
      R.group_sizes.push_back(int(groups[g].size()));
      if (b.ic > best.ic) {
        R.selected_group = int(g);
        best = std::move(b);
      }
      report(progress, "bim/blend", double(g + 1) / groups.size());
    }
    std::vector<int> selected = groups[R.selected_group];
    R.timings.push_back({"blend", seconds_since(t0)});
    if (opt.matching_search_sweeps > 0 && opt.landmarks_A.empty()) search_matching(best, selected);
    output(best, selected);
  }

  // The feature matching the maps G stand for (source feature -> target feature, -1: none).
  // A group's maps never conflict (Sec. 6.2), so their generating pairs form one matching.
  std::vector<int> matching_of(const std::vector<int>& G) const {
    std::vector<int> M(src.features.size(), -1);
    for (int i : G)
      for (int k = 0; k < 3; ++k) M[cand[i].source[k]] = cand[i].target[k];
    return M;
  }

  // Every candidate whose three generating correspondences are in the matching M.
  std::vector<int> maps_within(const std::vector<int>& M) const {
    std::vector<int> G;
    for (int i = 0; i < K; ++i)
      if (M[cand[i].source[0]] == cand[i].target[0] && M[cand[i].source[1]] == cand[i].target[1] &&
          M[cand[i].source[2]] == cand[i].target[2])
        G.push_back(i);
    return G;
  }

  // The matchings one change away from M: a source feature given another target feature
  // (taken from its owner) or none, or two source features swapping their targets.
  std::vector<std::vector<int>> matching_moves(const std::vector<int>& M) const {
    const int n1 = int(M.size()), n2 = int(dst.features.size());
    std::vector<std::vector<int>> moves;
    for (int s = 0; s < n1; ++s) {
      for (int t = -1; t < n2; ++t) {
        if (t == M[s]) continue;
        std::vector<int> Mt = M;
        for (int& x : Mt)
          if (t >= 0 && x == t) x = -1;
        Mt[s] = t;
        moves.push_back(std::move(Mt));
      }
      for (int u = s + 1; u < n1; ++u)
        if (M[s] >= 0 && M[u] >= 0) {
          std::vector<int> Mt = M;
          std::swap(Mt[s], Mt[u]);
          moves.push_back(std::move(Mt));
        }
    }
    return moves;
  }

  // Our addition (docs/methods.md, "The matching search"): Sec. 6.2's greedy grouping can
  // split the correct matching between groups when wrong maps agree with part of it on the
  // sphere (camel-gallop 08 -> 09: the tail and a hip go with one group, the hind feet with
  // another). Starting from the selected group's matching, change one correspondence at a
  // time (a source feature to another target feature or to none, or two source features
  // swapping their targets, as in Fig. 14's limb swaps) and keep the change that most raises
  // the integrated confidence of the blend of every candidate within the matching, until
  // none does. The result replaces the selected group only when its blend is better.
  void search_matching(Blended& best, std::vector<int>& selected) {
    auto t0 = Clock::now();
    std::vector<int> M = matching_of(selected);
    std::vector<int> G = maps_within(M);
    std::unordered_map<int, Eigen::MatrixXd> image;  // the maps within M
    // The blend of the maps Gt (maps_within a matching); keep_images: Gt is the new M's.
    auto evaluate = [&](const std::vector<int>& Gt, bool keep_images) {
      if (Gt.empty()) return Blended{};
      std::vector<int> missing;
      for (int i : Gt)
        if (!image.count(i)) missing.push_back(i);
      std::vector<Eigen::MatrixXd> fresh = images_of(missing);
      std::vector<const Eigen::MatrixXd*> ptr;
      for (size_t a = 0, f = 0; a < Gt.size(); ++a)
        ptr.push_back(image.count(Gt[a]) ? &image.at(Gt[a]) : &fresh[f++]);
      Blended b = blend_maps(Gt, ptr, &best.cp);
      if (keep_images) {
        std::unordered_map<int, Eigen::MatrixXd> kept;
        for (size_t a = 0, f = 0; a < Gt.size(); ++a)
          kept[Gt[a]] = image.count(Gt[a]) ? std::move(image.at(Gt[a])) : std::move(fresh[f++]);
        image = std::move(kept);
      }
      return b;
    };
    Blended cur = evaluate(G, true);
    R.matching_search.start_confidence = cur.ic;
    for (int sweep = 0; sweep < opt.matching_search_sweeps; ++sweep) {
      std::vector<std::vector<int>> moves = matching_moves(M);
      // The sweep's work: the images it must compute and one projection per blend. It is
      // not started when it would take the search past its budget (many features).
      long long work = 0;
      std::vector<std::vector<int>> within(moves.size());  // each move's maps
      for (size_t m = 0; m < moves.size(); ++m) {
        within[m] = maps_within(moves[m]);
        ++work;
        for (int i : within[m]) work += !image.count(i);
      }
      if (R.matching_search.work + work > opt.matching_search_max_work) {
        R.matching_search.over_budget = true;
        break;
      }
      R.matching_search.work += work;
      int pick = -1;
      double pick_ic = cur.ic + opt.matching_search_min_gain;
      for (size_t m = 0; m < moves.size(); ++m) {
        Blended b = evaluate(within[m], false);
        ++R.matching_search.evaluations;
        if (b.ic > pick_ic) pick = int(m), pick_ic = b.ic;
      }
      report(progress, "bim/matching_search", double(sweep + 1) / opt.matching_search_sweeps);
      if (pick < 0) break;
      M = moves[pick];
      G = within[pick];
      cur = evaluate(G, true);
      ++R.matching_search.changes;
    }
    R.matching_search.ran = true;
    R.matching_search.final_confidence = cur.ic;
    if (cur.ic > best.ic) {
      R.matching_search.kept = true;
      best = std::move(cur);
      selected = G;
    }
    R.timings.push_back({"matching_search", seconds_since(t0)});
  }

  BIMMapInfo map_info(int i) const {
    BIMMapInfo info;
    info.index = i;
    for (int k = 0; k < 3; ++k) {
      info.source[k] = src.features[cand[i].source[k]];
      info.target[k] = dst.features[cand[i].target[k]];
    }
    info.integrated_confidence = cand_conf(i);
    return info;
  }

  // R's map, confidences and selected maps from the chosen blend of the maps G.
  void output(const Blended& best, const std::vector<int>& G) {
    const int n = src.mesh.num_vertices();
    R.integrated_confidence = best.ic;
    R.confidence = best.conf;
    for (int i : G) R.selected.push_back(map_info(i));
    for (const auto& g : groups) R.group_leads.push_back(map_info(g.front()));
    R.map.elem.resize(n);
    R.map.bary.resize(n, 3);
    for (int v = 0; v < n; ++v) {
      R.map.elem(v) = best.cp[v].elem;
      Eigen::Vector3d b = best.cp[v].bary.head<3>().cwiseMax(0.0);
      R.map.bary.row(v) = (b / b.sum()).transpose();
    }
    to_input_faces(dst.mesh.F, dst.F_input, R.map);
    R.positions = map_positions(R.map, dst.V_input, dst.F_input);
  }
};

}  // namespace

BIMDirectionResult bim_map(const BIMSurface& src, const BIMSurface& dst, const BIMOptions& opt,
                           const ProgressCallback& progress) {
  BimDirection d(src, dst, opt, progress);
  d.candidates();
  d.confidence();
  d.consistency_matrix();
  d.eigenvector_groups();
  d.blend();
  return std::move(d.R);
}

// ---------------------------------------------------------------------------------------
// BIMOptions::reverse_candidates: R (src -> dst) becomes the inverse of Rrev (dst -> src),
// which locates each source vertex on dst's triangulation placed at its images under Rrev
// (closest point), as the elastic CLI derives Q from P.
namespace {
void take_inverse(const BIMSurface& src, const BIMSurface& dst, const BIMDirectionResult& Rrev,
                  BIMDirectionResult& R) {
  const Eigen::MatrixXd Y = map_positions(Rrev.map, src.mesh.V, src.F_input);  // dst vertices on src
  ClosestPoint3 bvh(Y, dst.F_input);
  const std::vector<ClosestPointResult> cp = bvh.query(src.mesh.V);
  const int n = src.mesh.num_vertices();
  BarycentricMap inv;
  inv.elem.resize(n);
  inv.bary.resize(n, 3);
  for (int v = 0; v < n; ++v) {
    inv.elem(v) = cp[v].elem;
    const Eigen::Vector3d b = cp[v].bary.head<3>().cwiseMax(0.0);
    inv.bary.row(v) = b.sum() > 0 ? Eigen::RowVector3d((b / b.sum()).transpose()) : Eigen::RowVector3d(1, 0, 0);
  }
  R.own_integrated_confidence = R.integrated_confidence;
  R.confidence = map_confidence(src.mesh, map_positions(inv, dst.mesh.V, dst.F_input));
  R.integrated_confidence = R.confidence.dot(src.mass);
  R.map = inv;
  R.positions = map_positions(inv, dst.V_input, dst.F_input);
  R.from_reverse = true;
}
}  // namespace

namespace {
// "Landmarks among the feature points": a triple that is not a landmark triple needs an added AGD
// maximum on each surface. When one surface has none, the other's go too, so that they do not
// change the landmark triples' groups through the implied correspondences (L: the landmarks).
// They go too when the maxima found would give more mixed triples than landmark_mixed_max (the
// count of maxima actually found decides, not max_features).
void keep_added_features_if_both(BIMSurface& a, BIMSurface& b, int L, long long mixed_max) {
  const long long ma = (long long)a.features.size() - L, mb = (long long)b.features.size() - L;
  if (L == 0 || (ma > 0 && mb > 0 && mixed_triples(L, ma, mb) <= mixed_max)) return;
  for (BIMSurface* s : {&a, &b}) {
    s->features.resize(L);
    s->feature_dist.conservativeResize(Eigen::NoChange, L);
  }
}
}  // namespace

BIMResult blended_intrinsic_maps(const TriMesh& A, const TriMesh& B, const BIMOptions& opt,
                                 const ProgressCallback& progress) {
  auto t0 = Clock::now();
  if (opt.landmarks_A.size() != opt.landmarks_B.size())
    throw InputError("landmarks: the two lists have different lengths (" +
                     std::to_string(opt.landmarks_A.size()) + " and " +
                     std::to_string(opt.landmarks_B.size()) + ")");
  if (!opt.landmarks_A.empty() && opt.landmarks_A.size() < 3)
    throw InputError("landmarks: at least 3 correspondences are needed");
  BIMOptions o = opt;
  std::uint64_t rs = opt.seed;
  for (int attempt = 0;; ++attempt) {
    try {
      BIMSurface sa = bim_prepare(A, o.name_A, o, o.landmarks_A, progress);
      BIMSurface sb = bim_prepare(B, o.name_B, o, o.landmarks_B, progress);
      keep_added_features_if_both(sa, sb, int(o.landmarks_A.size()), o.landmark_mixed_max);
      BIMResult out = bim_prepared(sa, sb, o, progress, true);
      out.seed = o.seed;
      out.seed_retries = attempt;
      out.total_seconds = seconds_since(t0);
      return out;
    } catch (const NoCandidateMaps& e) {
      if (attempt == kBimSeedRetries)
        throw InputError(opt.name_A + ", " + opt.name_B + ": " + e.what() + " (seeds " + std::to_string(opt.seed) +
                         " and " + std::to_string(kBimSeedRetries) + " others tried; --landmarks may help)");
      o.seed = splitmix64(rs);
    }
  }
}

namespace {
BIMResult bim_prepared_once(const BIMSurface& sa, const BIMSurface& sb, const BIMOptions& opt,
                       const ProgressCallback& progress, bool prepared_here) {
  auto t0 = Clock::now();
  BIMResult out;
  for (auto& t : sa.timings) out.timings.push_back({"A/" + t.first, prepared_here ? t.second : 0.0});
  for (auto& t : sb.timings) out.timings.push_back({"B/" + t.first, prepared_here ? t.second : 0.0});
  out.features_A = sa.features;
  out.features_B = sb.features;
  out.num_even = int(sa.even.size());
  out.AB = bim_map(sa, sb, opt, progress);
  for (auto& t : out.AB.timings) out.timings.push_back({"AB/" + t.first, t.second});
  if (opt.symmetric) {
    BIMOptions o2 = opt;
    std::swap(o2.landmarks_A, o2.landmarks_B);
    out.BA = bim_map(sb, sa, o2, progress);
    for (auto& t : out.BA.timings) out.timings.push_back({"BA/" + t.first, t.second});
    // The two blends can disagree (a limb swapped one way only); the more confident one
    // decides and the other direction follows it.
    if (opt.reverse_candidates) {
      if (out.BA.integrated_confidence > out.AB.integrated_confidence) take_inverse(sa, sb, out.BA, out.AB);
      else take_inverse(sb, sa, out.AB, out.BA);
    }
  }
  out.total_seconds = seconds_since(t0);
  return out;
}

// "Too few features to blend": the surface with `anchor` (3 of its features, or none) as its first
// features, then its other features, then P_even samples (FPS order, not already features) until
// it has k; the samples' geodesic distances are P_even's own columns.
BIMSurface anchored_spread_features(const BIMSurface& s, const std::vector<int>& anchor, int k) {
  BIMSurface out = s;
  out.features.assign(anchor.begin(), anchor.end());
  for (int f : s.features)
    if (std::find(anchor.begin(), anchor.end(), f) == anchor.end()) out.features.push_back(f);
  for (int j = 0; j < int(s.even.size()) && int(out.features.size()) < k; ++j)
    if (std::find(out.features.begin(), out.features.end(), s.even[j]) == out.features.end())
      out.features.push_back(s.even[j]);
  out.feature_dist.resize(s.mesh.num_vertices(), out.features.size());
  for (size_t c = 0; c < out.features.size(); ++c) {
    const int v = out.features[c];
    const auto f = std::find(s.features.begin(), s.features.end(), v);
    const auto e = std::find(s.even.begin(), s.even.end(), v);
    out.feature_dist.col(c) = f != s.features.end() ? s.feature_dist.col(f - s.features.begin())
                                                    : s.even_dist.col(e - s.even.begin());
  }
  return out;
}
}  // namespace

namespace {
using GuideTriple = std::pair<std::array<int, 3>, std::array<int, 3>>;  // (A's vertices, B's vertices)

// The same three correspondences in another order are the same guide.
bool same_guide(const GuideTriple& u, const GuideTriple& t) {
  for (int k = 0; k < 3; ++k) {
    const auto it = std::find(u.first.begin(), u.first.end(), t.first[k]);
    if (it == u.first.end() || u.second[it - u.first.begin()] != t.second[k]) return false;
  }
  return true;
}

// The triples (A's features, B's features) of the deciding direction's single maps, the most
// confident first, without repeats: its selected map, then its other groups' leads.
std::vector<GuideTriple> guiding_triples(const BIMResult& r, bool ba, int count) {
  const BIMDirectionResult& d = ba ? r.BA : r.AB;
  std::vector<BIMMapInfo> maps;
  if (!d.selected.empty()) maps.push_back(d.selected[0]);
  std::vector<int> order(d.group_leads.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return d.group_confidence.at(a) > d.group_confidence.at(b);
  });
  for (int g : order) maps.push_back(d.group_leads[g]);
  std::vector<GuideTriple> out;
  for (const BIMMapInfo& m : maps) {
    auto t = ba ? std::make_pair(m.target, m.source) : std::make_pair(m.source, m.target);
    if (std::none_of(out.begin(), out.end(), [&](const GuideTriple& u) { return same_guide(u, t); }))
      out.push_back(t);
    if (int(out.size()) >= count) break;
  }
  return out;
}
}  // namespace

namespace {
// "Too few features to blend", the stretch criterion: the membrane energy W_mem of the elastic
// model (elastic-correspondence.txt, Eq. 7, lambda = mu = 1) of the map that sends src's
// vertices to the points Y (both surfaces in their unit-area frames). Eq. 2's confidence is
// bounded at every point, so a map that is right on most of a surface scores well however it
// crushes the rest; W_mem grows without bound there (SHREC'07 busts: the heads-up Moebius maps
// have a tenth of the W_mem of the most confident (twisted) ones and half the upside-down one's).
class StretchEnergy {
 public:
  explicit StretchEnergy(const BIMSurface& src) : W_(src.mesh.V, src.mesh.F) {}
  double operator()(const Eigen::MatrixXd& Y) const {
    ShellEnergyTerms t;
    W_.evaluate(Y, nullptr, &t);
    return t.membrane;
  }
 private:
  ShellEnergy W_;
};

// Candidates ranked by confidence for the stretch guide: a seeded random pool of this many when
// there are more (BIMOptions::candidate_pool's ranking; busts, 12 features a side: 290,400).
constexpr int kStretchGuidePool = 20000;

// The images on B of A's vertices under the Moebius map of a guide triple (A -> B); false when
// its points coincide on the sphere.
bool triple_images(const BIMSurface& sa, const BIMSurface& sb, const GuideTriple& t, Eigen::MatrixXd& Y) {
  Mobius m;
  if (!mobius_through(sa, sb, t.first, t.second, m)) return false;
  Y = bim_apply(sa, sb, m);
  return true;
}

// BIMOptions::blend_guide_maps: appends to `guides` (the single maps' triples) the triples of the
// blend_guide_maps most confident candidate maps on both surfaces' features with P_even samples
// added up to k a side, scores each by the W_mem of its own Moebius map (`stretch`), and returns
// the index of the least stretched.
int least_stretched_guide(const BIMSurface& sa, const BIMSurface& sb, const BIMOptions& opt, int k,
                          std::vector<GuideTriple>& guides, std::vector<double>& stretch) {
  const BIMSurface a = anchored_spread_features(sa, {}, k), b = anchored_spread_features(sb, {}, k);
  BIMOptions o = opt;
  o.landmarks_A.clear();
  o.landmarks_B.clear();
  o.max_candidates = opt.blend_guide_maps;
  o.candidate_pool = std::max(kStretchGuidePool, opt.blend_guide_maps + 1);
  for (const BIMCandidate& cd : bim_candidates(a, b, o)) {
    GuideTriple t;
    for (int c = 0; c < 3; ++c) t.first[c] = a.features[cd.source[c]], t.second[c] = b.features[cd.target[c]];
    if (std::none_of(guides.begin(), guides.end(), [&](const GuideTriple& u) { return same_guide(u, t); }))
      guides.push_back(t);
  }
  const int n = int(guides.size());
  std::vector<Eigen::MatrixXd> Y(n);
  std::vector<char> ok(n);
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < n; ++i) ok[i] = triple_images(sa, sb, guides[i], Y[i]);
  const StretchEnergy W(sa);
  stretch.assign(n, std::numeric_limits<double>::infinity());
  for (int i = 0; i < n; ++i)
    if (ok[i]) stretch[i] = W(Y[i]);
  return int(std::min_element(stretch.begin(), stretch.end()) - stretch.begin());
}
}  // namespace

// The second run's candidates: with the triple in every candidate most pairs share two
// correspondences, so Sec. 7's consistency matrix costs far more per candidate (SHREC'07 busts,
// 25k vertices, both directions: 37 s with 10,000, under 4.2 s with 2,000; generated pairs with
// 3 maxima a side, within 0.1 near / non-isometric: 0.807 / 0.673 -> 0.796 / 0.742).
constexpr int kBlendRetryMaxCandidates = 2000;

BIMResult bim_prepared(const BIMSurface& sa, const BIMSurface& sb, const BIMOptions& opt,
                       const ProgressCallback& progress, bool prepared_here) {
  BIMResult out = bim_prepared_once(sa, sb, opt, progress, prepared_here);
  const int k = opt.blend_min_features;
  if (!opt.landmarks_A.empty() || out.AB.num_consistent_pairs > 0 ||
      (int(sa.features.size()) >= k && int(sb.features.size()) >= k))
    return out;
  // Sec. 6.2 blends maps that share two correspondences without a conflict; with 3 features on a
  // surface no two maps do, and the map is one Moebius map, exact only near its triple (the
  // paper's glasses, Fig. 14). So BIM runs again with spread samples added, guided by a single
  // map's triple as by landmarks ("Landmarks among the feature points": the triple goes only to
  // its partner, which keeps the spread samples from building a consistent wrong group); once
  // for each of the most confident single maps, since the best one's triple can be a symmetric
  // flip of the right one.
  auto decider_confidence = [&](const BIMResult& r) {
    return opt.symmetric && r.AB.from_reverse ? r.BA.integrated_confidence : r.AB.integrated_confidence;
  };
  const std::vector<GuideTriple> triples =
      guiding_triples(out, opt.symmetric && out.AB.from_reverse, std::max(1, opt.blend_retry_triples));
  BIMOptions o = opt;
  o.landmark_feature_points = true;
  o.landmark_agreement = opt.blend_agreement;
  o.max_candidates = std::min(opt.max_candidates, kBlendRetryMaxCandidates);
  std::vector<std::pair<std::string, double>> retry_timings;
  double retry_seconds = 0;
  int runs = 0;
  auto run = [&](const GuideTriple& t) {  // BIM again, guided by t
    o.landmarks_A.assign(t.first.begin(), t.first.end());
    o.landmarks_B.assign(t.second.begin(), t.second.end());
    BIMResult again = bim_prepared_once(anchored_spread_features(sa, o.landmarks_A, k),
                                        anchored_spread_features(sb, o.landmarks_B, k), o, progress, false);
    retry_seconds += again.total_seconds;
    const std::string tag = runs == 0 ? "blend_retry/" : "blend_retry" + std::to_string(runs) + "/";
    ++runs;
    for (const auto& s : again.timings) retry_timings.push_back({tag + s.first, s.second});
    return again;
  };
  BIMResult best;
  double best_confidence = -1;
  int best_rank = -1;
  for (size_t t = 0; t < triples.size(); ++t) {
    BIMResult again = run(triples[t]);
    // A blend, and the most confident one so far (Sec. 6.2's own criterion, of the direction
    // that decides).
    if (again.AB.num_consistent_pairs > 0 && decider_confidence(again) > best_confidence) {
      best_confidence = decider_confidence(again);
      best_rank = int(t);
      best = std::move(again);
    }
  }
  // Kept when more confident than the single map.
  bool keep = best_rank >= 0 && best_confidence > decider_confidence(out);
  // BIMOptions::blend_guide_maps: else the single map may be a wrong one that confidence does
  // not see; a last run, guided by the least stretched candidate on spread features when it is
  // less stretched than every single map, is kept when it blends.
  bool stretch_kept = false;
  double single_stretch = 0, guide_stretch = 0;
  if (!keep && opt.blend_guide_maps > 0) {
    std::vector<GuideTriple> guides = triples;
    std::vector<double> e;
    const int g = least_stretched_guide(sa, sb, opt, k, guides, e);
    single_stretch = e[0];
    guide_stretch = e[g];
    if (g >= int(triples.size())) {
      BIMResult again = run(guides[g]);
      if (again.AB.num_consistent_pairs > 0) {
        best_confidence = decider_confidence(again);
        best = std::move(again);
        keep = stretch_kept = true;
      }
    }
  }
  BIMResult& kept = keep ? best : out;
  kept.blend_retry_confidence = std::max(best_confidence, 0.0);
  kept.blend_retry_runs = runs;
  kept.blend_retry_stretch_guide = stretch_kept;
  kept.single_map_stretch = single_stretch;
  kept.blend_retry_stretch = guide_stretch;
  kept.total_seconds = out.total_seconds + retry_seconds;
  if (!keep) {  // the second runs' stages still count
    out.timings.insert(out.timings.end(), retry_timings.begin(), retry_timings.end());
    return out;
  }
  best.blend_retry_rank = stretch_kept ? -1 : best_rank;
  best.blend_retry_features_A = int(sa.features.size());
  best.blend_retry_features_B = int(sb.features.size());
  std::vector<std::pair<std::string, double>> timings = out.timings;
  timings.insert(timings.end(), retry_timings.begin(), retry_timings.end());
  best.timings = std::move(timings);
  return best;
}

}  // namespace shapemap
