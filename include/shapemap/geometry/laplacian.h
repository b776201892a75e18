// Cotangent Laplacians. Convention: the returned L is the positive semi-definite
// "stiffness" matrix, L(i,j) = -w_ij for i != j, L(i,i) = sum_j w_ij, so that
// x^T L x = sum_edges w_ij |x_i - x_j|^2 >= 0 (= 2 * Dirichlet energy).
#pragma once
#include <Eigen/Core>
#include <Eigen/Sparse>

namespace shapemap {

// Triangles: w_ij = (cot a_ij + cot b_ij) / 2 over the angles opposite edge ij.
// V n×3, F m×3 -> n×n.
Eigen::SparseMatrix<double> cotan_laplacian(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

// The same with face f's weights divided by sigma(f) (the stretch energy of spherical
// area-preserving maps); a face with sigma(f) not finite and > 0 contributes nothing.
Eigen::SparseMatrix<double> cotan_laplacian(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                            const Eigen::VectorXd& sigma);

// Tets: w_ij = (1/6) sum over tets containing edge ij of l_kl * cot(theta_kl), where kl
// is the opposite edge, l_kl its length and theta_kl the dihedral angle at kl.
// V n×3, T m×4 -> n×n. Also the weights used by the isovolumetric L_V (Eq. 3c).
// L without its negative edge weights (off-diagonal entries > 0, i.e. cotan weights w < 0:
// edges of a non-Delaunay triangulation), the diagonal made minus the sum of what is left:
// an M-matrix (discrete maximum principle) whose rows still sum to zero.
Eigen::SparseMatrix<double> drop_negative_weights(const Eigen::SparseMatrix<double>& L);
Eigen::SparseMatrix<double> tet_cotan_laplacian(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);

// Per-tet cotangent weights, m×6, for the edges (0,1),(0,2),(0,3),(1,2),(1,3),(2,3),
// = (1/6) l_kl cot(theta_kl) of each tet alone (can be negative). Parallel.
Eigen::MatrixXd tet_cotan_weights(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);

// Assembles sum over tets of per-tet edge weights W (m×6, edge order above) into the
// PSD Laplacian pattern. Reuses `L`'s pattern when it already has the right one.
void assemble_tet_laplacian(const Eigen::MatrixXi& T, const Eigen::MatrixXd& W, int num_vertices,
                            Eigen::SparseMatrix<double>& L);

}  // namespace shapemap
