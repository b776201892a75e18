// A barrier against turning tets over, for the landing stage of the symmetric volume map
// (ours, issue 19): the landing pulls X's boundary onto the target's boundary, and with
// ARAP alone (finite for inverted tets) the pull turned hundreds of tets over on real pairs.
//
//   B[X] = sum_{k in active} w_k b(det J_k),   w_k = v(T_k) / (2c) as in Eq. 20,
//   b(d) = -(d - d0)^2 log(d / d0)  for 0 < d < d0,   0 for d >= d0,   +inf for d <= 0
//
// b is the clamped log barrier of Incremental Potential Contact (Li et al. 2020, Eq. 6) on
// the volume ratio det J: C^2 at d0, zero on tets that keep at least d0 of their volume,
// infinite when a tet flattens. A line search that rejects non-finite values therefore
// never turns an active tet over. Tets inverted already are left out of the active set.
#pragma once
#include "shapemap/volume/sarap.h"
#include <Eigen/Core>
#include <vector>

namespace shapemap {

// b(d) and its first two derivatives (d1, d2 if non-null); +inf for d <= 0.
double clamped_log_barrier(double d, double d0, double* d1 = nullptr, double* d2 = nullptr);

// d^2 b(det J(x)) / dx^2 of one tet (12×12, corner-major like arap_tet_hessian), exact
// (project = false) or with negative eigenvalues clamped at 0.
Eigen::Matrix<double, 12, 12> barrier_tet_hessian(const Eigen::Matrix<double, 4, 3>& x,
                                                  const Eigen::Matrix3d& Dm_inv, double d0,
                                                  double scale, bool project = true);

class BlockHessian;

class InversionBarrier {
 public:
  // arap: the source mesh's rest data (Dm^{-1}, weights w_k), kept by reference.
  // d0 <= 0 disables the barrier (energy 0).
  InversionBarrier(const ArapEnergy& arap, double d0) : arap_(arap), d0_(d0) {}
  // The active set: every tet with det J > 0 at X.
  void activate_positive(const Eigen::MatrixXd& X);
  int num_active() const { return int(active_.size()); }
  double floor() const { return d0_; }
  // B[X]; adds its gradient to *grad (n×3, already sized) if non-null.
  double energy(const Eigen::MatrixXd& X, Eigen::MatrixXd* grad) const;
  // Adds scale × the projected Hessian of B at X to H (only tets with det J < d0 contribute).
  void add_hessian(const Eigen::MatrixXd& X, double scale, BlockHessian& H) const;

 private:
  const ArapEnergy& arap_;
  double d0_;
  std::vector<int> active_;
  mutable Eigen::VectorXd det_;
};

}  // namespace shapemap
