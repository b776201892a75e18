// Dirichlet problem on a tet mesh (harmonic_extension.h).
#include "shapemap/geometry/harmonic_extension.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include <Eigen/Sparse>
#include <algorithm>

namespace shapemap {

namespace {
// The free block is singular exactly when some free vertex cannot reach a fixed one (a
// Cholesky factorization need not notice: rounding can leave a tiny positive pivot).
void require_fixed_vertex_per_component(const Eigen::SparseMatrix<double>& L, const std::vector<char>& fixed) {
  const int n = int(L.rows());
  std::vector<char> reached(n, 0);
  std::vector<int> stack;
  for (int v = 0; v < n; ++v)
    if (fixed[v]) reached[v] = 1, stack.push_back(v);
  while (!stack.empty()) {
    const int v = stack.back();
    stack.pop_back();
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, v); it; ++it)  // symmetric pattern
      if (!reached[it.row()]) reached[it.row()] = 1, stack.push_back(int(it.row()));
  }
  if (std::find(reached.begin(), reached.end(), 0) != reached.end())
    throw Error("harmonic_extension: a component of the mesh has no fixed vertex");
}
}  // namespace

Eigen::MatrixXd harmonic_extension(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T, const Eigen::MatrixXd& X,
                                   const std::vector<char>& fixed) {
  const int n = int(V.rows());
  if (X.rows() != n || int(fixed.size()) != n) throw Error("harmonic_extension: X and fixed need one row per vertex");
  // Free vertices numbered 0..k-1.
  std::vector<int> index(n, -1);
  int k = 0;
  for (int v = 0; v < n; ++v)
    if (!fixed[v]) index[v] = k++;
  Eigen::MatrixXd out = X;
  if (k == 0) return out;
  const Eigen::SparseMatrix<double> L = tet_cotan_laplacian(V, T);
  // Mean positive edge weight: the scale of the small uniform term that keeps every free
  // vertex connected when all its cotangent weights are negative (dropped).
  double sum = 0;
  long edges = 0;
  for (int c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it)
      if (it.row() != it.col() && it.value() < 0) sum -= it.value(), ++edges;
  const double eps = edges > 0 ? 1e-3 * sum / double(edges) : 1.0;
  // A_II X_I = -A_IB X_B with A = L + eps * (graph Laplacian over the same edges).
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(k, X.cols());
  for (int c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it) {
      const int r = int(it.row());
      if (r == c || index[r] < 0) continue;  // the diagonal is assembled from the edges below
      const double w = std::max(0.0, -it.value()) + eps;  // edge weight, > 0
      trip.emplace_back(index[r], index[r], w);
      if (index[c] >= 0) trip.emplace_back(index[r], index[c], -w);
      else rhs.row(index[r]) += w * X.row(c);
    }
  require_fixed_vertex_per_component(L, fixed);
  Eigen::SparseMatrix<double> A(k, k);
  A.setFromTriplets(trip.begin(), trip.end());
  SparseCholesky chol;
  chol.compute(A);
  const Eigen::MatrixXd XI = chol.solve(rhs);
  for (int v = 0; v < n; ++v)
    if (index[v] >= 0) out.row(v) = XI.row(index[v]);
  return out;
}

}  // namespace shapemap
