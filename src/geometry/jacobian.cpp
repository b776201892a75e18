// Per-element Jacobians of piecewise-linear maps.
#include "shapemap/geometry/jacobian.h"
#include "shapemap/error.h"
#include "shapemap/mesh.h"
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <string>

namespace shapemap {

namespace {

// Edge matrix of a triangle in its own orthonormal frame (first axis along x1 - x0,
// second in the plane): upper triangular 2×2 [[|a|, a.b/|a|], [0, |a×b|/|a|]].
// Returns false if the triangle is degenerate.
bool frame_edges(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                 Eigen::Matrix2d& D) {
  const Eigen::Vector3d a = x1 - x0, b = x2 - x0;
  const double la = a.norm();
  if (!(la > 0)) {
    D.setZero();
    return false;
  }
  const double cr = a.cross(b).norm();
  D << la, a.dot(b) / la, 0.0, cr / la;
  return cr > 0;
}

}  // namespace

std::vector<Eigen::Matrix3d> tet_rest_inverse(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  require_element_indices(T, V.rows(), 4, "tet_rest_inverse");
  const Eigen::Index m = T.rows();
  std::vector<Eigen::Matrix3d> Dm_inv(m);
  int bad = -1;
#pragma omp parallel for schedule(static)
  for (Eigen::Index t = 0; t < m; ++t) {
    Eigen::Matrix3d D;
    const Eigen::Vector3d x0 = V.row(T(t, 0));
    for (int c = 0; c < 3; ++c) D.col(c) = V.row(T(t, c + 1)).transpose() - x0;
    const double det = D.determinant();
    if (!(std::abs(det) > 0) || !std::isfinite(det)) {
#pragma omp critical(shapemap_tet_rest_inverse)
      if (bad < 0 || t < bad) bad = int(t);
      Dm_inv[t].setZero();
    } else {
      Dm_inv[t] = D.inverse();
    }
  }
  if (bad >= 0) throw InputError("tet mesh: tet " + std::to_string(bad) + " has zero volume");
  return Dm_inv;
}

void tet_jacobians(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T,
                   const std::vector<Eigen::Matrix3d>& Dm_inv, std::vector<Eigen::Matrix3d>& J) {
  require_element_indices(T, X.rows(), 4, "tet_jacobians");
  const Eigen::Index m = T.rows();
  if (Eigen::Index(Dm_inv.size()) != m)
    throw InputError("tet_jacobians: Dm_inv has " + std::to_string(Dm_inv.size()) +
                     " entries, expected " + std::to_string(m));
  if (Eigen::Index(J.size()) != m) J.resize(m);
#pragma omp parallel for schedule(static)
  for (Eigen::Index t = 0; t < m; ++t) {
    Eigen::Matrix3d D;
    const Eigen::Vector3d x0 = X.row(T(t, 0));
    for (int c = 0; c < 3; ++c) D.col(c) = X.row(T(t, c + 1)).transpose() - x0;
    J[t].noalias() = D * Dm_inv[t];
  }
}

void triangle_jacobians(const Eigen::MatrixXd& V_rest, const Eigen::MatrixXd& X,
                        const Eigen::MatrixXi& F, std::vector<Eigen::Matrix2d>& J) {
  require_element_indices(F, V_rest.rows(), 3, "triangle_jacobians");
  if (X.rows() != V_rest.rows())
    throw InputError("triangle_jacobians: X has " + std::to_string(X.rows()) + " rows, V_rest has " +
                     std::to_string(V_rest.rows()));
  const Eigen::Index m = F.rows();
  if (Eigen::Index(J.size()) != m) J.resize(m);
  int bad = -1;
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < m; ++f) {
    Eigen::Matrix2d R, D;
    const bool ok = frame_edges(V_rest.row(F(f, 0)), V_rest.row(F(f, 1)), V_rest.row(F(f, 2)), R);
    frame_edges(X.row(F(f, 0)), X.row(F(f, 1)), X.row(F(f, 2)), D);
    if (!ok) {
#pragma omp critical(shapemap_triangle_jacobians)
      if (bad < 0 || f < bad) bad = int(f);
      J[f].setZero();
      continue;
    }
    // R is upper triangular: R^{-1} = [[1/r00, -r01/(r00 r11)], [0, 1/r11]].
    Eigen::Matrix2d Rinv;
    Rinv << 1.0 / R(0, 0), -R(0, 1) / (R(0, 0) * R(1, 1)), 0.0, 1.0 / R(1, 1);
    J[f].noalias() = D * Rinv;
  }
  if (bad >= 0)
    throw InputError("triangle_jacobians: rest face " + std::to_string(bad) + " is degenerate");
}

void first_fundamental_forms(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F,
                             std::vector<Eigen::Matrix2d>& I) {
  require_element_indices(F, X.rows(), 3, "first_fundamental_forms");
  const Eigen::Index m = F.rows();
  if (Eigen::Index(I.size()) != m) I.resize(m);
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < m; ++f) {
    const Eigen::Vector3d x0 = X.row(F(f, 0));
    const Eigen::Vector3d a = X.row(F(f, 1)).transpose() - x0, b = X.row(F(f, 2)).transpose() - x0;
    I[f] << a.dot(a), a.dot(b), a.dot(b), b.dot(b);
  }
}

}  // namespace shapemap
