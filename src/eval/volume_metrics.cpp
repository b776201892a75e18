// Volume map metrics: symmetric-volume-maps Sec. 6.1, Eqs. 18, 20, 27, 28.
#include "shapemap/eval/volume_metrics.h"
#include "shapemap/error.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/geometry/svd3.h"
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace shapemap {

namespace {

// Sec. 6.1 and Eq. 20, per source tet k with its Jacobian J_k (unit-volume frames): whether
// it is inverted (det J <= 0), |det J^| with J^ = J with unit columns, and
// f_ARAP = sum (sigma - 1)^2 (Eq. 19); then n_inv, E_ARAP and the volume-weighted mean and
// SD of |det J^|. Vs, Xn: source vertices and their images, each in its unit-volume frame.
void jacobian_distortion(const TetMesh& source, const Eigen::MatrixXd& Vs, const Eigen::MatrixXd& Xn,
                         VolumeMapMetrics& r) {
  const int m = source.num_tets();
  Eigen::VectorXd vol(m), detn(m), farap(m);
  Eigen::VectorXi inv(m);
#pragma omp parallel for schedule(static)
  for (int k = 0; k < m; ++k) {
    Eigen::Matrix3d Dm, Ds;
    for (int j = 0; j < 3; ++j) {
      Dm.col(j) = (Vs.row(source.T(k, j + 1)) - Vs.row(source.T(k, 0))).transpose();
      Ds.col(j) = (Xn.row(source.T(k, j + 1)) - Xn.row(source.T(k, 0))).transpose();
    }
    vol(k) = std::abs(Dm.determinant()) / 6.0;
    double dd = Dm.determinant();
    Eigen::Matrix3d J = std::abs(dd) > 0 ? Eigen::Matrix3d(Ds * Dm.inverse()) : Eigen::Matrix3d::Zero();
    double dj = J.determinant();
    inv(k) = !(dj > 0);
    Eigen::Matrix3d Jn = J;
    bool ok = true;
    for (int j = 0; j < 3; ++j) {
      double l = J.col(j).norm();
      if (l > 0) Jn.col(j) /= l; else ok = false;
    }
    detn(k) = ok ? std::abs(Jn.determinant()) : 0.0;
    SignedSVD3 s = signed_svd3(J);
    farap(k) = (s.S.array() - 1.0).square().sum();
  }
  double V = 0, ea = 0, dm = 0;
  for (int k = 0; k < m; ++k) {
    V += vol(k);
    r.n_inv += inv(k);
    ea += vol(k) * farap(k);
    dm += vol(k) * detn(k);
  }
  r.inverted_fraction = m ? double(r.n_inv) / m : 0;
  r.E_arap = V > 0 ? ea / (2 * V) : 0;  // Eq. 20, c = V (= 1 up to rounding)
  r.det_mean = V > 0 ? dm / V : 0;
  double var = 0;
  for (int k = 0; k < m; ++k) var += vol(k) * (detn(k) - r.det_mean) * (detn(k) - r.det_mean);
  r.det_sd = V > 0 ? std::sqrt(var / V) : 0;
}

// Eqs. 27-28 between the mapped boundary X(dM_i) and dM_j, at vertices, over the target's
// bbox diagonal: d^_avg (both ways) and d^_max.
void boundary_distances(const TetBoundary& bs, const TetMesh& target, const Eigen::MatrixXd& X, double diag,
                        VolumeMapMetrics& r) {
  TetBoundary bt = boundary_surface(target);
  Eigen::MatrixXd Xb(bs.to_volume.size(), 3);
  for (int b = 0; b < Xb.rows(); ++b) Xb.row(b) = X.row(bs.to_volume(b));
  ClosestPoint3 to_target(bt.surface.V, bt.surface.F), to_mapped(Xb, bs.surface.F);
  std::vector<ClosestPointResult> r1 = to_target.query(Xb), r2 = to_mapped.query(bt.surface.V);
  double sum = 0, mx = 0;
  for (const std::vector<ClosestPointResult>* side : {&r1, &r2})
    for (const auto& q : *side) {
      double d = std::sqrt(std::max(0.0, q.sqdist));
      sum += d;
      mx = std::max(mx, d);
    }
  const double cnt = double(r1.size() + r2.size());
  r.d_avg = cnt > 0 && diag > 0 ? sum / cnt / diag : 0;
  r.d_max = diag > 0 ? mx / diag : 0;
}

// Eq. 18 term (i,j) in the source's unit-volume frame ns (Vs = ns(V_i)):
// 1/c_i^2 ||P_ij X_ji - V_i||^2_{M_i}, with the lumped tet mass of M_i; and where it sits.
void reversibility_energy(const TetMesh& source, const TetBoundary& bs, const TetMesh& target, const Normalization& ns,
                          const Eigen::MatrixXd& Vs, const BarycentricMap& P_ij, const Eigen::MatrixXd& X_ji,
                          VolumeMapMetrics& r) {
  const Eigen::VectorXd rt = round_trip_distances(source, target, P_ij, X_ji);
  const Eigen::VectorXd C = tet_lumped_mass(Vs, source.T);
  std::vector<char> on_boundary(size_t(source.num_vertices()), 0);
  for (Eigen::Index b = 0; b < bs.to_volume.size(); ++b) on_boundary[size_t(bs.to_volume(b))] = 1;
  const double c = C.sum();
  double e = 0, e_boundary = 0;
  for (Eigen::Index v = 0; v < rt.size(); ++v) {
    const double d = ns.scale * rt(v);  // the unit-volume frame is a scaled copy
    e += C(v) * d * d;
    if (on_boundary[size_t(v)]) e_boundary += C(v) * d * d;
  }
  r.E_R = e / (c * c);
  r.E_R_boundary_share = e > 0 ? e_boundary / e : 0;
  const double diag = bbox_diagonal(source.V);
  r.round_trip_max = rt.size() > 0 && diag > 0 ? rt.maxCoeff() / diag : 0;
  r.round_trip_avg = rt.size() > 0 && diag > 0 ? rt.mean() / diag : 0;
}

// Mean and largest |X - X_true| over the target's bbox diagonal.
void truth_error(const Eigen::MatrixXd& X, const Eigen::MatrixXd& truth, double diag, VolumeMapMetrics& r) {
  const int ni = int(X.rows());
  if (truth.rows() != ni || truth.cols() != 3)
    throw InputError("truth: " + std::to_string(truth.rows()) + " rows for " + std::to_string(ni) +
                     " source vertices");
  r.has_truth = true;
  double s = 0, mx2 = 0;
  for (int v = 0; v < ni; ++v) {
    double d = (X.row(v) - truth.row(v)).norm();
    s += d;
    mx2 = std::max(mx2, d);
  }
  r.truth_mean = diag > 0 ? s / ni / diag : 0;
  r.truth_max = diag > 0 ? mx2 / diag : 0;
}

}  // namespace

Eigen::VectorXd round_trip_distances(const TetMesh& source, const TetMesh& target, const BarycentricMap& P_ij,
                                     const Eigen::MatrixXd& X_ji) {
  const int ni = source.num_vertices();
  validate_map(P_ij, ni, target.num_tets(), 4, "map");
  if (X_ji.rows() != target.num_vertices() || X_ji.cols() != 3)
    throw InputError("reverse map: wrong number of rows");
  Eigen::VectorXd d(ni);
  for (int v = 0; v < ni; ++v) {
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int q = 0; q < 4; ++q) p += P_ij.bary(v, q) * X_ji.row(target.T(P_ij.elem(v), q));
    d(v) = (p - source.V.row(v)).norm();
  }
  return d;
}

VolumeMapMetrics volume_map_metrics(const TetMesh& source, const TetMesh& target,
                                    const Eigen::MatrixXd& X, const BarycentricMap* P_ij,
                                    const Eigen::MatrixXd* X_ji, const Eigen::MatrixXd* truth) {
  const int ni = source.num_vertices();
  if (X.rows() != ni || X.cols() != 3)
    throw InputError("map: " + std::to_string(X.rows()) + " images for " + std::to_string(ni) +
                     " source vertices");
  VolumeMapMetrics r;
  r.num_tets = source.num_tets();
  const double diag = bbox_diagonal(target.V);
  Normalization ns = unit_volume_normalization(source), nt = unit_volume_normalization(target);
  Eigen::MatrixXd Vs = ns.apply(source.V), Xn = nt.apply(X);
  jacobian_distortion(source, Vs, Xn, r);
  const TetBoundary bs = boundary_surface(source);
  boundary_distances(bs, target, X, diag, r);
  if (P_ij && X_ji) reversibility_energy(source, bs, target, ns, Vs, *P_ij, *X_ji, r);
  if (truth) truth_error(X, *truth, diag, r);
  return r;
}

}  // namespace shapemap
