// Per-element Jacobians of piecewise-linear maps.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace shapemap {

// Rest-shape inverse edge matrices of tets: Dm_inv[t] = [X1-X0, X2-X0, X3-X0]^{-1}.
std::vector<Eigen::Matrix3d> tet_rest_inverse(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);

// Jacobians J_t = [x1-x0, x2-x0, x3-x0] * Dm_inv[t] of the map V_rest -> X (3×3 each).
// Parallel over tets.
void tet_jacobians(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T,
                   const std::vector<Eigen::Matrix3d>& Dm_inv, std::vector<Eigen::Matrix3d>& J);

// Triangles: per-face 2×2 Jacobian of the map from the rest triangle (in its own
// orthonormal 2D frame) to the deformed triangle (in its own frame), i.e. the
// intrinsic deformation gradient. Columns of the first fundamental form:
// the metric tensor of the deformed triangle pulled back to the rest frame is J^T J.
void triangle_jacobians(const Eigen::MatrixXd& V_rest, const Eigen::MatrixXd& X,
                        const Eigen::MatrixXi& F, std::vector<Eigen::Matrix2d>& J);

// Triangle first fundamental forms in edge coordinates: I_f = E^T E with E = [x1-x0, x2-x0]
// (3×2), so the rest-to-deformed distortion tensor is Ibar^{-1} I (elastic-correspondence Eq. 7).
void first_fundamental_forms(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F,
                             std::vector<Eigen::Matrix2d>& I);

}  // namespace shapemap
