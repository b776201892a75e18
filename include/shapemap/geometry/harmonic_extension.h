// Harmonic extension of values given on some vertices of a tet mesh to the others: the
// Dirichlet problem (L X)_v = 0 at every free vertex v, X fixed elsewhere.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace shapemap {

// V n×3 rest positions, T m×4 tets, X n×d values; rows v with fixed[v] != 0 are kept, the
// others are returned harmonic. L is the tet cotangent Laplacian without its negative
// weights (as drop_negative_weights, laplacian.h) plus 1e-3 of its mean weight on every edge:
// an M-matrix, so every free row is a convex combination of its neighbours' (a free image
// cannot leave the convex hull of the fixed ones) and the free block is positive definite
// when every component has a fixed vertex. The cotangent weights are non-negative on a
// Delaunay-like mesh, and there an affine X on the fixed vertices is extended exactly up
// to the 1e-3 term. Throws shapemap::Error when a component has no fixed vertex.
Eigen::MatrixXd harmonic_extension(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T, const Eigen::MatrixXd& X,
                                   const std::vector<char>& fixed);

}  // namespace shapemap
