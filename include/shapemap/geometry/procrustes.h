// The rotation that best aligns one point set with another (orthogonal Procrustes with the
// reflection excluded; Kabsch 1976, Umeyama 1991): the ball registration's g_s and the rigid
// placement of collapsed surface parts both need it.
#pragma once
#include <Eigen/Core>

namespace shapemap {

// C = sum_i w_i q_i p_i^T (targets q, sources p, both centred when a translation is fitted
// too). Returns the R in SO(3) that minimizes sum_i w_i ||R p_i - q_i||^2, i.e. maximizes
// tr(R^T C): U V^T of C's signed SVD, so a reflection is never returned.
Eigen::Matrix3d procrustes_rotation(const Eigen::Matrix3d& C);

}  // namespace shapemap
