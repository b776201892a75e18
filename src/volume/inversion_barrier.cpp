// The landing's barrier against inverted tets (inversion_barrier.h).
#include "shapemap/volume/inversion_barrier.h"
#include "shapemap/optim/block_hessian.h"
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

namespace shapemap {

double clamped_log_barrier(double d, double d0, double* d1, double* d2) {
  if (d1) *d1 = 0;
  if (d2) *d2 = 0;
  if (!(d > 0)) return std::numeric_limits<double>::infinity();
  if (d >= d0) return 0;
  const double e = d - d0, l = std::log(d / d0);
  if (d1) *d1 = -2.0 * e * l - e * e / d;
  if (d2) *d2 = -2.0 * l - 4.0 * e / d + e * e / (d * d);
  return -e * e * l;
}

namespace {
// The corner gradients g_a of J = sum_a x_a g_a^T (g_0 = -(sum of Dm_inv's rows)).
Eigen::Matrix<double, 4, 3> corner_gradients(const Eigen::Matrix3d& Dm_inv) {
  Eigen::Matrix<double, 4, 3> G;
  G.bottomRows<3>() = Dm_inv;
  G.row(0) = -Dm_inv.colwise().sum();
  return G;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v(2), v(1), v(2), 0, -v(0), -v(1), v(0), 0;
  return S;
}
}  // namespace

Eigen::Matrix<double, 12, 12> barrier_tet_hessian(const Eigen::Matrix<double, 4, 3>& x,
                                                  const Eigen::Matrix3d& Dm_inv, double d0,
                                                  double scale, bool project) {
  const Eigen::Matrix<double, 4, 3> G = corner_gradients(Dm_inv);
  const Eigen::Matrix3d J = x.transpose() * G;  // sum_a x_a g_a^T
  const Eigen::Vector3d f0 = J.col(0), f1 = J.col(1), f2 = J.col(2);
  double b1 = 0, b2 = 0;
  clamped_log_barrier(J.determinant(), d0, &b1, &b2);
  // In vec(J) (column m, row c -> 3m + c): d det / d f_m are the cofactor columns, and the
  // second derivatives are the cross-product blocks d^2 det / d f_m d f_n.
  Eigen::Matrix<double, 9, 1> cof;
  cof << f1.cross(f2), f2.cross(f0), f0.cross(f1);
  Eigen::Matrix<double, 9, 9> Hd = Eigen::Matrix<double, 9, 9>::Zero();
  Hd.block<3, 3>(0, 3) = -skew(f2);
  Hd.block<3, 3>(0, 6) = skew(f1);
  Hd.block<3, 3>(3, 6) = -skew(f0);
  Hd.block<3, 3>(3, 0) = skew(f2);
  Hd.block<3, 3>(6, 0) = -skew(f1);
  Hd.block<3, 3>(6, 3) = skew(f0);
  const Eigen::Matrix<double, 9, 9> HJ = b2 * cof * cof.transpose() + b1 * Hd;
  // vec(J) = K x with K(3m + c, 3a + c) = g_a(m).
  Eigen::Matrix<double, 9, 12> K = Eigen::Matrix<double, 9, 12>::Zero();
  for (int a = 0; a < 4; ++a)
    for (int m = 0; m < 3; ++m)
      for (int c = 0; c < 3; ++c) K(3 * m + c, 3 * a + c) = G(a, m);
  Eigen::Matrix<double, 12, 12> H = K.transpose() * HJ * K;
  if (project) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> es(H);
    const Eigen::Matrix<double, 12, 1> lam = es.eigenvalues().cwiseMax(0.0);
    H = es.eigenvectors() * lam.asDiagonal() * es.eigenvectors().transpose();
  }
  return scale * H;
}

void InversionBarrier::activate_positive(const Eigen::MatrixXd& X) {
  active_.clear();
  if (d0_ <= 0) return;
  const Eigen::VectorXd d = arap_.determinants(X);
  for (int k = 0; k < d.size(); ++k)
    if (d(k) > 0) active_.push_back(k);
}

// Determinants in parallel, terms summed serially in tet order (deterministic).
double InversionBarrier::energy(const Eigen::MatrixXd& X, Eigen::MatrixXd* grad) const {
  if (active_.empty()) return 0;
  const Eigen::MatrixXi& T = arap_.tets();
  const auto& Dm_inv = arap_.rest_inverse();
  const int m = int(active_.size());
  det_.resize(m);
#pragma omp parallel for schedule(static)
  for (int q = 0; q < m; ++q) {
    const int k = active_[q];
    Eigen::Matrix3d Ds;
    for (int j = 0; j < 3; ++j) Ds.col(j) = (X.row(T(k, j + 1)) - X.row(T(k, 0))).transpose();
    det_(q) = (Ds * Dm_inv[k]).determinant();
  }
  double E = 0;
  for (int q = 0; q < m; ++q) {
    if (det_(q) >= d0_) continue;
    const int k = active_[q];
    double b1 = 0;
    E += arap_.weights()(k) * clamped_log_barrier(det_(q), d0_, grad ? &b1 : nullptr);
    if (!std::isfinite(E)) return E;
    if (!grad) continue;
    // d det / d x_a = cof(J) g_a; cof(J)'s columns are f1 x f2, f2 x f0, f0 x f1.
    Eigen::Matrix3d Ds;
    for (int j = 0; j < 3; ++j) Ds.col(j) = (X.row(T(k, j + 1)) - X.row(T(k, 0))).transpose();
    const Eigen::Matrix3d J = Ds * Dm_inv[k];
    Eigen::Matrix3d P;
    P << J.col(1).cross(J.col(2)), J.col(2).cross(J.col(0)), J.col(0).cross(J.col(1));
    P *= arap_.weights()(k) * b1;
    const Eigen::Matrix<double, 4, 3> G = corner_gradients(Dm_inv[k]);
    for (int a = 0; a < 4; ++a) grad->row(T(k, a)) += (P * G.row(a).transpose()).transpose();
  }
  return E;
}

void InversionBarrier::add_hessian(const Eigen::MatrixXd& X, double scale, BlockHessian& H) const {
  const Eigen::MatrixXi& T = arap_.tets();
  const auto& Dm_inv = arap_.rest_inverse();
  for (int k : active_) {
    Eigen::Matrix<double, 4, 3> x;
    for (int a = 0; a < 4; ++a) x.row(a) = X.row(T(k, a));
    Eigen::Matrix3d Ds;
    for (int j = 0; j < 3; ++j) Ds.col(j) = (x.row(j + 1) - x.row(0)).transpose();
    const double d = (Ds * Dm_inv[k]).determinant();
    if (!(d > 0) || d >= d0_) continue;
    H.add_element(k, barrier_tet_hessian(x, Dm_inv[k], d0_, scale * arap_.weights()(k), true));
  }
}

}  // namespace shapemap
