// The ARAP distortion of a piecewise-linear volume map with signed singular values,
// symmetric-volume-maps Sec. 3.3 (sARAP = average of the ARAP energies of the forward
// and backward maps) and Sec. 4.3.2 (Eqs. 19, 20, gradient Eq. 26).
//
//   f_ARAP(J) = sum_j (sigma_j - 1)^2                              (Eq. 19)
//   sigma: signed singular values of J, Irving et al. 2004 convention (U, V in SO(3),
//   the smallest carries sign(det J)), from shapemap::signed_svd3; equivalently
//   f_ARAP(J) = min_{R in SO(3)} ||J - R||_F^2, finite for inverted and flat tets.
//
//   E_ARAP[X] = 1/(2c) sum_k v(T_k) f_ARAP(J(X^{T_k}))             (Eq. 20, one direction)
//   c: total volume of the source mesh, v(T_k): rest volume of tet k.
//
//   dE/dX^{T_k} = w_k ((B V^{T_k})^{-T} B)^T (U diag(grad_sigma f) V^T)^T   (Eq. 26)
//
//   Hessian (projected Newton, issue 19): f = ||J - R||^2 has, in the signed SVD frame
//   J = U diag(sigma) V^T, the eigenpairs (Smith, de Goes, Kim 2019, "Analytic Eigensystems
//   for Isotropic Distortion Energies", Sec. 5): 2 on the 3 scaling and 3 flip modes, and
//   2 - 4/(sigma_j + sigma_k) on the twist mode U (e_k e_j^T - e_j e_k^T) V^T / sqrt(2) of
//   each pair j < k. With the signed convention sigma_j + sigma_k >= 0; clamping the twist
//   eigenvalues at 0 gives the closest positive semi-definite matrix.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace shapemap {

// Eq. 19 on a vector of signed singular values; writes d f / d sigma if grad != nullptr.
double arap_distortion(const Eigen::Vector3d& sigma, Eigen::Vector3d* grad = nullptr);

// Eq. 19 on a Jacobian (signed SVD inside); writes d f / d J (3×3) if grad != nullptr.
double arap_distortion(const Eigen::Matrix3d& J, Eigen::Matrix3d* grad = nullptr);

// d^2 f(J(x)) / dx^2 of one tet (12×12, corner-major: row 3a+c is coordinate c of corner a)
// for J = [x1-x0, x2-x0, x3-x0] Dm_inv, times `scale`. With `project`, the twist eigenvalues are clamped at 0 (positive
// semi-definite); without, exact (where sigma_j + sigma_k > 0).
Eigen::Matrix<double, 12, 12> arap_tet_hessian(const Eigen::Matrix<double, 4, 3>& x,
                                               const Eigen::Matrix3d& Dm_inv, double scale,
                                               bool project = true);

// The post-repair penalty of the authors' released code (issue 19): f_ARAP plus
//   weight * sum_j ((floor - sigma_j) / floor)^6   for each signed sigma_j < floor,
// which rises steeply as a tet flattens or turns over (ARAP alone stays finite, so moving
// the corners of one inverted tet can turn its neighbours over). floor <= 0: no penalty.
struct SigmaPenalty {
  double floor = 0.1;
  double weight = 1.0;
};

// Eq. 19 plus the penalty on a Jacobian (signed SVD inside); d/dJ into grad if non-null.
double penalized_arap_distortion(const Eigen::Matrix3d& J, const SigmaPenalty& pen,
                                 Eigen::Matrix3d* grad = nullptr);

class BlockHessian;

// Eq. 20 for one map of a fixed source tet mesh: precompute, then evaluate many X.
// Evaluation is parallel over tets and deterministic (per-tet values are written into
// arrays and summed serially; vertex gradients are gathered per vertex in a fixed order).
// Not thread-safe: one evaluation at a time per object (internal scratch buffers).
class ArapEnergy {
 public:
  ArapEnergy() = default;
  // V: n×3 rest positions, T: m×4 positively oriented tets. Weights w_k = v(T_k)/(2c)
  // with c = total volume (Eq. 20).
  ArapEnergy(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) { build(V, T); }
  void build(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);

  // E_ARAP[X] (Eq. 20); X: n×3 mapped positions. grad (n×3, resized) if non-null.
  double energy(const Eigen::MatrixXd& X, Eigen::MatrixXd* grad = nullptr) const;
  // The same sum restricted to the listed tets (the others are held constant and
  // left out); grad (n×3, resized, zero outside those tets) if non-null.
  double energy(const Eigen::MatrixXd& X, const std::vector<int>& tets,
                Eigen::MatrixXd* grad) const;
  // The same with f_ARAP replaced by penalized_arap_distortion (post-repair).
  double energy(const Eigen::MatrixXd& X, const std::vector<int>& tets, Eigen::MatrixXd* grad,
                const SigmaPenalty& pen) const;

  // Adds scale × the projected Hessian of E_ARAP (Eq. 20) at X to H (over all tets, or over
  // `tets` when non-null). Per-tet Hessians are computed in parallel into scratch and added
  // serially in tet order (deterministic).
  void add_hessian(const Eigen::MatrixXd& X, double scale, BlockHessian& H,
                   const std::vector<int>* tets = nullptr) const;

  // f_ARAP(J_k) per tet (m), without weights.
  Eigen::VectorXd per_tet(const Eigen::MatrixXd& X) const;
  // det J_k per tet (m); <= 0 means inverted or flat (Algorithm 1, line 13).
  Eigen::VectorXd determinants(const Eigen::MatrixXd& X) const;

  const Eigen::VectorXd& weights() const { return w_; }  // v(T_k)/(2c), m
  const Eigen::MatrixXi& tets() const { return T_; }
  const std::vector<Eigen::Matrix3d>& rest_inverse() const { return Dm_inv_; }
  int num_vertices() const { return n_; }
  int num_tets() const { return int(T_.rows()); }

 private:
  int n_ = 0;
  Eigen::MatrixXi T_;
  std::vector<Eigen::Matrix3d> Dm_inv_;
  Eigen::VectorXd w_;
  std::vector<int> vt_start_, vt_list_;  // vertex -> 4*tet + corner, CSR, sorted
  mutable Eigen::VectorXd tet_e_;
  mutable std::vector<Eigen::Matrix<double, 4, 3>> tet_g_;
  mutable std::vector<Eigen::Matrix<double, 12, 12>> tet_h_;
};

}  // namespace shapemap
