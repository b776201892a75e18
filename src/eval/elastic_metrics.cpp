// Sec. 6.1 distortion metrics of elastic correspondence. See eval/surface_distortion.h.
#include "shapemap/eval/surface_distortion.h"

#include "shapemap/error.h"
#include "shapemap/geometry/curvature.h"
#include "shapemap/geometry/mass.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace shapemap {

namespace {

double median(Eigen::VectorXd v) {
  if (v.size() == 0) return 0;
  std::vector<double> s(v.data(), v.data() + v.size());
  const size_t k = s.size() / 2;
  std::nth_element(s.begin(), s.begin() + k, s.end());
  double m = s[k];
  if (s.size() % 2 == 0) m = 0.5 * (m + *std::max_element(s.begin(), s.begin() + k));
  return m;
}

void check_map(const TriMesh& S, const TriMesh& T, const BarycentricMap& P, const char* name) {
  validate_map(P, S.num_vertices(), T.num_faces(), 3, name);
}

// A per-face quantity of the map X -> Y (faces in parallel): value(e1, e2, d1, d2) of the
// edge vectors x1 - x0, x2 - x0 of a face and their images under the map.
template <class Value>
Eigen::VectorXd per_face(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const Eigen::MatrixXi& F,
                         Value value) {
  const int m = int(F.rows());
  Eigen::VectorXd out(m);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < m; ++f) {
    const Eigen::Vector3d x0 = X.row(F(f, 0)), e1 = Eigen::Vector3d(X.row(F(f, 1))) - x0,
                          e2 = Eigen::Vector3d(X.row(F(f, 2))) - x0;
    const Eigen::Vector3d y0 = Y.row(F(f, 0)), d1 = Eigen::Vector3d(Y.row(F(f, 1))) - y0,
                          d2 = Eigen::Vector3d(Y.row(F(f, 2))) - y0;
    out(f) = value(e1, e2, d1, d2);
  }
  return out;
}

}  // namespace

double face_conformal_distortion(const Eigen::Vector3d& e1, const Eigen::Vector3d& e2, const Eigen::Vector3d& d1,
                                 const Eigen::Vector3d& d2) {
  const double G00 = e1.dot(e1), G01 = e1.dot(e2), G11 = e2.dot(e2);
  const double detG = e1.cross(e2).squaredNorm();
  const double g00 = d1.dot(d1), g01 = d1.dot(d2), g11 = d2.dot(d2);
  const double detg = d1.cross(d2).squaredNorm();
  if (!(detG > 0)) return std::numeric_limits<double>::quiet_NaN();
  // tr(G^-1 g) and det(G^-1 g) = detg/detG; MIPS = tr / sqrt(det) = s1/s2 + s2/s1
  const double tr = (G11 * g00 - 2 * G01 * g01 + G00 * g11) / detG;
  const double det = detg / detG;
  return det > 0 ? std::max(0.0, tr / std::sqrt(det) - 2.0) : std::numeric_limits<double>::infinity();
}

Eigen::VectorXd conformal_distortion(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                                     const Eigen::MatrixXi& F) {
  return per_face(X, Y, F, face_conformal_distortion);
}

Eigen::VectorXd area_distortion(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                                const Eigen::MatrixXi& F) {
  return per_face(X, Y, F, [](const Eigen::Vector3d& e1, const Eigen::Vector3d& e2, const Eigen::Vector3d& d1,
                              const Eigen::Vector3d& d2) {
    return std::log(d1.cross(d2).norm() / e1.cross(e2).norm());
  });
}

namespace {
// The target normal at P's point i that is the most aligned with n: the normal of its face, or
// of a face around the vertex / across the edge it lies on (barycentric tolerance 1e-6).
Eigen::Vector3d best_normal(const Eigen::Vector3d& n, int i, const Eigen::MatrixXd& Nt, const Eigen::MatrixXi& Ft,
                            const BarycentricMap& P, const VertexElementsCsr& vf) {
  constexpr double kAt = 1e-6;
  const int t = P.elem(i);
  int kmax = 0, kmin = 0;
  for (int k = 1; k < 3; ++k) {
    if (P.bary(i, k) > P.bary(i, kmax)) kmax = k;
    if (P.bary(i, k) < P.bary(i, kmin)) kmin = k;
  }
  int best = t;
  auto consider = [&](int g) {
    if (n.dot(Nt.row(g).transpose()) > n.dot(Nt.row(best).transpose())) best = g;
  };
  if (P.bary(i, kmax) >= 1 - kAt) {  // at a vertex: every face around it
    const int v = Ft(t, kmax);
    for (int q = vf.start[v]; q < vf.start[v + 1]; ++q) consider(vf.elems[q]);
  } else if (P.bary(i, kmin) <= kAt) {  // on the edge opposite kmin: also the face across it
    const int a = Ft(t, (kmin + 1) % 3), b = Ft(t, (kmin + 2) % 3);
    for (int q = vf.start[a]; q < vf.start[a + 1]; ++q) {
      const int g = vf.elems[q];
      if (Ft(g, 0) == b || Ft(g, 1) == b || Ft(g, 2) == b) consider(g);
    }
  }
  return Nt.row(best).transpose();
}
}  // namespace

int fold_class(int f, const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, const Eigen::MatrixXd& Y,
               const Eigen::MatrixXd& Nt, const Eigen::MatrixXi& Ft, const BarycentricMap& P, double degenerate_tol,
               const VertexElementsCsr& target_vertex_faces) {
  const Eigen::Vector3d x0 = X.row(F(f, 0)), y0 = Y.row(F(f, 0)), y1 = Y.row(F(f, 1)), y2 = Y.row(F(f, 2));
  const double a0 = (Eigen::Vector3d(X.row(F(f, 1))) - x0).cross(Eigen::Vector3d(X.row(F(f, 2))) - x0).norm();
  const Eigen::Vector3d n = (y1 - y0).cross(y2 - y0);
  // the same expression as area_distortion, so that the counts agree bit for bit; the log
  // (the elastic loop counts folds every outer iteration) only near the threshold, where
  // rounding could make the two tests differ
  const double r = n.norm() / a0;
  const bool collapsed = degenerate_tol > 0 && r > 2 * degenerate_tol   ? false
                         : degenerate_tol > 0 && r < 0.5 * degenerate_tol ? true
                                                                         : !(std::log(r) > std::log(degenerate_tol));
  if (collapsed) return 2;
  Eigen::Vector3d nt = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j) nt += best_normal(n, F(f, j), Nt, Ft, P, target_vertex_faces);
  return n.dot(nt) < 0 ? 1 : 0;
}

FoldCounts fold_counts(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, const Eigen::MatrixXd& Y,
                       const Eigen::MatrixXd& Nt, const Eigen::MatrixXi& Ft, const BarycentricMap& P,
                       double degenerate_tol, std::vector<unsigned char>* faces,
                       const VertexElementsCsr* target_vertex_faces) {
  const int m = int(F.rows());
  if (faces) faces->assign(m, 0);
  VertexElementsCsr own;
  if (!target_vertex_faces) own = vertex_elements_csr(Ft, Ft.rows() ? int(Ft.maxCoeff()) + 1 : 0);
  const VertexElementsCsr& vf = target_vertex_faces ? *target_vertex_faces : own;
  // The elastic loop counts folds 4 times per outer iteration: in parallel from 16,384 faces
  // (10k-vertex meshes; integer counts, so the result does not depend on it).
  int flipped = 0, degenerate = 0;
#pragma omp parallel for schedule(static) reduction(+ : flipped, degenerate) if (m >= (1 << 14))
  for (int f = 0; f < m; ++f) {
    const int c = fold_class(f, X, F, Y, Nt, Ft, P, degenerate_tol, vf);
    flipped += c == 1;
    degenerate += c == 2;
    if (faces) (*faces)[f] = static_cast<unsigned char>(c);
  }
  FoldCounts counts;
  counts.flipped = flipped;
  counts.degenerate = degenerate;
  return counts;
}

SurfaceDistortion surface_distortion(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                                     const SurfaceDistortionOptions& opt) {
  check_map(S, T, P, "surface_distortion: map");
  Eigen::MatrixXd X = S.V, Xt = T.V;
  if (opt.normalize_area) {
    X = unit_area_normalization(S).apply(S.V);
    Xt = unit_area_normalization(T).apply(T.V);
  }
  const Eigen::MatrixXd Y = map_positions(P, Xt, T.F);
  SurfaceDistortion d;
  const int m = S.num_faces();
  d.conformal = conformal_distortion(X, Y, S.F);
  d.area = area_distortion(X, Y, S.F);
  const double lo = std::log(opt.min_area_ratio), hi = -lo;
  // target surface normal at a mapped point: the normal of the face it lies in
  const FoldCounts folds = fold_counts(X, S.F, Y, face_normals(Xt, T.F), T.F, P, opt.degenerate_tol);
  d.flipped = folds.flipped;
  d.degenerate = folds.degenerate;
  for (int f = 0; f < m; ++f) {
    double& c = d.conformal(f);
    if (!(c <= opt.conformal_cap)) c = opt.conformal_cap;  // also NaN (degenerate source)
    double& a = d.area(f);
    if (!(a >= lo)) a = lo;
    if (a > hi) a = hi;
  }
  if (m > 0) {
    d.conformal_mean = d.conformal.mean();
    d.conformal_median = median(d.conformal);
    d.area_mean_abs = d.area.cwiseAbs().mean();
    d.area_median_abs = median(d.area.cwiseAbs());
  }
  d.mean_curvature_error = mean_curvature_error(S, T, P, opt.normalize_area);
  return d;
}

double mean_curvature_error(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                            bool normalize_area) {
  check_map(S, T, P, "mean_curvature_error: map");
  Eigen::MatrixXd X = S.V, Xt = T.V;
  if (normalize_area) {
    X = unit_area_normalization(S).apply(S.V);
    Xt = unit_area_normalization(T).apply(T.V);
  }
  const Eigen::VectorXd H = mean_curvature(X, S.F);
  const Eigen::VectorXd Ht = mean_curvature(Xt, T.F);
  const Eigen::VectorXd M = lumped_mass(X, S.F);
  double s = 0;
  for (int i = 0; i < P.size(); ++i) {
    const int f = P.elem(i);
    const double h = P.bary(i, 0) * Ht(T.F(f, 0)) + P.bary(i, 1) * Ht(T.F(f, 1)) +
                     P.bary(i, 2) * Ht(T.F(f, 2));
    const double r = h - H(i);
    if (std::isfinite(r)) s += M(i) * r * r;
  }
  return std::sqrt(s);
}

double reversibility_error(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                           const BarycentricMap& Q, bool normalize_area) {
  check_map(S, T, P, "reversibility_error: map P");
  check_map(T, S, Q, "reversibility_error: map Q");
  Eigen::MatrixXd X = S.V;
  if (normalize_area) X = unit_area_normalization(S).apply(S.V);
  const Eigen::MatrixXd QX = map_positions(Q, X, S.F);       // T vertices -> points on S
  const Eigen::MatrixXd PQX = map_positions(P, QX, T.F);     // S vertices -> back on S
  const Eigen::VectorXd M = lumped_mass(X, S.F);
  double s = 0;
  for (int i = 0; i < X.rows(); ++i) s += M(i) * (PQX.row(i) - X.row(i)).squaredNorm();
  return std::sqrt(s);
}

Eigen::VectorXd round_trip_bbox(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                                const BarycentricMap& Q) {
  check_map(S, T, P, "round_trip_bbox: map P");
  check_map(T, S, Q, "round_trip_bbox: map Q");
  const Eigen::MatrixXd PQX = map_positions(P, map_positions(Q, S.V, S.F), T.F);
  const double diag = (S.V.colwise().maxCoeff() - S.V.colwise().minCoeff()).norm();
  return (PQX - S.V).rowwise().norm() / (diag > 0 ? diag : 1.0);
}

}  // namespace shapemap
