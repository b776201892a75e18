// ARAP distortion with signed singular values: symmetric-volume-maps Eqs. 19, 20, 26.
#include "shapemap/volume/sarap.h"
#include "shapemap/error.h"
#include "shapemap/geometry/jacobian.h"
#include "shapemap/geometry/svd3.h"
#include "shapemap/optim/block_hessian.h"
#include <Eigen/Dense>
#include <cmath>

namespace shapemap {

namespace {
// Signed polar rotation of a 3x3 M: R = argmax_{R in SO(3)} tr(R^T M) and lambda = that max
// (= s1 + s2 + sign(det M) s3, the sum of the signed singular values), by the largest
// eigenvalue of Horn's 4x4 quaternion matrix (Newton on its characteristic polynomial,
// Theobald 2005) and its eigenvector from the adjugate. Returns false when the largest
// eigenvalue is not well separated (then the caller uses the SVD).
inline bool signed_polar_qcp(const Eigen::Matrix3d& M, Eigen::Matrix3d& R, double& lambda) {
  const double Sxx = M(0, 0), Sxy = M(0, 1), Sxz = M(0, 2), Syx = M(1, 0), Syy = M(1, 1),
               Syz = M(1, 2), Szx = M(2, 0), Szy = M(2, 1), Szz = M(2, 2);
  Eigen::Matrix4d N;
  N << Sxx + Syy + Szz, Szy - Syz, Sxz - Szx, Syx - Sxy,
       Szy - Syz, Sxx - Syy - Szz, Sxy + Syx, Szx + Sxz,
       Sxz - Szx, Sxy + Syx, -Sxx + Syy - Szz, Syz + Szy,
       Syx - Sxy, Szx + Sxz, Syz + Szy, -Sxx - Syy + Szz;
  const double s2 = M.squaredNorm();
  if (!(s2 > 1e-200 && s2 < 1e200)) return false;
  const Eigen::Matrix4d N2 = N * N;
  const double p2 = N2.trace();                 // = 4 s2
  const double p3 = (N2.cwiseProduct(N)).sum();  // tr(N^3), N symmetric
  const double c2 = -0.5 * p2, c1 = -p3 / 3.0, c0 = N.determinant();
  // Newton from an upper bound of the largest root: lambda_max <= sqrt(3) ||M||_F.
  double l = std::sqrt(3.0 * s2);
  for (int it = 0; it < 50; ++it) {
    const double l2 = l * l;
    const double P = (l2 + c2) * l2 + c1 * l + c0;
    const double dP = 4 * l2 * l + 2 * c2 * l + c1;
    if (!(dP > 0)) break;
    const double step = P / dP;
    l -= step;
    if (std::abs(step) <= 1e-15 * std::abs(l) + 1e-300) break;
  }
  const double l2 = l * l;
  const double dP = 4 * l2 * l + 2 * c2 * l + c1;  // product of the gaps to the other roots
  const double s = std::sqrt(s2);
  if (!(dP > 1e-3 * s2 * s)) return false;  // the largest root is not well separated
  const double P = (l2 + c2) * l2 + c1 * l + c0;
  if (!(std::abs(P) <= 1e-11 * s2 * s2)) return false;  // Newton did not converge
  // Eigenvector: adj(N - l I) = (prod of the gaps) q q^T, so its diagonal is proportional
  // to q_j^2; take the column j of the largest diagonal entry (|q_j| >= 1/2).
  Eigen::Matrix4d A = N;
  A.diagonal().array() -= l;
  auto cofactor = [&A](int i, int j) {  // (-1)^(i+j) det(A without row i, column j)
    int r[3], c[3];
    for (int a = 0, k = 0; a < 4; ++a)
      if (a != i) r[k++] = a;
    for (int a = 0, k = 0; a < 4; ++a)
      if (a != j) c[k++] = a;
    const double m =
        A(r[0], c[0]) * (A(r[1], c[1]) * A(r[2], c[2]) - A(r[1], c[2]) * A(r[2], c[1])) -
        A(r[0], c[1]) * (A(r[1], c[0]) * A(r[2], c[2]) - A(r[1], c[2]) * A(r[2], c[0])) +
        A(r[0], c[2]) * (A(r[1], c[0]) * A(r[2], c[1]) - A(r[1], c[1]) * A(r[2], c[0]));
    return ((i + j) & 1) ? -m : m;
  };
  double d[4];
  int best = 0;
  for (int j = 0; j < 4; ++j) {
    d[j] = cofactor(j, j);
    if (std::abs(d[j]) > std::abs(d[best])) best = j;
  }
  Eigen::Vector4d q;
  for (int i = 0; i < 4; ++i) q(i) = i == best ? d[best] : cofactor(best, i);  // adj(i, best)
  const double qn = q.norm();
  if (!(qn > 0)) return false;
  q /= qn;
  const double w = q(0), x = q(1), y = q(2), z = q(3);
  R << w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y),
       2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x),
       2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z;
  lambda = l;
  return true;
}
}  // namespace

double arap_distortion(const Eigen::Vector3d& sigma, Eigen::Vector3d* grad) {
  Eigen::Vector3d d = sigma.array() - 1.0;
  if (grad) *grad = 2.0 * d;
  return d.squaredNorm();
}

// f_ARAP(J) = sum_j (sigma_j - 1)^2 = ||J - R||_F^2 with R = U V^T the rotation of the signed
// SVD (the closest rotation to J), and grad f = U diag(2(sigma - 1)) V^T = 2 (J - R). R comes
// from signed_polar_qcp when the largest eigenvalue of Horn's matrix is well separated
// (the same R to ~1e-12, about twice as fast as the SVD); otherwise (flat tets, inverted
// tets with |sigma_3| ~ sigma_2, non-finite input) from signed_svd3.
double arap_distortion(const Eigen::Matrix3d& J, Eigen::Matrix3d* grad) {
  Eigen::Matrix3d R;
  double lambda;
  if (signed_polar_qcp(J, R, lambda)) {
    const Eigen::Matrix3d D = J - R;
    if (grad) *grad = 2.0 * D;
    return D.squaredNorm();
  }
  SignedSVD3 s = signed_svd3(J);
  Eigen::Vector3d gs;
  double f = arap_distortion(s.S, grad ? &gs : nullptr);
  if (grad) *grad = s.U * gs.asDiagonal() * s.V.transpose();  // Sec. 5.2: U diag(grad f) V^T
  return f;
}

double penalized_arap_distortion(const Eigen::Matrix3d& J, const SigmaPenalty& pen,
                                 Eigen::Matrix3d* grad) {
  double f = arap_distortion(J, grad);
  if (!(pen.floor > 0) || pen.weight == 0) return f;
  const SignedSVD3 s = signed_svd3(J);
  if (s.S.minCoeff() >= pen.floor) return f;
  // d sigma_j / d J = u_j v_j^T (distinct singular values; ties have measure zero).
  Eigen::Vector3d gp = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j) {
    const double t = (pen.floor - s.S(j)) / pen.floor;
    if (t <= 0) continue;
    const double t5 = t * t * t * t * t;
    f += pen.weight * t5 * t;
    gp(j) = -6.0 * pen.weight * t5 / pen.floor;
  }
  if (grad) *grad += s.U * gp.asDiagonal() * s.V.transpose();
  return f;
}

Eigen::Matrix<double, 12, 12> arap_tet_hessian(const Eigen::Matrix<double, 4, 3>& x,
                                               const Eigen::Matrix3d& Dm_inv, double scale,
                                               bool project) {
  // J = sum_a x_a g_a^T with g_0 = -(sum of Dm_inv's rows), g_a = row a-1 of Dm_inv. With
  // H_J = 2 I + sum_t mu_t q_t q_t^T (sarap.h: mu_t = lambda_t - 2 for the twists), block (a, b) of the tet Hessian is
  // 2 (g_a . g_b) I_3 + sum_t mu_t (Q_t g_a)(Q_t g_b)^T: no 9×12 products needed.
  Eigen::Matrix<double, 4, 3> G;
  G.bottomRows<3>() = Dm_inv;
  G.row(0) = -Dm_inv.colwise().sum();
  Eigen::Matrix3d Ds;
  for (int j = 0; j < 3; ++j) Ds.col(j) = (x.row(j + 1) - x.row(0)).transpose();
  const SignedSVD3 s = signed_svd3(Ds * Dm_inv);
  const Eigen::Matrix4d GG = G * G.transpose();
  Eigen::Matrix<double, 12, 12> H = Eigen::Matrix<double, 12, 12>::Zero();
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) H.block<3, 3>(3 * a, 3 * b).diagonal().setConstant(2.0 * GG(a, b));
  const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (const auto& p : pairs) {
    const int j = p[0], k = p[1];
    const double sum = s.S(j) + s.S(k);
    double lambda = sum > 0 ? 2.0 - 4.0 / sum : 0.0;
    if (project) lambda = std::max(lambda, 0.0);
    if (lambda == 2.0) continue;
    const Eigen::Matrix3d Q = (s.U.col(k) * s.V.col(j).transpose() - s.U.col(j) * s.V.col(k).transpose()) /
                              std::sqrt(2.0);
    Eigen::Matrix<double, 12, 1> v;
    for (int a = 0; a < 4; ++a) v.segment<3>(3 * a) = Q * G.row(a).transpose();
    H.noalias() += (lambda - 2.0) * v * v.transpose();
  }
  return scale * H;
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
// pen: the post-repair penalty (SigmaPenalty), or nullptr for Eq. 19 alone.
inline double tet_term(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T, int k,
                       const Eigen::Matrix3d& Dm_inv, double w, Eigen::Matrix<double, 4, 3>* g,
                       const SigmaPenalty* pen = nullptr) {
  Eigen::Matrix3d Ds;
  for (int j = 0; j < 3; ++j) Ds.col(j) = (X.row(T(k, j + 1)) - X.row(T(k, 0))).transpose();
  Eigen::Matrix3d J = Ds * Dm_inv;
  if (!g) return w * (pen ? penalized_arap_distortion(J, *pen) : arap_distortion(J, nullptr));
  Eigen::Matrix3d G;
  double f = pen ? penalized_arap_distortion(J, *pen, &G) : arap_distortion(J, &G);
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
  return energy(X, tets, grad, SigmaPenalty{0.0, 0.0});
}

double ArapEnergy::energy(const Eigen::MatrixXd& X, const std::vector<int>& tets,
                          Eigen::MatrixXd* grad, const SigmaPenalty& pen) const {
  const int m = int(tets.size());
  if (X.rows() != n_ || X.cols() != 3) throw Error("ArapEnergy: X must be n×3");
  const SigmaPenalty* p = pen.floor > 0 && pen.weight != 0 ? &pen : nullptr;
  // A vertex's few tets (the landing's guards, one call per move) are not worth a parallel region.
#pragma omp parallel for schedule(static) if (m > 256)
  for (int q = 0; q < m; ++q) {
    int k = tets[q];
    tet_e_(k) = tet_term(X, T_, k, Dm_inv_[k], w_(k), grad ? &tet_g_[k] : nullptr, p);
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

void ArapEnergy::add_hessian(const Eigen::MatrixXd& X, double scale, BlockHessian& H,
                             const std::vector<int>* tets) const {
  const int m = tets ? int(tets->size()) : int(T_.rows());
  if (X.rows() != n_ || X.cols() != 3) throw Error("ArapEnergy: X must be n×3");
  tet_h_.resize(T_.rows());
#pragma omp parallel for schedule(static)
  for (int q = 0; q < m; ++q) {
    const int k = tets ? (*tets)[q] : q;
    Eigen::Matrix<double, 4, 3> x;
    for (int a = 0; a < 4; ++a) x.row(a) = X.row(T_(k, a));
    tet_h_[k] = arap_tet_hessian(x, Dm_inv_[k], scale * w_(k), true);
  }
  for (int q = 0; q < m; ++q) {
    const int k = tets ? (*tets)[q] : q;
    H.add_element(k, tet_h_[k]);
  }
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
