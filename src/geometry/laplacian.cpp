// Cotangent Laplacians of triangle and tetrahedral meshes (PSD convention, see header).
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/tet_volume.h"
#include "shapemap/error.h"
#include "shapemap/mesh.h"
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace shapemap {

namespace {

// Edge order inside a tet, shared with tet_cotan_weights' documentation.
constexpr int kTetEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

// Precomputed sparsity pattern of a tet Laplacian and where each tet edge goes in it.
struct TetPattern {
  Eigen::MatrixXi T;          // the connectivity this pattern was built for
  int n = 0;
  std::vector<int> outer;     // CSC outer index (n+1)
  std::vector<int> inner;     // CSC inner index (nnz)
  // Unique edges a<b: contributions are W entries (flat column-major index e*m+t).
  std::vector<int> edge_ptr;      // k+1
  std::vector<int> edge_contrib;  // 6m
  std::vector<int> nz_ab, nz_ba;  // value positions of (a,b) and (b,a)
  std::vector<int> nz_diag;       // n: value position of (i,i)
};

std::shared_ptr<const TetPattern> build_pattern(const Eigen::MatrixXi& T, int n) {
  auto P = std::make_shared<TetPattern>();
  P->T = T;
  P->n = n;
  const Eigen::Index m = T.rows();
  // All (min,max,flat W index) of the 6m tet edges, sorted: groups are unique edges.
  struct Item {
    int a, b, w;
  };
  std::vector<Item> items(size_t(m) * 6);
  for (Eigen::Index t = 0; t < m; ++t)
    for (int e = 0; e < 6; ++e) {
      int a = T(t, kTetEdge[e][0]), b = T(t, kTetEdge[e][1]);
      if (a == b) throw InputError("tet mesh: tet " + std::to_string(t) + " repeats a vertex");
      items[size_t(t) * 6 + e] = {std::min(a, b), std::max(a, b), int(e * m + t)};
    }
  std::sort(items.begin(), items.end(), [](const Item& x, const Item& y) {
    return x.a != y.a ? x.a < y.a : (x.b != y.b ? x.b < y.b : x.w < y.w);
  });
  std::vector<std::array<int, 2>> edges;
  P->edge_ptr.push_back(0);
  P->edge_contrib.reserve(items.size());
  for (size_t i = 0; i < items.size();) {
    size_t j = i;
    while (j < items.size() && items[j].a == items[i].a && items[j].b == items[i].b) {
      P->edge_contrib.push_back(items[j].w);
      ++j;
    }
    edges.push_back({items[i].a, items[i].b});
    P->edge_ptr.push_back(int(P->edge_contrib.size()));
    i = j;
  }
  // Column counts: the diagonal plus both directions of every edge.
  std::vector<int> count(n, 1);
  for (auto& e : edges) {
    ++count[e[0]];
    ++count[e[1]];
  }
  P->outer.assign(n + 1, 0);
  for (int i = 0; i < n; ++i) P->outer[i + 1] = P->outer[i] + count[i];
  // Rows of column c: its neighbors and c itself, sorted. Edges are sorted by (a,b), so
  // filling column b with a (a<b) in edge order, then c, then column a with b gives sorted
  // rows if we do it in three passes.
  P->inner.resize(P->outer[n]);
  std::vector<int> fill(P->outer.begin(), P->outer.end() - 1);
  const size_t k = edges.size();
  P->nz_ab.resize(k);
  P->nz_ba.resize(k);
  P->nz_diag.resize(n);
  // Pass 1: entries (a, b) with a < b live in column b, rows a ascending (edges sorted by a).
  for (size_t e = 0; e < k; ++e) {
    int a = edges[e][0], b = edges[e][1];
    P->nz_ab[e] = fill[b];
    P->inner[fill[b]++] = a;
  }
  // Pass 2: diagonal.
  for (int i = 0; i < n; ++i) {
    P->nz_diag[i] = fill[i];
    P->inner[fill[i]++] = i;
  }
  // Pass 3: entries (b, a) with b > a live in column a, rows b ascending (edges of one a are
  // sorted by b).
  for (size_t e = 0; e < k; ++e) {
    int a = edges[e][0], b = edges[e][1];
    P->nz_ba[e] = fill[a];
    P->inner[fill[a]++] = b;
  }
  return P;
}

// A small process-wide cache of patterns keyed by the exact connectivity.
std::shared_ptr<const TetPattern> cached_pattern(const Eigen::MatrixXi& T, int n) {
  static std::mutex mutex;
  static std::vector<std::shared_ptr<const TetPattern>> cache;  // most recent first
  constexpr size_t kMaxEntries = 8;
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (size_t i = 0; i < cache.size(); ++i) {
      const auto& P = cache[i];
      if (P->n == n && P->T.rows() == T.rows() && P->T.cols() == T.cols() &&
          std::memcmp(P->T.data(), T.data(), sizeof(int) * size_t(T.size())) == 0) {
        auto hit = P;
        cache.erase(cache.begin() + i);
        cache.insert(cache.begin(), hit);
        return hit;
      }
    }
  }
  auto P = build_pattern(T, n);
  std::lock_guard<std::mutex> lock(mutex);
  cache.insert(cache.begin(), P);
  if (cache.size() > kMaxEntries) cache.pop_back();
  return P;
}

bool has_pattern(const Eigen::SparseMatrix<double>& L, const TetPattern& P) {
  if (L.rows() != P.n || L.cols() != P.n || !L.isCompressed() ||
      L.nonZeros() != Eigen::Index(P.inner.size()))
    return false;
  return std::memcmp(L.outerIndexPtr(), P.outer.data(), sizeof(int) * P.outer.size()) == 0 &&
         std::memcmp(L.innerIndexPtr(), P.inner.data(), sizeof(int) * P.inner.size()) == 0;
}

// Both cotan_laplacian()s; sigma null: all divisors 1 (x / 1.0 is x exactly).
Eigen::SparseMatrix<double> weighted_cotan(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                           const Eigen::VectorXd* sigma) {
  require_element_indices(F, V.rows(), 3, "cotan_laplacian");
  const Eigen::Index m = F.rows();
  std::vector<Eigen::Triplet<double>> trip(size_t(m) * 12);
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < m; ++f) {
    const double d = sigma ? (*sigma)(f) : 1.0;
    for (int c = 0; c < 3; ++c) {
      // Corner c with opposite edge (i, j).
      const int i = F(f, (c + 1) % 3), j = F(f, (c + 2) % 3);
      const Eigen::Vector3d p = V.row(F(f, c));
      const Eigen::Vector3d u = V.row(i).transpose() - p, v = V.row(j).transpose() - p;
      const double s = u.cross(v).norm();
      // cot = cos/sin = (u.v) / |u x v|; a degenerate corner contributes nothing.
      const double w = (s > 0 && d > 0 && std::isfinite(d)) ? 0.5 * u.dot(v) / s / d : 0.0;
      Eigen::Triplet<double>* out = &trip[size_t(f) * 12 + size_t(c) * 4];
      out[0] = {i, j, -w};
      out[1] = {j, i, -w};
      out[2] = {i, i, w};
      out[3] = {j, j, w};
    }
  }
  Eigen::SparseMatrix<double> L(V.rows(), V.rows());
  L.setFromTriplets(trip.begin(), trip.end());
  L.makeCompressed();
  return L;
}

}  // namespace

Eigen::SparseMatrix<double> drop_negative_weights(const Eigen::SparseMatrix<double>& L) {
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(size_t(L.nonZeros()));
  Eigen::VectorXd diag = Eigen::VectorXd::Zero(L.rows());
  for (int col = 0; col < L.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, col); it; ++it)
      if (it.row() != it.col() && it.value() < 0) {  // off-diagonal -w with w > 0: kept
        trip.emplace_back(int(it.row()), int(it.col()), it.value());
        diag(it.row()) -= it.value();
      }
  for (Eigen::Index i = 0; i < L.rows(); ++i) trip.emplace_back(int(i), int(i), diag(i));
  Eigen::SparseMatrix<double> R(L.rows(), L.cols());
  R.setFromTriplets(trip.begin(), trip.end());
  R.makeCompressed();
  return R;
}

Eigen::SparseMatrix<double> cotan_laplacian(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  return weighted_cotan(V, F, nullptr);
}

Eigen::SparseMatrix<double> cotan_laplacian(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                            const Eigen::VectorXd& sigma) {
  return weighted_cotan(V, F, &sigma);
}

Eigen::MatrixXd tet_cotan_weights(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  require_element_indices(T, V.rows(), 4, "tet_cotan_weights");
  const Eigen::Index m = T.rows();
  Eigen::MatrixXd W(m, 6);
  // With c_i the doubled area vector of the face opposite vertex i (consistently outward or
  // consistently inward), grad phi_i = -c_i / (6 vol), and the P1 stiffness entry
  // K_ij = |vol| grad phi_i . grad phi_j = c_i . c_j / (36 |vol|). Since c_i . c_j =
  // -4 A_i A_j cos(theta_kl) and |vol| = (2/3) A_i A_j sin(theta_kl) / l_kl, this is
  // -l_kl cot(theta_kl) / 6 = -w_ij: the dihedral cot formula, evaluated without angles.
#pragma omp parallel for schedule(static)
  for (Eigen::Index t = 0; t < m; ++t) {
    const Eigen::Vector3d x0 = V.row(T(t, 0)), x1 = V.row(T(t, 1)), x2 = V.row(T(t, 2)),
                          x3 = V.row(T(t, 3));
    Eigen::Vector3d c[4];
    c[0] = (x2 - x1).cross(x3 - x1);  // face (1,2,3)
    c[1] = (x3 - x0).cross(x2 - x0);  // face (0,3,2)
    c[2] = (x1 - x0).cross(x3 - x0);  // face (0,1,3)
    c[3] = (x2 - x0).cross(x1 - x0);  // face (0,2,1)
    const double vol6 = std::abs(signed_tet_volume6(x0, x1, x2, x3));
    if (!(vol6 > 0)) {
      // Flat tet: the dihedral angles are 0 or pi and the weights are unbounded; a
      // degenerate element contributes nothing rather than inf/NaN.
      W.row(t).setZero();
      continue;
    }
    for (int e = 0; e < 6; ++e)
      W(t, e) = -c[kTetEdge[e][0]].dot(c[kTetEdge[e][1]]) / (6.0 * vol6);
  }
  return W;
}

void assemble_tet_laplacian(const Eigen::MatrixXi& T, const Eigen::MatrixXd& W, int num_vertices,
                            Eigen::SparseMatrix<double>& L) {
  if (T.cols() != 4) throw InputError("assemble_tet_laplacian: T must have 4 columns");
  if (W.rows() != T.rows() || W.cols() != 6)
    throw InputError("assemble_tet_laplacian: W must be " + std::to_string(T.rows()) + "x6, got " +
                     std::to_string(W.rows()) + "x" + std::to_string(W.cols()));
  if (T.size() > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= num_vertices))
    throw InputError("assemble_tet_laplacian: vertex index out of range");
  auto P = cached_pattern(T, num_vertices);
  if (!has_pattern(L, *P)) {
    L.resize(num_vertices, num_vertices);
    L.resizeNonZeros(Eigen::Index(P->inner.size()));
    std::memcpy(L.outerIndexPtr(), P->outer.data(), sizeof(int) * P->outer.size());
    std::memcpy(L.innerIndexPtr(), P->inner.data(), sizeof(int) * P->inner.size());
  }
  double* val = L.valuePtr();
  const double* w = W.data();
  const int k = int(P->nz_ab.size());
  // Off-diagonals: each unique edge sums its tets in a fixed order (deterministic).
#pragma omp parallel for schedule(static)
  for (int e = 0; e < k; ++e) {
    double s = 0;
    for (int q = P->edge_ptr[e]; q < P->edge_ptr[e + 1]; ++q) s += w[P->edge_contrib[q]];
    val[P->nz_ab[e]] = -s;
    val[P->nz_ba[e]] = -s;
  }
  // Diagonal = minus the sum of the column's off-diagonals (rows in ascending order).
  const int* outer = P->outer.data();
#pragma omp parallel for schedule(static)
  for (int i = 0; i < num_vertices; ++i) {
    double s = 0;
    const int d = P->nz_diag[i];
    for (int q = outer[i]; q < outer[i + 1]; ++q)
      if (q != d) s -= val[q];
    val[d] = s;
  }
}

Eigen::SparseMatrix<double> tet_cotan_laplacian(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  Eigen::SparseMatrix<double> L;
  assemble_tet_laplacian(T, tet_cotan_weights(V, T), int(V.rows()), L);
  return L;
}

}  // namespace shapemap
