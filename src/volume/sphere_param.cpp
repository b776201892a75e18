// Spherical area-preserving map: linear puncture map, conformal energy minimization,
// stretch energy minimization (see the header and docs/methods.md).
#include "shapemap/volume/sphere_param.h"
#include "shapemap/error.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include <Eigen/Geometry>
#include <Eigen/Sparse>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace shapemap {

namespace {

using Plane = Eigen::MatrixXd;  // n×2

// Cotangent Laplacian (PSD convention) of triangles with per-face weight divisors
// sigma (weights cot/2 / sigma_f). P n×3 positions.
Eigen::SparseMatrix<double> weighted_cotan(const Eigen::MatrixXd& P, const Eigen::MatrixXi& F,
                                           const Eigen::VectorXd* sigma) {
  const Eigen::Index m = F.rows();
  std::vector<Eigen::Triplet<double>> trip(size_t(m) * 12);
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < m; ++f) {
    const double s = sigma ? (*sigma)(f) : 1.0;
    for (int c = 0; c < 3; ++c) {
      const int i = F(f, (c + 1) % 3), j = F(f, (c + 2) % 3);
      const Eigen::Vector3d p = P.row(F(f, c));
      const Eigen::Vector3d u = P.row(i).transpose() - p, v = P.row(j).transpose() - p;
      const double cr = u.cross(v).norm();
      const double w = (cr > 0 && s > 0 && std::isfinite(s)) ? 0.5 * u.dot(v) / cr / s : 0.0;
      Eigen::Triplet<double>* out = &trip[size_t(f) * 12 + size_t(c) * 4];
      out[0] = {i, j, -w};
      out[1] = {j, i, -w};
      out[2] = {i, i, w};
      out[3] = {j, j, w};
    }
  }
  Eigen::SparseMatrix<double> L(P.rows(), P.rows());
  L.setFromTriplets(trip.begin(), trip.end());
  L.makeCompressed();
  return L;
}

// Flat triangle areas of P (n×3).
Eigen::VectorXd areas3(const Eigen::MatrixXd& P, const Eigen::MatrixXi& F) {
  Eigen::VectorXd A(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = P.row(F(f, 0)), b = P.row(F(f, 1)), c = P.row(F(f, 2));
    A(f) = 0.5 * (b - a).cross(c - a).norm();
  }
  return A;
}

// 1/2 tr(S^T L S) - A(S): conformal (sigma = 1) or stretch-minus-area energy.
double energy_minus_area(const Eigen::SparseMatrix<double>& L, const Eigen::MatrixXd& S,
                         const Eigen::MatrixXi& F) {
  const Eigen::MatrixXd LS = L * S;
  return 0.5 * S.cwiseProduct(LS).sum() - areas3(S, F).sum();
}

Eigen::MatrixXd inverse_stereographic(const Plane& uv) {
  Eigen::MatrixXd S(uv.rows(), 3);
  for (Eigen::Index i = 0; i < uv.rows(); ++i) {
    const double x = uv(i, 0), y = uv(i, 1);
    if (!std::isfinite(x) || !std::isfinite(y)) {
      S.row(i) << 0, 0, 1;
      continue;
    }
    const double b = 1 + x * x + y * y;
    S.row(i) << 2 * x / b, 2 * y / b, (b - 2) / b;
  }
  return S;
}

// z -> z / |z|^2 (the reflection of the sphere through the equator).
void invert(Plane& uv) {
  for (Eigen::Index i = 0; i < uv.rows(); ++i) {
    const double r2 = uv(i, 0) * uv(i, 0) + uv(i, 1) * uv(i, 1);
    if (r2 == 0) {
      uv(i, 0) = uv(i, 1) = 1e30;
    } else if (!std::isfinite(r2)) {
      uv(i, 0) = uv(i, 1) = 0;
    } else {
      uv(i, 0) /= r2;
      uv(i, 1) /= r2;
    }
  }
}

// Outward triangles on the sphere appear clockwise in the plane of the north-pole
// stereographic projection; flip x when the majority is counter-clockwise.
void make_downward(const Eigen::MatrixXi& F, Plane& uv) {
  double s = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector2d a = uv.row(F(f, 0)), b = uv.row(F(f, 1)), c = uv.row(F(f, 2));
    const double det = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (std::isfinite(det)) s += det > 0 ? 1 : -1;
  }
  if (s > 0) uv.col(0) *= -1;
}

void normalize_median(Plane& uv) {
  std::vector<double> r(uv.rows());
  for (Eigen::Index i = 0; i < uv.rows(); ++i) r[i] = uv.row(i).norm();
  std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
  const double med = r[r.size() / 2];
  if (med > 0 && std::isfinite(med)) uv /= med;
}

// Solves L_II x_I = -L_IB x_B for rows with inner[i], in place.
void solve_inner(const Eigen::SparseMatrix<double>& L, const std::vector<char>& inner, Plane& uv) {
  const Eigen::Index n = L.rows();
  std::vector<int> idx(n, -1);
  int nI = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    if (inner[i]) idx[i] = nI++;
  if (nI == 0) return;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(L.nonZeros());
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(nI, uv.cols());
  for (Eigen::Index c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it) {
      const int r = int(it.row());
      if (idx[r] < 0) continue;
      if (idx[c] >= 0)
        trip.emplace_back(idx[r], idx[c], it.value());
      else
        rhs.row(idx[r]) -= it.value() * uv.row(c);
    }
  Eigen::SparseMatrix<double> A(nI, nI);
  A.setFromTriplets(trip.begin(), trip.end());
  SparseCholesky chol;
  chol.compute(A);
  const Eigen::MatrixXd x = chol.solve(rhs);
  for (Eigen::Index i = 0; i < n; ++i)
    if (idx[i] >= 0) uv.row(i) = x.row(idx[i]);
}

struct Stage {
  Plane uv;
  Eigen::MatrixXd S;
  double E = 0;
  int folded = 0;
};

}  // namespace

int spherical_folded_faces(const Eigen::MatrixXd& S, const Eigen::MatrixXi& F) {
  int k = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = S.row(F(f, 0)), b = S.row(F(f, 1)), c = S.row(F(f, 2));
    if (!(a.dot(b.cross(c)) > 0)) ++k;
  }
  return k;
}

SphereParamResult spherical_area_preserving_map(const TriMesh& surface,
                                                const Eigen::VectorXd& face_weights,
                                                const SphereParamOptions& opt,
                                                const ProgressCallback& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::MatrixXd& V = surface.V;
  const Eigen::MatrixXi& F = surface.F;
  const Eigen::Index n = V.rows(), m = F.rows();
  if (n < 4 || m < 4 || F.cols() != 3)
    throw InputError("spherical map: the surface needs at least 4 vertices and 4 faces");
  if (face_weights.size() != 0 && face_weights.size() != m)
    throw InputError("spherical map: face_weights must have one entry per face");
  SphereParamResult res;

  // ---- 1. Linear map: puncture the most regular face (Yueh et al., Sphere.Linear).
  const Eigen::VectorXd A0 = areas3(V, F);
  Eigen::Index best = 0;
  double bestq = -1;
  for (Eigen::Index f = 0; f < m; ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const double l2 = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
    const double q = l2 > 0 ? 4 * std::sqrt(3.0) * A0(f) / l2 : 0;  // 1 = equilateral
    if (q > bestq) {
      bestq = q;
      best = f;
    }
  }
  if (!(bestq > 0)) throw InputError("spherical map: all faces are degenerate");
  const Eigen::SparseMatrix<double> Lc = weighted_cotan(V, F, nullptr);
  Plane uv = Plane::Zero(n, 2);
  {
    const int ia = F(best, 0), ib = F(best, 1), ic = F(best, 2);
    const Eigen::Vector3d A = V.row(ia), B = V.row(ib), C = V.row(ic);
    const double alpha = (C - A).dot(B - A) / (B - A).squaredNorm();
    const Eigen::Vector3d E = A + alpha * (B - A);
    const double nBA = (B - A).norm(), nCE = (C - E).norm();
    uv.row(ia) << -1.0 / nBA, (1 - alpha) / nCE;
    uv.row(ib) << 1.0 / nBA, alpha / nCE;
    uv.row(ic) << 0.0, -1.0 / nCE;
    std::vector<char> inner(n, 1);
    inner[ia] = inner[ib] = inner[ic] = 0;
    solve_inner(Lc, inner, uv);
    make_downward(F, uv);
    uv.rowwise() -= uv.colwise().mean();
    normalize_median(uv);
  }
  Stage cur;
  cur.uv = uv;
  cur.S = inverse_stereographic(uv);
  cur.E = energy_minus_area(Lc, cur.S, F);
  cur.folded = spherical_folded_faces(cur.S, F);
  report(progress, "ball/sphere-map", 0.05);

  // One hemisphere-alternation step (CEM and SEM share it).
  auto step = [&](const Eigen::SparseMatrix<double>& L, double R, const Stage& from) {
    Stage s;
    s.uv = from.uv;
    invert(s.uv);
    std::vector<char> inner(n, 0);
    for (Eigen::Index i = 0; i < n; ++i) inner[i] = s.uv.row(i).norm() < R;
    solve_inner(L, inner, s.uv);
    normalize_median(s.uv);
    make_downward(F, s.uv);
    s.S = inverse_stereographic(s.uv);
    s.folded = spherical_folded_faces(s.S, F);
    return s;
  };

  // ---- 2. Conformal energy minimization (fixed cotangent Laplacian of the surface).
  for (int it = 0; it < opt.conformal_iterations; ++it) {
    Stage s = step(Lc, opt.conformal_radius, cur);
    s.E = energy_minus_area(Lc, s.S, F);
    if (!(s.E < cur.E) || s.folded > cur.folded) break;
    const double dE = cur.E - s.E;
    cur = std::move(s);
    res.conformal_iterations = it + 1;
    report(progress, "ball/sphere-map", 0.05 + 0.25 * (it + 1) / opt.conformal_iterations);
    if (dE < opt.conformal_tolerance) break;
  }
  res.conformal_energy = cur.E;

  // ---- 3. Stretch energy minimization (Yueh et al. 2019).
  Eigen::VectorXd target = face_weights.size() ? face_weights : A0;
  target /= target.sum();
  auto stretch_laplacian = [&](const Eigen::MatrixXd& S) {
    Eigen::VectorXd As = areas3(S, F);
    As /= As.sum();
    Eigen::VectorXd sigma(m);
    for (Eigen::Index f = 0; f < m; ++f) sigma(f) = As(f) > 0 ? target(f) / As(f) : 0.0;
    return weighted_cotan(S, F, &sigma);
  };
  Eigen::SparseMatrix<double> Ls = stretch_laplacian(cur.S);
  cur.E = energy_minus_area(Ls, cur.S, F);
  res.stretch_energy_initial = cur.E;
  for (int it = 0; it < opt.stretch_iterations; ++it) {
    Stage s = step(Ls, opt.stretch_radius, cur);
    Eigen::SparseMatrix<double> Ln = stretch_laplacian(s.S);
    s.E = energy_minus_area(Ln, s.S, F);
    if (!(s.E < cur.E) || s.folded > cur.folded) break;
    const double rel = (cur.E - s.E) / std::max(1e-300, std::abs(cur.E));
    cur = std::move(s);
    Ls = std::move(Ln);
    res.stretch_iterations = it + 1;
    report(progress, "ball/sphere-map", 0.3 + 0.7 * (it + 1) / opt.stretch_iterations);
    if (rel < opt.stretch_tolerance) break;
  }
  res.stretch_energy = cur.E;
  res.S = cur.S;
  res.S.rowwise().normalize();
  res.folded_faces = spherical_folded_faces(res.S, F);
  report(progress, "ball/sphere-map", 1.0);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace shapemap
