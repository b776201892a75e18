// Discrete mean curvature.
#pragma once
#include <Eigen/Core>

namespace shapemap {

// Signed mean curvature per vertex, H = (k1 + k2) / 2, from the mean curvature normal
// (L x)_i / (2 M_ii) with the cotangent Laplacian and Voronoi mass; positive on a
// sphere with outward orientation (H = 1/r).
Eigen::VectorXd mean_curvature(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

}  // namespace shapemap
