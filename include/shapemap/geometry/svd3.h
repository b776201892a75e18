// Signed 3×3 SVD, Irving et al. 2004 convention: A = U diag(s) V^T with U, V proper
// rotations (det = +1), s sorted descending in absolute value, s0 >= s1 >= |s2|, and
// the smallest singular value s2 carrying the sign of det(A).
#pragma once
#include <Eigen/Core>
#include <vector>

namespace shapemap {

struct SignedSVD3 {
  Eigen::Matrix3d U, V;
  Eigen::Vector3d S;
};

SignedSVD3 signed_svd3(const Eigen::Matrix3d& A);

// Batched, parallel over matrices.
void signed_svd3_batch(const std::vector<Eigen::Matrix3d>& A, std::vector<SignedSVD3>& out);

}  // namespace shapemap
