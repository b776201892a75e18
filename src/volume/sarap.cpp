// ARAP distortion with signed singular values: symmetric-volume-maps Eqs. 19, 20, 26.
#include "shapemap/volume/sarap.h"
#include "shapemap/error.h"
#include "shapemap/geometry/jacobian.h"
#include "shapemap/geometry/svd3.h"
#include <Eigen/Dense>
#include <cmath>

namespace shapemap {

double arap_distortion(const Eigen::Vector3d& sigma, Eigen::Vector3d* grad) {
  Eigen::Vector3d d = sigma.array() - 1.0;
  if (grad) *grad = 2.0 * d;
  return d.squaredNorm();
}

double arap_distortion(const Eigen::Matrix3d& J, Eigen::Matrix3d* grad) {
  SignedSVD3 s = signed_svd3(J);
  Eigen::Vector3d gs;
  double f = arap_distortion(s.S, grad ? &gs : nullptr);
  if (grad) *grad = s.U * gs.asDiagonal() * s.V.transpose();  // Sec. 5.2: U diag(grad f) V^T
  return f;
}

void ArapEnergy::build(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  if (T.cols() != 4) throw Error("ArapEnergy: T must be m×4");
  n_ = int(V.rows());
  T_ = T;
  Dm_inv_ = tet_rest_inverse(V, T);
  const int m = int(T.rows());
  w_.resize(m);
  double c = 0;
  for (int k = 0; k < m; ++k) {
    Eigen::Matrix3d Dm;
    for (int j = 0; j < 3; ++j) Dm.col(j) = (V.row(T(k, j + 1)) - V.row(T(k, 0))).transpose();
    w_(k) = std::abs(Dm.determinant()) / 6.0;
    c += w_(k);
  }
  if (!(c > 0)) throw Error("ArapEnergy: mesh has zero volume");
  w_ /= 2.0 * c;  // Eq. 20: v(T_k) / (2 c)
  // vertex -> (tet, corner), in increasing order of 4*tet+corner (fixed gather order)
  vt_start_.assign(n_ + 1, 0);
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < 4; ++j) vt_start_[T(k, j) + 1]++;
  for (int i = 0; i < n_; ++i) vt_start_[i + 1] += vt_start_[i];
  vt_list_.resize(4 * m);
  std::vector<int> fill(vt_start_.begin(), vt_start_.end() - 1);
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < 4; ++j) vt_list_[fill[T(k, j)]++] = 4 * k + j;
  tet_e_.resize(m);
  tet_g_.resize(m);
}

namespace {
// Energy and Eq. 26 gradient of one tet; g rows = vertices 0..3.
inline double tet_term(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T, int k,
                       const Eigen::Matrix3d& Dm_inv, double w, Eigen::Matrix<double, 4, 3>* g) {
  Eigen::Matrix3d Ds;
  for (int j = 0; j < 3; ++j) Ds.col(j) = (X.row(T(k, j + 1)) - X.row(T(k, 0))).transpose();
  Eigen::Matrix3d J = Ds * Dm_inv;
  if (!g) return w * arap_distortion(J, nullptr);
  Eigen::Matrix3d G;
  double f = arap_distortion(J, &G);
  // d f / d Ds = G Dm_inv^T; columns -> vertices 1..3, vertex 0 gets minus their sum.
  Eigen::Matrix3d H = w * G * Dm_inv.transpose();
  for (int j = 0; j < 3; ++j) g->row(j + 1) = H.col(j).transpose();
  g->row(0) = -(H.col(0) + H.col(1) + H.col(2)).transpose();
  return w * f;
}
}  // namespace

double ArapEnergy::energy(const Eigen::MatrixXd& X, Eigen::MatrixXd* grad) const {
  const int m = int(T_.rows());
  if (X.rows() != n_ || X.cols() != 3) throw Error("ArapEnergy: X must be n×3");
#pragma omp parallel for schedule(static)
  for (int k = 0; k < m; ++k)
    tet_e_(k) = tet_term(X, T_, k, Dm_inv_[k], w_(k), grad ? &tet_g_[k] : nullptr);
  double E = 0;
  for (int k = 0; k < m; ++k) E += tet_e_(k);
  if (grad) {
    grad->resize(n_, 3);
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n_; ++i) {
      Eigen::RowVector3d s = Eigen::RowVector3d::Zero();
      for (int p = vt_start_[i]; p < vt_start_[i + 1]; ++p) {
        int code = vt_list_[p];
        s += tet_g_[code >> 2].row(code & 3);
      }
      grad->row(i) = s;
    }
  }
  return E;
}

double ArapEnergy::energy(const Eigen::MatrixXd& X, const std::vector<int>& tets,
                          Eigen::MatrixXd* grad) const {
  const int m = int(tets.size());
  if (X.rows() != n_ || X.cols() != 3) throw Error("ArapEnergy: X must be n×3");
#pragma omp parallel for schedule(static)
  for (int q = 0; q < m; ++q) {
    int k = tets[q];
    tet_e_(k) = tet_term(X, T_, k, Dm_inv_[k], w_(k), grad ? &tet_g_[k] : nullptr);
  }
  double E = 0;
  for (int q = 0; q < m; ++q) E += tet_e_(tets[q]);
  if (grad) {
    grad->setZero(n_, 3);
    for (int q = 0; q < m; ++q) {  // serial scatter: fixed order
      int k = tets[q];
      for (int j = 0; j < 4; ++j) grad->row(T_(k, j)) += tet_g_[k].row(j);
    }
  }
  return E;
}

Eigen::VectorXd ArapEnergy::per_tet(const Eigen::MatrixXd& X) const {
  const int m = int(T_.rows());
  Eigen::VectorXd f(m);
#pragma omp parallel for schedule(static)
  for (int k = 0; k < m; ++k) f(k) = tet_term(X, T_, k, Dm_inv_[k], 1.0, nullptr);
  return f;
}

Eigen::VectorXd ArapEnergy::determinants(const Eigen::MatrixXd& X) const {
  const int m = int(T_.rows());
  Eigen::VectorXd d(m);
#pragma omp parallel for schedule(static)
  for (int k = 0; k < m; ++k) {
    Eigen::Matrix3d Ds;
    for (int j = 0; j < 3; ++j) Ds.col(j) = (X.row(T_(k, j + 1)) - X.row(T_(k, 0))).transpose();
    d(k) = (Ds * Dm_inv_[k]).determinant();
  }
  return d;
}

}  // namespace shapemap
