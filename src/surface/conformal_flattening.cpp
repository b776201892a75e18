// Cotangent dipole flattening of genus-0 surfaces, lifted to the Riemann sphere.
#include "shapemap/surface/conformal_flattening.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include "shapemap/mesh.h"
#include "shapemap/surface/mobius.h"
#include <algorithm>
#include <cmath>
#include <vector>

namespace shapemap {

double spherical_triangle_area(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c) {
  // a . ((b - a) x (c - a)) = det[a, b, c], precise for tiny faces (unlike a . (b x c)).
  double num = std::abs(a.dot((b - a).cross(c - a)));
  double den = 1 + a.dot(b) + b.dot(c) + c.dot(a);
  return 2 * std::atan2(num, den);
}

Eigen::MatrixXd dipole_flattening(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int pole,
                                  bool drop_negative) {
  const int n = int(V.rows());
  if (pole < 0 || pole >= F.rows()) throw Error("dipole flattening: pole face out of range");
  Eigen::SparseMatrix<double> L = cotan_laplacian(V, F);
  if (drop_negative) L = drop_negative_weights(L);
  const int A = F(pole, 0), B = F(pole, 1), C = F(pole, 2);
  Eigen::Vector3d pa = V.row(A).transpose(), pb = V.row(B).transpose(), pc = V.row(C).transpose();
  double lab = (pb - pa).norm();
  double theta = (pc - pa).dot(pb - pa) / (lab * lab);
  Eigen::Vector3d E = pa + theta * (pb - pa);
  double hce = (pc - E).norm();
  if (!(lab > 0) || !(hce > 0)) throw Error("dipole flattening: degenerate pole face");
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n, 2);
  b(A, 0) = -1 / lab;
  b(B, 0) = 1 / lab;
  b(A, 1) = (1 - theta) / hce;
  b(B, 1) = theta / hce;
  b(C, 1) = -1 / hce;
  // Pin one vertex away from the pole (L has the constants as kernel; b sums to 0).
  int pin = 0;
  while (pin == A || pin == B || pin == C) ++pin;
  std::vector<int> idx(n, -1);
  int k = 0;
  for (int i = 0; i < n; ++i)
    if (i != pin) idx[i] = k++;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(L.nonZeros());
  for (int col = 0; col < L.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, col); it; ++it) {
      int r = idx[it.row()], c = idx[it.col()];
      if (r >= 0 && c >= 0) trip.emplace_back(r, c, it.value());
    }
  Eigen::SparseMatrix<double> Lr(n - 1, n - 1);
  Lr.setFromTriplets(trip.begin(), trip.end());
  Eigen::MatrixXd br(n - 1, 2);
  for (int i = 0; i < n; ++i)
    if (idx[i] >= 0) br.row(idx[i]) = b.row(i);
  SparseCholesky chol;
  chol.compute(Lr);
  Eigen::MatrixXd xr = chol.solve(br);
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, 2);
  for (int i = 0; i < n; ++i)
    if (idx[i] >= 0) X.row(i) = xr.row(idx[i]);
  if (!X.allFinite()) throw Error("dipole flattening: solve produced non-finite values");
  return X;
}

Eigen::VectorXd angle_distortion(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                 const Eigen::MatrixXd& X, int skip) {
  auto angles = [](const Eigen::MatrixXd& P, const Eigen::RowVector3i& f) {
    Eigen::Vector3d out;
    for (int k = 0; k < 3; ++k) {
      Eigen::VectorXd a = P.row(f(k)).transpose(), b = P.row(f((k + 1) % 3)).transpose(),
                      c = P.row(f((k + 2) % 3)).transpose();
      Eigen::VectorXd u = b - a, v = c - a;
      double cosv = u.dot(v) / std::max(1e-300, u.norm() * v.norm());
      out(k) = std::acos(std::clamp(cosv, -1.0, 1.0));
    }
    return out;
  };
  Eigen::VectorXd d = Eigen::VectorXd::Zero(F.rows());
#pragma omp parallel for
  for (int f = 0; f < int(F.rows()); ++f) {
    if (f == skip) continue;
    Eigen::RowVector3i fi = F.row(f);
    d(f) = (angles(V, fi) - angles(X, fi)).cwiseAbs().mean();
  }
  return d;
}

namespace {

// One dipole map, lifted, centred and measured (conformal_flattening below picks the weights).
ConformalFlattening flatten_once(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                 const ConformalFlatteningOptions& opt, bool drop_negative) {
  const int n = int(V.rows()), m = int(F.rows());
  ConformalFlattening out;
  out.pole_face = opt.pole_face >= 0 ? opt.pole_face : 0;
  out.plane = dipole_flattening(V, F, out.pole_face, drop_negative);
  out.dropped_negative_weights = drop_negative;
  // Normalize the planar scale (median distance to the area-weighted centre) so the
  // sphere lift is well conditioned before the Möbius centering.
  Eigen::VectorXd mass = lumped_mass(V, F);
  mass /= mass.sum();
  Eigen::RowVector2d c0 = Eigen::RowVector2d::Zero();
  {
    // The median point (coordinatewise) is robust to the large coordinates near the pole.
    std::vector<double> xs(n), ys(n);
    for (int i = 0; i < n; ++i) xs[i] = out.plane(i, 0), ys[i] = out.plane(i, 1);
    std::nth_element(xs.begin(), xs.begin() + n / 2, xs.end());
    std::nth_element(ys.begin(), ys.begin() + n / 2, ys.end());
    c0 << xs[n / 2], ys[n / 2];
  }
  std::vector<double> r(n);
  for (int i = 0; i < n; ++i) r[i] = (out.plane.row(i) - c0).norm();
  std::nth_element(r.begin(), r.begin() + n / 2, r.end());
  double scale = r[n / 2] > 0 ? 1.0 / r[n / 2] : 1.0;
  out.sphere.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    Homogeneous h;
    h.u = Complex((out.plane(i, 0) - c0(0)) * scale, (out.plane(i, 1) - c0(1)) * scale);
    out.sphere.row(i) = sphere_from_plane(h).transpose();
  }
  // Orientation: faces CCW seen from outside (the stereographic lift reverses the
  // orientation of the plane; the sign of the dipole depends on conventions).
  auto orientation_sum = [&](const Eigen::MatrixXd& S) {
    double pos = 0, neg = 0;
    for (int f = 0; f < m; ++f) {
      if (f == out.pole_face) continue;
      Eigen::Vector3d a = S.row(F(f, 0)), b = S.row(F(f, 1)), c = S.row(F(f, 2));
      double t = a.dot((b - a).cross(c - a));
      (t > 0 ? pos : neg) += std::abs(t);
    }
    return pos - neg;
  };
  if (orientation_sum(out.sphere) < 0) {
    out.sphere.col(1) *= -1;  // complex conjugation
    out.plane.col(1) *= -1;
  }
  // Möbius centering: x -> (1-|c|²)(x - c)/|x - c|² - c expands around the area
  // centroid c until the centroid is at the origin.
  if (opt.center) {
    for (int it = 0; it < opt.centering_iterations; ++it) {
      Eigen::RowVector3d c = (mass.asDiagonal() * out.sphere).colwise().sum();
      out.centroid_norm = c.norm();
      if (c.norm() < opt.centering_tolerance) break;
      if (c.norm() > 0.5) c *= 0.5 / c.norm();  // damped far from the centre
      double c2 = c.squaredNorm();
      for (int i = 0; i < n; ++i) {
        Eigen::RowVector3d y = out.sphere.row(i) - c;
        Eigen::RowVector3d x = (1 - c2) * y / y.squaredNorm() - c;
        out.sphere.row(i) = x.normalized();
      }
    }
    Eigen::RowVector3d c = (mass.asDiagonal() * out.sphere).colwise().sum();
    out.centroid_norm = c.norm();
  }
  // Per-vertex area factor over the one-ring (Eq. 2 uses areas of neighbourhoods).
  Eigen::VectorXd sa(n), ma(n);
  sa.setZero();
  ma.setZero();
  Eigen::VectorXd fa = triangle_areas(V, F);
  out.flipped_faces = 0;
  for (int f = 0; f < m; ++f) {
    Eigen::Vector3d a = out.sphere.row(F(f, 0)), b = out.sphere.row(F(f, 1)), c = out.sphere.row(F(f, 2));
    double s = spherical_triangle_area(a, b, c);
    if (a.dot((b - a).cross(c - a)) < 0) ++out.flipped_faces;
    for (int k = 0; k < 3; ++k) {
      sa(F(f, k)) += s;
      ma(F(f, k)) += fa(f);
    }
  }
  out.area_factor.resize(n);
  for (int i = 0; i < n; ++i) out.area_factor(i) = ma(i) > 0 ? sa(i) / ma(i) : 1.0;
  return out;
}

}  // namespace

ConformalFlattening conformal_flattening(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                         const ConformalFlatteningOptions& opt) {
  // The cotangent weights are the conformal ones; where the mesh is not Delaunay some are
  // negative, the discrete maximum principle fails and on thin parts the dipole map folds
  // (camel-gallop-03: 1,312 of 10,000 faces, also in a long-double solve). Without the
  // negative weights it cannot fold that way, but it is less conformal where they were
  // (an ellipsoid stretched from a sphere mesh: 11.7 degrees mean angle error instead of
  // under 2.5), so they are dropped only when the cotangent map folds.
  ConformalFlattening out = flatten_once(V, F, opt, false);
  if (out.flipped_faces == 0) return out;
  ConformalFlattening dropped = flatten_once(V, F, opt, true);
  dropped.cotan_flipped_faces = out.flipped_faces;
  if (dropped.flipped_faces < out.flipped_faces) return dropped;
  out.cotan_flipped_faces = out.flipped_faces;
  return out;
}

}  // namespace shapemap
