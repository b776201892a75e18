// Discrete mean curvature from the cotangent Laplacian (Meyer et al. 2003).
#include "shapemap/geometry/curvature.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/mesh.h"
#include <cmath>

namespace shapemap {

Eigen::VectorXd mean_curvature(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  const Eigen::SparseMatrix<double> L = cotan_laplacian(V, F);
  const Eigen::VectorXd M = voronoi_mass(V, F);
  const Eigen::MatrixXd N = vertex_normals(V, F);
  // L is PSD (= -M * Laplace-Beltrami), and Laplace-Beltrami of the position is -2 H n, so
  // (L x)_i / M_ii = 2 H n_i.
  const Eigen::MatrixXd LX = L * V;
  Eigen::VectorXd H(V.rows());
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const Eigen::Vector3d hn = LX.row(i);
    if (!(M(i) > 0)) {
      H(i) = 0;
      continue;
    }
    const double mag = hn.norm() / (2 * M(i));
    H(i) = hn.dot(N.row(i).transpose()) < 0 ? -mag : mag;
  }
  return H;
}

}  // namespace shapemap
