// Collapsed parts of a surface map re-extended: see collapsed_parts.h (steps 1-5).
#include "shapemap/surface/collapsed_parts.h"

#include "shapemap/adjacency.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include "shapemap/geometry/procrustes.h"
#include "shapemap/timing.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace shapemap {

namespace {

// Step 1: the singular values of the map's 3x2 Jacobian on each face (A's face in its own
// plane -> the images of its corners), over `scale`; degenerate when outside the limits.
std::vector<char> degenerate_faces(const TriMesh& A, const Eigen::MatrixXd& X, double scale, double limit) {
  std::vector<char> bad(A.num_faces(), 0);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < A.num_faces(); ++f) {
    const Eigen::Vector3d e1 = A.V.row(A.F(f, 1)) - A.V.row(A.F(f, 0));
    const Eigen::Vector3d e2 = A.V.row(A.F(f, 2)) - A.V.row(A.F(f, 0));
    const double l1 = e1.norm();
    const Eigen::Vector3d u = e1 / l1;
    const Eigen::Vector3d w = (e2 - e2.dot(u) * u);
    const double h = w.norm();
    if (!(l1 > 0) || !(h > 0)) continue;  // A's own degenerate faces are not the map's doing
    Eigen::Matrix2d S;  // A's edges in the face's frame (u, w / h)
    S << l1, e2.dot(u), 0, h;
    Eigen::Matrix<double, 3, 2> E;
    E.col(0) = (X.row(A.F(f, 1)) - X.row(A.F(f, 0))).transpose();
    E.col(1) = (X.row(A.F(f, 2)) - X.row(A.F(f, 0))).transpose();
    const Eigen::Matrix<double, 3, 2> J = E * S.inverse() / scale;
    const Eigen::Vector2d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(J.transpose() * J).eigenvalues();
    const double smin = std::sqrt(std::max(0.0, ev(0))), smax = std::sqrt(std::max(0.0, ev(1)));
    bad[f] = !std::isfinite(smax) || smin < 1.0 / limit || smax > limit;
  }
  return bad;
}

// Step 2: connected regions of degenerate vertices (at least half of their faces degenerate)
// whose lumped area is at least min_area of A's; each as a vertex list.
std::vector<std::vector<int>> degenerate_regions(const TriMesh& A, const std::vector<char>& bad_face,
                                                 const std::vector<std::vector<int>>& nbr, double min_area) {
  const int n = A.num_vertices();
  std::vector<int> count(n, 0), total(n, 0);
  Eigen::VectorXd mass = Eigen::VectorXd::Zero(n);
  const Eigen::VectorXd area = triangle_areas(A.V, A.F);
  for (int f = 0; f < A.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = A.F(f, k);
      ++total[v];
      count[v] += bad_face[f];
      mass(v) += area(f) / 3;
    }
  std::vector<char> bad(n), seen(n, 0);
  for (int v = 0; v < n; ++v) bad[v] = total[v] > 0 && 2 * count[v] >= total[v];
  std::vector<std::vector<int>> regions;
  for (int s = 0; s < n; ++s) {
    if (!bad[s] || seen[s]) continue;
    std::vector<int> region{s};
    seen[s] = 1;
    double a = 0;
    for (size_t i = 0; i < region.size(); ++i) {
      a += mass(region[i]);
      for (int w : nbr[region[i]])
        if (bad[w] && !seen[w]) seen[w] = 1, region.push_back(w);
    }
    if (a >= min_area * mass.sum()) regions.push_back(std::move(region));
  }
  return regions;
}

// `rings` rings of vertices around the flagged set `in` (in place), not entering `stop`.
void grow(std::vector<char>& in, const std::vector<std::vector<int>>& nbr, int rings, const std::vector<char>& stop) {
  std::vector<int> front;
  for (int v = 0; v < int(in.size()); ++v)
    if (in[v]) front.push_back(v);
  for (int r = 0; r < rings; ++r) {
    std::vector<int> next;
    for (int v : front)
      for (int w : nbr[v])
        if (!in[w] && !stop[w]) in[w] = 1, next.push_back(w);
    front.swap(next);
  }
}

// Step 3: rows `region` of Y placed by the rotation and translation taking Vs[handles] closest
// to X[handles] (Kabsch); false when fewer than 3 handles.
bool place_rigidly(const Eigen::MatrixXd& Vs, const Eigen::MatrixXd& X, const std::vector<int>& handles,
                   const std::vector<int>& region, Eigen::MatrixXd& Y) {
  if (handles.size() < 3) return false;
  Eigen::RowVector3d mp = Eigen::RowVector3d::Zero(), mq = Eigen::RowVector3d::Zero();
  for (int v : handles) mp += Vs.row(v), mq += X.row(v);
  mp /= double(handles.size());
  mq /= double(handles.size());
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (int v : handles) C += (X.row(v) - mq).transpose() * (Vs.row(v) - mp);
  const Eigen::Matrix3d R = procrustes_rotation(C);
  for (int v : region) Y.row(v) = (Vs.row(v) - mp) * R.transpose() + mq;
  return true;
}

// Step 4: as-rigid-as-possible (local rotations, global solve) of the free rows of Y from the
// rest shape Vs, the other rows held. W: edge weights (the negated off-diagonal of L).
void arap(const Eigen::MatrixXd& Vs, const Eigen::SparseMatrix<double>& L, const std::vector<char>& free,
          int iterations, Eigen::MatrixXd& Y) {
  const int n = int(Vs.rows());
  std::vector<int> id(n, -1), fi;
  for (int v = 0; v < n; ++v)
    if (free[v]) id[v] = int(fi.size()), fi.push_back(v);
  const int k = int(fi.size());
  std::vector<Eigen::Triplet<double>> t;
  for (int c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it)
      if (id[it.row()] >= 0 && id[it.col()] >= 0) t.emplace_back(id[it.row()], id[it.col()], it.value());
  Eigen::SparseMatrix<double> Lff(k, k);
  Lff.setFromTriplets(t.begin(), t.end());
  SparseCholesky chol(SparseCholesky::Method::Simplicial);
  chol.compute(Lff);  // positive definite: every region touches held vertices
  std::vector<Eigen::Matrix3d> R(n, Eigen::Matrix3d::Identity());
  std::vector<char> active(n, 0);  // free vertices and their neighbours need rotations
  for (int c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it)
      if (free[it.row()]) active[it.col()] = 1;
  for (int it = 0; it < iterations; ++it) {
#pragma omp parallel for schedule(dynamic, 256)
    for (int v = 0; v < n; ++v) {
      if (!active[v]) continue;
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
      for (Eigen::SparseMatrix<double>::InnerIterator e(L, v); e; ++e)
        if (e.row() != v) C -= e.value() * (Y.row(v) - Y.row(e.row())).transpose() * (Vs.row(v) - Vs.row(e.row()));
      R[v] = procrustes_rotation(C);
    }
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(k, 3);
#pragma omp parallel for schedule(dynamic, 256)
    for (int i = 0; i < k; ++i) {
      const int v = fi[i];
      for (Eigen::SparseMatrix<double>::InnerIterator e(L, v); e; ++e) {
        const int w = int(e.row());
        if (w == v) continue;
        const double wt = -e.value();
        b.row(i) += 0.5 * wt * ((R[v] + R[w]) * (Vs.row(v) - Vs.row(w)).transpose()).transpose();
        if (!free[w]) b.row(i) += wt * Y.row(w);  // held neighbour: moved to the right-hand side
      }
    }
    const Eigen::MatrixXd sol = chol.solve(b);
    for (int i = 0; i < k; ++i) Y.row(fi[i]) = sol.row(i);
  }
}

}  // namespace

BarycentricMap reextend_collapsed_parts(const TriMesh& A, const TriMesh& B, const BarycentricMap& map,
                                        const CollapsedPartOptions& opt, CollapsedPartResult* result) {
  const auto t0 = Clock::now();
  CollapsedPartResult res;
  BarycentricMap out = map;
  const Eigen::MatrixXd X = map_positions(map, B.V, B.F);
  const double scale = std::sqrt(surface_area(B.V, B.F) / surface_area(A.V, A.F));
  const std::vector<char> bad_face = degenerate_faces(A, X, scale, opt.stretch_limit);
  res.degenerate_faces = int(std::count(bad_face.begin(), bad_face.end(), 1));
  const std::vector<std::vector<int>> nbr = vertex_neighbors(A.F, A.num_vertices());
  const std::vector<std::vector<int>> regions = degenerate_regions(A, bad_face, nbr, opt.min_area);
  const int n = A.num_vertices();
  const Eigen::MatrixXd Vs = A.V * scale;
  Eigen::MatrixXd Y = X;
  std::vector<char> free(n, 0);
  for (const auto& seed : regions) {
    std::vector<char> region(n, 0);
    for (int v : seed) region[v] = 1;
    grow(region, nbr, opt.grow_rings, free);  // regions placed before keep their vertices
    std::vector<char> ring = region;
    grow(ring, nbr, opt.handle_rings, free);
    std::vector<int> rows, handles;
    for (int v = 0; v < n; ++v) {
      if (region[v] && !free[v]) rows.push_back(v);
      else if (ring[v] && !free[v]) handles.push_back(v);
    }
    if (int(rows.size()) == n || !place_rigidly(Vs, X, handles, rows, Y)) continue;
    for (int v : rows) free[v] = 1;
    ++res.regions;
    res.vertices += int(rows.size());
  }
  if (res.regions > 0) {
    arap(Vs, drop_negative_weights(cotan_laplacian(A.V, A.F)), free, opt.arap_iterations, Y);
    std::vector<int> rows;
    for (int v = 0; v < n; ++v)
      if (free[v]) rows.push_back(v);
    Eigen::MatrixXd P(rows.size(), 3);
    for (size_t i = 0; i < rows.size(); ++i) P.row(i) = Y.row(rows[i]);
    const std::vector<ClosestPointResult> hit = ClosestPoint3(B.V, B.F).query(P);  // step 5
    for (size_t i = 0; i < rows.size(); ++i) {
      const Eigen::Vector3d b = hit[i].bary.head<3>().cwiseMax(0.0);
      out.elem(rows[i]) = hit[i].elem;
      out.bary.row(rows[i]) = b.sum() > 0 ? Eigen::RowVector3d(b.transpose() / b.sum()) : Eigen::RowVector3d(1, 0, 0);
    }
  }
  res.seconds = seconds_since(t0);
  if (result) *result = res;
  return out;
}

}  // namespace shapemap
