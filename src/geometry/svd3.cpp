// Signed 3×3 SVD (Irving et al. 2004, "Invertible finite elements", Sec. 5).
//
// Fast path (McAdams et al. 2011 structure, in double and iterated to convergence):
// cyclic Jacobi on A^T A gives V; B = A V has (nearly) orthogonal columns, sorted by norm;
// a Givens QR of B gives the rotation U and R = U^T A V, upper triangular with a
// non-negative leading diagonal, so diag(R) are the signed singular values. Since A = U R V^T
// holds to roundoff, the off-diagonal part of R that is dropped is exactly the reconstruction
// error: if it is not tiny (close singular values near sqrt(eps), non-finite input, ...), the
// matrix goes to Eigen's two-sided Jacobi SVD, which is robust for any input.
#include "shapemap/geometry/svd3.h"
#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>
#include <utility>

namespace shapemap {

namespace {

// Reference path: two-sided Jacobi SVD (Eigen rescales by the largest entry, so tiny and
// huge matrices are fine); then flip last columns to make U, V proper rotations, each flip
// moving a sign onto the smallest singular value, which ends up with sign(det A).
SignedSVD3 signed_svd3_robust(const Eigen::Matrix3d& A) {
  Eigen::JacobiSVD<Eigen::Matrix3d, Eigen::NoQRPreconditioner> svd(
      A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  SignedSVD3 r;
  r.U = svd.matrixU();
  r.V = svd.matrixV();
  r.S = svd.singularValues();
  if (r.U.determinant() < 0) {
    r.U.col(2) = -r.U.col(2);
    r.S(2) = -r.S(2);
  }
  if (r.V.determinant() < 0) {
    r.V.col(2) = -r.V.col(2);
    r.S(2) = -r.S(2);
  }
  return r;
}

// Accept the fast result when the dropped off-diagonal of R is below this times ||A||_F.
constexpr double kAcceptTol = 1e-14;

bool signed_svd3_fast(const Eigen::Matrix3d& A, SignedSVD3& r) {
  const double norm2 = A.squaredNorm();
  if (!(norm2 > 1e-200 && norm2 < 1e200)) return false;  // zero, tiny, huge or non-finite
  // 1. Jacobi eigen-decomposition of the symmetric S = A^T A.
  Eigen::Matrix3d S = A.transpose() * A;
  Eigen::Matrix3d V = Eigen::Matrix3d::Identity();
  const double tol2 = 1e-32 * S.squaredNorm();
  for (int sweep = 0; sweep < 12; ++sweep) {
    const double off = S(0, 1) * S(0, 1) + S(0, 2) * S(0, 2) + S(1, 2) * S(1, 2);
    if (off <= tol2) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        const double spq = S(p, q);
        if (spq == 0) continue;
        // Rotation zeroing S(p,q) (Golub & Van Loan Alg. 8.4.1, the smaller angle).
        const double theta = (S(q, q) - S(p, p)) / (2 * spq);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        // S <- G^T S G, V <- V G with G = [[c, s], [-s, c]] on (p, q).
        for (int k = 0; k < 3; ++k) {
          const double skp = S(k, p), skq = S(k, q);
          S(k, p) = c * skp - s * skq;
          S(k, q) = s * skp + c * skq;
        }
        for (int k = 0; k < 3; ++k) {
          const double spk = S(p, k), sqk = S(q, k);
          S(p, k) = c * spk - s * sqk;
          S(q, k) = s * spk + c * sqk;
        }
        for (int k = 0; k < 3; ++k) {
          const double vkp = V(k, p), vkq = V(k, q);
          V(k, p) = c * vkp - s * vkq;
          V(k, q) = s * vkp + c * vkq;
        }
      }
  }
  // 2. B = A V, columns sorted by decreasing norm; a swap negates one column to keep det V = 1.
  Eigen::Matrix3d B = A * V;
  double rho[3] = {B.col(0).squaredNorm(), B.col(1).squaredNorm(), B.col(2).squaredNorm()};
  auto swap_cols = [&](int i, int j) {
    B.col(i).swap(B.col(j));
    V.col(i).swap(V.col(j));
    B.col(j) = -B.col(j);
    V.col(j) = -V.col(j);
    std::swap(rho[i], rho[j]);
  };
  if (rho[0] < rho[1]) swap_cols(0, 1);
  if (rho[0] < rho[2]) swap_cols(0, 2);
  if (rho[1] < rho[2]) swap_cols(1, 2);
  // 3. Givens QR of B: U accumulates the rotations, B becomes R.
  Eigen::Matrix3d U = Eigen::Matrix3d::Identity();
  auto givens = [&](int p, int q, int col) {  // zero B(q, col) against B(p, col)
    const double a = B(p, col), b = B(q, col);
    const double h = std::sqrt(a * a + b * b);  // no overflow: ||A|| is bounded above
    if (h == 0) return;
    const double c = a / h, s = b / h;
    for (int k = 0; k < 3; ++k) {
      const double bp = B(p, k), bq = B(q, k);
      B(p, k) = c * bp + s * bq;
      B(q, k) = -s * bp + c * bq;
      const double up = U(k, p), uq = U(k, q);
      U(k, p) = c * up + s * uq;
      U(k, q) = -s * up + c * uq;
    }
  };
  givens(0, 1, 0);
  givens(0, 2, 0);
  givens(1, 2, 1);
  // 4. Accept if the dropped upper part is negligible and the order is right.
  const double dropped = B(0, 1) * B(0, 1) + B(0, 2) * B(0, 2) + B(1, 2) * B(1, 2) +
                         B(1, 0) * B(1, 0) + B(2, 0) * B(2, 0) + B(2, 1) * B(2, 1);
  if (!(dropped <= kAcceptTol * kAcceptTol * norm2)) return false;
  const Eigen::Vector3d s(B(0, 0), B(1, 1), B(2, 2));
  if (!(s(0) >= s(1) && s(1) >= std::abs(s(2)))) return false;
  r.U = U;
  r.V = V;
  r.S = s;
  return true;
}

}  // namespace

SignedSVD3 signed_svd3(const Eigen::Matrix3d& A) {
  SignedSVD3 r;
  if (signed_svd3_fast(A, r)) return r;
  return signed_svd3_robust(A);
}

void signed_svd3_batch(const std::vector<Eigen::Matrix3d>& A, std::vector<SignedSVD3>& out) {
  const long n = long(A.size());
  if (long(out.size()) != n) out.resize(n);
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) out[i] = signed_svd3(A[i]);
}

}  // namespace shapemap
